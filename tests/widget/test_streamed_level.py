"""A multiscale layer's full level rendered band by band into a pyramid on disk, without Qt.

A small memory budget (``NAPARI_LABYRINTH_MEMORY``) makes a 512 x 700 full
level too large to render in memory: Run renders it in bands of rows, read
from the layer's array (numpy, dask, zarr), and writes each band to the full
level and, halved, to the levels below; the levels are bit for bit those of
``labyrinth()`` in memory and :func:`lower_levels` of its result.
"""

from __future__ import annotations

import os
import tempfile

import numpy as np
import pytest

zarr = pytest.importorskip("zarr")
da = pytest.importorskip("dask.array")

from napari_labyrinth import api
from napari_labyrinth._budget import MEMORY_ENV, refusal
from napari_labyrinth.core.presets import resolve_parameters
from napari_labyrinth.io.bands import array_plane_bands
from napari_labyrinth.widget.choices import Choices, LayerSnapshot
from napari_labyrinth.widget.layer_kwargs import METADATA_KEY
from napari_labyrinth.widget.multiscale import lower_levels
from napari_labyrinth.widget.plan import make_plan
from napari_labyrinth.widget.plane_store import STORE_PREFIX
from napari_labyrinth.widget.pyramid_store import CHUNK_COLUMNS, PyramidStore
from napari_labyrinth.widget.run import result_layer
from napari_labyrinth.widget.streamed_level import band_rows, streams

from .. import textures
from .plan_helpers import drive

SHAPE = (512, 700)
#: Too little memory for the 512 x 700 level in memory, enough for bands of a few chunks.
BUDGET = "1500K"
CHUNK_ROWS = 16


def smooth(dtype, shape=SHAPE, seed=0) -> np.ndarray:
    return textures.smooth(dtype, shape, seed)


def limits(image) -> tuple[float, float]:
    return float(image.min()), float(image.max())


def snapshot_of(full, count=3, **fields) -> LayerSnapshot:
    """A multiscale layer of ``count`` levels over ``full`` (a numpy, dask or zarr array)."""
    levels = [full, *lower_levels(np.asarray(full), count, False)]
    fields.setdefault("contrast_limits", limits(np.asarray(full)))
    return LayerSnapshot.of(levels, name="cam", multiscale=True, **fields)


@pytest.fixture
def small_budget(monkeypatch):
    monkeypatch.setenv(MEMORY_ENV, BUDGET)


@pytest.fixture
def stores(monkeypatch, tmp_path):
    """The stores' directory (the system's temporary directory, for these tests)."""
    monkeypatch.setattr(tempfile, "tempdir", str(tmp_path))
    return tmp_path


def store_dirs(directory) -> list[str]:
    return sorted(name for name in os.listdir(directory) if name.startswith(STORE_PREFIX))


def in_memory(image, **arguments) -> np.ndarray:
    """``labyrinth()`` of the whole level, with the memory it needs."""
    budget = os.environ.pop(MEMORY_ENV, None)
    try:
        return api.labyrinth(image, **arguments)
    finally:
        if budget is not None:
            os.environ[MEMORY_ENV] = budget


@pytest.mark.parametrize("dtype", [np.uint8, np.uint16, np.float32])
@pytest.mark.parametrize("preset", ["labyrinth", "paper"])
def test_a_level_too_large_for_memory_renders_band_by_band_bit_for_bit(
    small_budget, stores, dtype, preset
):
    image = smooth(dtype, seed=2)
    assert refusal(image.shape, image.dtype) is not None  # in memory: refused here
    full = zarr.create_array(store=str(stores / "in.zarr"), shape=SHAPE,
                             chunks=(CHUNK_ROWS, SHAPE[1]), dtype=dtype)  # fmt: skip
    full[...] = image
    plan = make_plan(snapshot_of(full), Choices(preset=preset, seed=7))
    assert plan.streamed is not None and plan.levels == 3
    steps, outcome = drive(plan)
    assert steps == list(range(1, plan.total_steps + 1)) and plan.total_steps > 4
    data, kwargs = result_layer(plan, outcome)
    expected = in_memory(image, **plan.arguments)
    np.testing.assert_array_equal(data[0][...], expected)
    for level, made in zip(data[1:], lower_levels(expected, 3, False), strict=True):
        np.testing.assert_array_equal(level[...], made)
    record = kwargs["metadata"][METADATA_KEY]
    assert record["band_by_band"] is True and kwargs["multiscale"] is True
    _, diagnostics = in_memory(image, **plan.arguments, return_diagnostics=True)
    np.testing.assert_array_equal(outcome.diagnostics, diagnostics)


