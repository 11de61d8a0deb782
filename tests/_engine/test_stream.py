"""One plane streamed band by band (``_engine.stream``): the in-memory rendering, bit for bit."""

from __future__ import annotations

import numpy as np
import pytest

from napari_labyrinth import labyrinth
from napari_labyrinth._engine import stream as stream_module
from napari_labyrinth._engine.stream import stream_plane, streaming_refusal
from napari_labyrinth.core.codes import DIAGNOSTIC_FIELDS
from napari_labyrinth.core.noise import tone_noise_sigma, variance_floor
from napari_labyrinth.core.presets import resolve_parameters
from napari_labyrinth.core.tone_scale import resolve_tone_scale

from .. import textures

SHAPE = (96, 70)


def smooth(shape=SHAPE, dtype=np.uint16, seed=0) -> np.ndarray:
    """A smooth random texture with a few sharp edges, on most of the dtype's range."""
    return textures.smooth(dtype, shape, seed, stripes=(40, 23, 4))


def streamed(image, parameters, seed, rows, tone_limits=None, workers=1):
    """The plane rendered by ``stream_plane`` from bands of ``rows`` rows; the bands' rows."""
    scale = resolve_tone_scale(image, tone_limits)
    floor = variance_floor(parameters.noise_gate, tone_noise_sigma(image, scale))
    bands = (image[start : start + rows] for start in range(0, image.shape[0], rows))
    result = np.full_like(image, 0)
    counts = np.zeros((parameters.passes, len(DIAGNOSTIC_FIELDS)), np.int64)
    covered = 0
    for start, values in stream_plane(
        bands,
        image.shape,
        image.dtype,
        scale,
        parameters,
        seed,
        rows=rows,
        counts=counts,
        workers=workers,
        variance_floor=floor,
    ):
        assert start == covered  # in order, no gap
        result[start : start + len(values)] = values
        covered += len(values)
    assert covered == image.shape[0]
    return result, counts


@pytest.mark.parametrize("dtype", [np.uint8, np.uint16, np.float32])
@pytest.mark.parametrize("preset", ["paper", "labyrinth"])
@pytest.mark.parametrize("rows", [1, 2, 7, 16, 200])
def test_streamed_plane_equals_the_in_memory_rendering(dtype, preset, rows):
    image = smooth(dtype=dtype)
    if image.dtype.kind == "f":
        image[40, 3] = np.nan  # non-finite pixels: kept, never neighbours
    expected, diagnostics = labyrinth(image, preset=preset, seed=5, return_diagnostics=True)
    result, counts = streamed(image, resolve_parameters(preset), 5, rows)
    np.testing.assert_array_equal(result, expected)
    assert not np.array_equal(result, image, equal_nan=True)
    np.testing.assert_array_equal(counts, diagnostics.view(np.int64).reshape(counts.shape))


@pytest.mark.parametrize("rows", [3, 32])
def test_a_streamed_plane_is_gated_as_in_memory(rows):
    # a noisy black field beside a bright block: the gate leaves most of the field alone
    rng = np.random.default_rng(2)
    image = np.clip(rng.normal(6, 3, (120, 90)), 0, 255).astype(np.uint8)
    image[30:90, 50:80] = 200
    gated = resolve_parameters("labyrinth")
    assert gated.noise_gate > 0  # on in the default preset
    expected, diagnostics = labyrinth(image, seed=4, return_diagnostics=True)
    result, counts = streamed(image, gated, 4, rows)
    np.testing.assert_array_equal(result, expected)
    np.testing.assert_array_equal(counts, diagnostics.view(np.int64).reshape(counts.shape))
    ungated, _ = streamed(image, resolve_parameters("labyrinth", noise_gate=0), 4, rows)
    field = np.s_[:25, :45]
    assert (result[field] != image[field]).mean() < 0.05 < (ungated[field] != image[field]).mean()


@pytest.mark.parametrize("preset", ["paper", "labyrinth"])
def test_streamed_plane_in_exact_order_tiles_on_threads(monkeypatch, preset):
    # every core taken as idle: the rows of each band run in tiles of 16 rows on 2 threads
    monkeypatch.setattr(stream_module, "idle_cores", lambda: 2)
    image = smooth(shape=(160, 300), dtype=np.uint16, seed=4)
    expected, diagnostics = labyrinth(image, preset=preset, seed=1, return_diagnostics=True)
    calls = []
    original = stream_module.run_exact_order
    monkeypatch.setattr(
        stream_module, "run_exact_order", lambda *a: calls.append(a[-1]) or original(*a)
    )
    result, counts = streamed(image, resolve_parameters(preset), 1, 40, workers=2)
    np.testing.assert_array_equal(result, expected)
    np.testing.assert_array_equal(counts, diagnostics.view(np.int64).reshape(counts.shape))
    assert calls and all(region.row_offset >= 0 for region in calls)


@pytest.mark.parametrize(
    "overrides",
    [
        {"border": "mirror", "passes": 3},
        {"border": "nearest", "passes": 2, "include_centre": True},
        {"scan": "serpentine", "passes": 3},
        {"on_exhausted": "last_draw", "passes": 0},
    ],
    ids=["mirror", "nearest", "serpentine", "no passes"],
)
def test_streamed_plane_follows_borders_and_scans(overrides):
    image = smooth(dtype=np.uint16, seed=3)
    expected = labyrinth(image, preset="labyrinth", seed=2, **overrides)
    result, _ = streamed(image, resolve_parameters("labyrinth", **overrides), 2, 5)
    np.testing.assert_array_equal(result, expected)


@pytest.mark.parametrize(
    "overrides, said",
    [({"scan": "checkerboard"}, "checkerboard"), ({"border": "wrap"}, "wrap")],
)
def test_orders_that_need_the_whole_plane_are_refused(overrides, said):
    parameters = resolve_parameters("labyrinth", **overrides)
    assert said in streaming_refusal(parameters)
    image = smooth()
    with pytest.raises(ValueError, match=said):
        streamed(image, parameters, 0, 8)