class Recorded:
    """A 2-D array that records the rows of every read (as a zarr array is read)."""

    def __init__(self, image, chunk_rows):
        self.image, self.shape, self.dtype = image, image.shape, image.dtype
        self.chunks = (chunk_rows, image.shape[1])
        self.reads = []

    def __getitem__(self, key):
        rows = key[0] if isinstance(key, tuple) else key
        start, stop, _ = rows.indices(self.shape[0])
        self.reads.append((start, stop))
        return self.image[key]


def test_the_level_is_read_by_bands_never_whole(small_budget, stores):
    image = smooth(np.uint16, seed=4)
    level = Recorded(image, CHUNK_ROWS)
    plan = make_plan(snapshot_of(image), Choices(seed=1))
    plan.data = level  # read as the run reads the layer's full level
    rows = band_rows(array_plane_bands(level, "cam"), plan.streamed, plan.levels)
    assert rows % CHUNK_ROWS == 0 and rows % 4 == 0 and rows <= SHAPE[0] // 4
    _, outcome = drive(plan)
    data, _ = result_layer(plan, outcome)
    np.testing.assert_array_equal(data[0][...], in_memory(image, **plan.arguments))
    assert max(stop - start for start, stop in level.reads) <= rows
    # the noise gate's one sweep (its estimate: core/_noise_loops.py) and the rendering's
    read = np.zeros(SHAPE[0], int)
    for start, stop in level.reads:
        read[start:stop] += 1
    assert np.all(read == 2), np.unique(read, return_counts=True)


def test_a_dask_level_renders_as_its_array(small_budget, stores):
    image = smooth(np.uint16, seed=4)
    blocks = []

    def counted(block, block_info=None):
        blocks.append(tuple(block_info[0]["array-location"][0]))
        return block

    lazy = da.from_array(image, chunks=(CHUNK_ROWS, 350)).map_blocks(counted, dtype=image.dtype)
    plan = make_plan(snapshot_of(image), Choices(seed=1))
    plan.data = lazy
    blocks.clear()
    _, outcome = drive(plan)
    data, _ = result_layer(plan, outcome)
    np.testing.assert_array_equal(data[0][...], in_memory(image, **plan.arguments))
    chunks = 2 * SHAPE[0] // CHUNK_ROWS
    assert set(blocks) == {(start, start + CHUNK_ROWS) for start in range(0, SHAPE[0], CHUNK_ROWS)}
    assert len(blocks) <= 4 * chunks  # each chunk a few times, not once per row


def test_odd_sides_halve_as_the_whole_level_does(small_budget, stores):
    image = smooth(np.uint16, shape=(301, 203), seed=5)
    plan = make_plan(snapshot_of(image, count=4), Choices(seed=3))
    assert plan.streamed is not None and plan.total_steps > 1
    _, outcome = drive(plan)
    data, _ = result_layer(plan, outcome)
    expected = in_memory(image, **plan.arguments)
    made = [expected, *lower_levels(expected, 4, False)]
    assert [level.shape for level in data] == [(301, 203), (151, 102), (76, 51), (38, 26)]
    for level, want in zip(data, made, strict=True):
        np.testing.assert_array_equal(level[...], want)


def test_a_cancelled_run_returns_nothing_and_removes_its_store(small_budget, stores):
    plan = make_plan(snapshot_of(smooth(np.uint16)), Choices())
    assert plan.streamed is not None
    _, outcome = drive(plan, on_step=lambda step: step == 2 and plan.cancel.set())
    assert outcome is None and store_dirs(stores) == []


def test_the_store_goes_with_the_outcome_and_when_removed(stores):
    plan = make_plan(snapshot_of(smooth(np.uint8, shape=(64, 64))), Choices())
    _, outcome = drive(plan)
    assert outcome.store is not None and store_dirs(stores) == [outcome.store.path.name]
    outcome.store.remove()
    assert store_dirs(stores) == [] and outcome.store.removed
    _, outcome = drive(plan)
    assert len(store_dirs(stores)) == 1
    del outcome  # nothing reads its levels any more
    assert store_dirs(stores) == []


@pytest.mark.parametrize(
    "change",
    [
        {"overrides": {"border": "wrap"}},
        {"overrides": {"scan": "checkerboard"}},
        {"mode": "stack"},
        {"mode": "sweep", "sweep_parameter": "seed", "sweep_text": "1, 2"},
    ],
    ids=["wrap", "checkerboard", "stack", "sweep"],
)
def test_what_needs_the_whole_level_renders_it_in_memory(change):
    image = smooth(np.uint8, shape=(64, 64))
    plan = make_plan(snapshot_of(image), Choices(**change))
    assert plan.streamed is None
    assert plan.layer_kwargs["metadata"][METADATA_KEY]["band_by_band"] is False


def test_only_a_grey_plane_run_once_into_a_pyramid_streams():
    parameters = resolve_parameters("labyrinth")
    assert streams("single", False, 2, 3, parameters)
    assert not streams("single", True, 2, 3, parameters)  # colour
    assert not streams("single", False, 3, 3, parameters)  # a stack's planes
    assert not streams("single", False, 2, 1, parameters)  # a preview, or one level
    assert not streams("stack", False, 2, 3, parameters)


def test_the_pyramid_store_is_chunked_by_bands_and_refuses_uneven_bands(stores):
    store = PyramidStore((100, 5000), np.uint16, 3, 8)
    assert [array.chunks for array in store.arrays] == [
        (8, CHUNK_COLUMNS), (4, CHUNK_COLUMNS), (2, 1250)
    ]
    with pytest.raises(ValueError, match="starts at a multiple of 8"):
        store.write(4, np.zeros((8, 5000), np.uint16))
    store.remove()
    store.write(0, np.ones((8, 5000), np.uint16))  # into a removed store: nothing
    assert not store.path.exists()
    with pytest.raises(ValueError, match="do not halve evenly into 3 levels"):
        PyramidStore((100, 100), np.uint16, 3, 6)


def test_an_array_is_read_by_bands_of_its_chunks_rows():
    image = np.zeros((40, 10), np.uint8)
    assert array_plane_bands(image, "a").chunk_rows == 1
    assert array_plane_bands(da.from_array(image, chunks=(8, 5)), "a").chunk_rows == 8
    stored = zarr.create_array(store={}, shape=(40, 10), chunks=(4, 10), dtype=np.uint8)
    assert array_plane_bands(stored, "a").chunk_rows == 4
    with pytest.raises(ValueError, match="2-D"):
        array_plane_bands(np.zeros((2, 4, 4)), "a")


def test_bands_read_whole_are_rendered_in_pieces_of_a_wide_plane_bit_for_bit(
    monkeypatch, small_budget, stores
):
    from napari_labyrinth import streaming

    image = smooth(np.uint16, seed=6)
    plan = make_plan(snapshot_of(image), Choices(seed=2))
    plane = array_plane_bands(image, "cam")
    per_row = streaming.stream_bytes_per_row(SHAPE[1], image.dtype, plan.streamed.passes)
    monkeypatch.setattr(streaming, "STREAM_BYTES", 7 * per_row)  # 7 rows a piece
    rows = band_rows(plane, plan.streamed, plan.levels)
    assert streaming.rendered_rows(plane, plan.streamed.passes, rows) == 7 < rows
    _, outcome = drive(plan)
    data, _ = result_layer(plan, outcome)
    np.testing.assert_array_equal(data[0][...], in_memory(image, **plan.arguments))
