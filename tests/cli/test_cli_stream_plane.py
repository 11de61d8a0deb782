"""One plane too large for the run's memory: rendered band by band from file to file.

A small memory budget (``NAPARI_LABYRINTH_MEMORY``) makes a 512 x 700 plane
"too large": it was refused, and is now read, rendered and written in bands of
a few chunks of 16 rows, bit for bit what ``labyrinth()`` renders in memory.
"""

from __future__ import annotations

import os
import re
import signal
import sys
import time
import weakref
from pathlib import Path

import numpy as np
import pytest
import tifffile

zarr = pytest.importorskip("zarr")
pytest.importorskip("dask.array")

from napari_labyrinth import labyrinth, streaming
from napari_labyrinth.cli import main
from napari_labyrinth.core.noise import tone_noise_sigma
from napari_labyrinth.core.presets import resolve_parameters
from napari_labyrinth.core.tone_scale import resolve_tone_scale
from napari_labyrinth.io import ImageFileError, read_image, read_metadata
from napari_labyrinth.io import bands as plane_bands

from .. import textures

SHAPE = (512, 700)
ROWS = 16  # the chunks and strips of the inputs
#: The memory of every rendering below: too little for the plane, enough for bands of a few
#: chunks of 16 rows (the wider the values, the fewer rows).
BUDGET = "1500K"


def smooth(dtype, shape=SHAPE, seed=0) -> np.ndarray:
    return textures.smooth(dtype, shape, seed)


def written_input(path: Path, image: np.ndarray) -> Path:
    """``image`` as a zarr store chunked by 16 rows, or a TIFF file of 16-row strips."""
    if path.suffix == ".zarr":
        array = zarr.create_array(store=str(path), shape=image.shape, chunks=(ROWS, SHAPE[1]),
                                  dtype=image.dtype)  # fmt: skip
        array[...] = image
    else:
        tifffile.imwrite(path, image, rowsperstrip=ROWS, compression="zlib")
    return path


def render(*argv) -> int:
    return main(["render", *map(str, argv)])


@pytest.fixture
def small_budget(monkeypatch):
    monkeypatch.setenv("NAPARI_LABYRINTH_MEMORY", BUDGET)


@pytest.fixture
def band_reads(monkeypatch):
    """The rows of every read of an input's plane."""
    reads = []
    original = plane_bands.PlaneBands.read

    def read(self, start, stop):
        reads.append(stop - start)
        return original(self, start, stop)

    monkeypatch.setattr(plane_bands.PlaneBands, "read", read)
    return reads


@pytest.mark.parametrize("dtype", [np.uint8, np.uint16, np.float32])
@pytest.mark.parametrize("preset", ["paper", "labyrinth"])
@pytest.mark.parametrize("route", ["zarr-zarr", "zarr-tif", "tif-zarr", "tif-tif"])
def test_a_plane_too_large_for_memory_is_streamed_bit_for_bit(
    tmp_path, capsys, monkeypatch, small_budget, band_reads, dtype, preset, route
):
    image = smooth(dtype)
    image_in, image_out = route.split("-")
    source = written_input(tmp_path / f"in.{image_in}", image)
    target = tmp_path / f"out.{image_out}"
    assert render(source, "-o", target, "--preset", preset, "--seed", "3") == 0
    captured = capsys.readouterr()
    assert "rendered band by band" in captured.err
    monkeypatch.delenv("NAPARI_LABYRINTH_MEMORY")  # the result read whole
    expected = labyrinth(image, preset=preset, seed=3)
    result = read_image(target)
    assert result.dtype == image.dtype
    np.testing.assert_array_equal(result, expected)
    assert not np.array_equal(result, image)
    assert 0 < max(band_reads) <= SHAPE[0] // 8 and max(band_reads) % ROWS == 0  # whole chunks
    record = read_metadata(target).provenance
    assert record["preset"] == preset and record["input"]["shape"] == list(SHAPE)
    if preset == "paper":
        assert "noise_sigma" not in record
    else:  # the gate's measure of the whole plane, recorded
        sigma = tone_noise_sigma(image, resolve_tone_scale(image, None))
        assert record["noise_sigma"] == [sigma] and sigma > 0
    assert [p.name for p in tmp_path.iterdir() if p.name.startswith(".")] == []


def test_an_existing_output_is_still_refused_without_overwrite(
    tmp_path, capsys, monkeypatch, small_budget
):
    image = smooth(np.uint16)
    source = written_input(tmp_path / "in.zarr", image)
    target = tmp_path / "out.tif"
    tifffile.imwrite(target, np.zeros((4, 4), np.uint8))
    assert render(source, "-o", target) == 1
    assert "refusing to overwrite an existing file (use --overwrite" in capsys.readouterr().err
    np.testing.assert_array_equal(read_image(target), np.zeros((4, 4), np.uint8))
    assert render(source, "-o", target, "--overwrite", "--tone-limits", "0", "60000") == 0
    monkeypatch.delenv("NAPARI_LABYRINTH_MEMORY")
    expected = labyrinth(image, tone_limits=(0, 60000))
    np.testing.assert_array_equal(read_image(target), expected)


@pytest.mark.skipif(sys.platform == "win32", reason="POSIX signals")
@pytest.mark.parametrize("suffix", [".zarr", ".tif"])
def test_ctrl_c_while_bands_are_written_leaves_no_temporary(
    tmp_path, capsys, small_budget, monkeypatch, suffix
):
    image = smooth(np.uint16)
    source = written_input(tmp_path / "in.tif", image)
    aligned = streaming._aligned

    def interrupted(*args):
        for number, band in enumerate(aligned(*args)):
            if number == 3:  # Ctrl-C as the fourth band is written
                os.kill(os.getpid(), signal.SIGINT)
            yield band

    monkeypatch.setattr(streaming, "_aligned", interrupted)
    assert render(source, "-o", tmp_path / f"out{suffix}") == 130
    assert sorted(p.name for p in tmp_path.iterdir()) == ["in.tif"]


def test_an_output_that_cannot_take_bands_is_named(tmp_path, capsys, small_budget):
    source = written_input(tmp_path / "in.zarr", smooth(np.uint16))
    assert render(source, "-o", tmp_path / "out.png") == 1
    err = capsys.readouterr().err
    assert "rendered band by band into a .zarr or .tif output, not .png" in err
    assert not (tmp_path / "out.png").exists()


def test_chunks_larger_than_the_budget_are_named(tmp_path, capsys, small_budget):
    image = smooth(np.uint16)
    array = zarr.create_array(store=str(tmp_path / "in.zarr"), shape=SHAPE, chunks=(256, 700),
                              dtype=image.dtype)  # fmt: skip
    array[...] = image
    assert render(tmp_path / "in.zarr", "-o", tmp_path / "out.zarr") == 1
    err = capsys.readouterr().err
    assert "its chunks of 256 rows need more memory than this run may use" in err
    assert sorted(p.name for p in tmp_path.iterdir()) == ["in.zarr"]


def test_the_python_api_streams_an_ome_zarr_with_its_lower_levels(tmp_path, small_budget):
    pytest.importorskip("ome_zarr")
    from napari_labyrinth.io import ImageMetadata
    from napari_labyrinth.io._pyramid import halved

    image = smooth(np.uint16)
    source = written_input(tmp_path / "in.tif", image)
    metadata = ImageMetadata(axes="YX", pixel_sizes={"Y": (0.5, "micrometer")}, ome=True)
    done = []
    rendering = streaming.render_plane_file(
        source, tmp_path / "out.zarr", preset="paper", metadata=metadata,
        progress=lambda rows, total: done.append((rows, total)),
    )  # fmt: skip
    expected, diagnostics = labyrinth(image, preset="paper", return_diagnostics=True)
    assert rendering.rows % ROWS == 0 and rendering.rows <= 3 * ROWS
    assert done[-1] == (SHAPE[0], SHAPE[0])
    np.testing.assert_array_equal(rendering.diagnostics, diagnostics)
    group = zarr.open_group(str(tmp_path / "out.zarr"), mode="r")
    np.testing.assert_array_equal(group["0"][...], expected)
    np.testing.assert_array_equal(group["1"][...], halved(expected, (0, 1)))
    assert group["0"].chunks == (rendering.rows, SHAPE[1])


@pytest.mark.parametrize("byteorder", ["<", ">"])
def test_an_uncompressed_tiff_is_read_row_by_row_from_the_file(
    tmp_path, monkeypatch, small_budget, band_reads, byteorder
):
    image = smooth(np.uint16)
    source = tmp_path / "in.tif"
    tifffile.imwrite(source, image.astype(image.dtype.newbyteorder(byteorder)))  # one strip
    assert render(source, "-o", tmp_path / "out.tif", "--seed", "2") == 0
    assert 0 < max(band_reads) < SHAPE[0] // 4
    monkeypatch.delenv("NAPARI_LABYRINTH_MEMORY")
    np.testing.assert_array_equal(read_image(tmp_path / "out.tif"), labyrinth(image, seed=2))


def test_a_compressed_tiff_of_one_strip_is_refused_naming_it(tmp_path, capsys, small_budget):
    source = tmp_path / "in.tif"
    tifffile.imwrite(source, smooth(np.uint16), compression="zlib", rowsperstrip=512)
    assert render(source, "-o", tmp_path / "out.tif") == 1
    err = capsys.readouterr().err
    assert "its chunks of 512 rows need more memory" in err
    assert "tone limits" not in err  # refused before a pass over the file
    assert sorted(p.name for p in tmp_path.iterdir()) == ["in.tif"]


@pytest.mark.parametrize(
    "option, said",
    [
        (["--set", "border=wrap"], "border='wrap' makes the first rows neighbours of the last"),
        (["--set", "scan=checkerboard"], "scan='checkerboard' visits the whole plane"),
        (["--variance-threshold", "auto"], "variance_threshold='auto' probes the whole plane"),
    ],
)
def test_options_that_need_the_whole_plane_are_refused_before_reading(
    tmp_path, capsys, small_budget, band_reads, option, said
):
    source = written_input(tmp_path / "in.zarr", smooth(np.uint16))
    assert render(source, "-o", tmp_path / "out.zarr", *option) == 1
    err = capsys.readouterr().err
    assert said in err and "tone limits" not in err
    assert band_reads == []
    assert sorted(p.name for p in tmp_path.iterdir()) == ["in.zarr"]


def test_rows_picked_by_index_read_each_chunk_they_fall_in_once(tmp_path, band_reads):
    image = smooth(np.uint16)
    plane = plane_bands.open_plane_bands(written_input(tmp_path / "in.zarr", image))
    rows = np.array([40, 3, 17, 18, 5, 500, 33])  # chunks 2, 0, 1, 1, 0, 31, 2 of 16 rows
    np.testing.assert_array_equal(plane[rows], image[rows])
    np.testing.assert_array_equal(plane[rows, 7:9], image[rows, 7:9])
    assert band_reads == [ROWS] * 4 * 2  # chunks 0, 1, 2 and 31, once each per call
    assert plane[np.array([], int)].shape == (0, SHAPE[1])
    with pytest.raises(IndexError, match="of a plane of 512 rows"):
        plane[np.array([512])]
    with pytest.raises(TypeError, match="a slice or 1-D integers"):
        plane[np.array([1.5])]


#: A plane in chunks of 1024 x 256, the shape of the chunks ome-zarr and bioio write (1024²)
#: for a plane 2.5 chunks wide: its rendering in memory needs about 20 MB.
TALL = (1536, 640)
TALL_CHUNKS = (1024, 256)


def tall_input(path: Path, dtype=np.uint16) -> np.ndarray:
    image = smooth(dtype, TALL, seed=5)
    array = zarr.create_array(store=str(path), shape=TALL, chunks=TALL_CHUNKS, dtype=dtype)
    array[...] = image
    return image


@pytest.mark.parametrize("preset", ["paper", "labyrinth"])
@pytest.mark.parametrize("suffix", [".zarr", ".tif"])
def test_chunks_of_1024_rows_stream_under_a_budget_that_holds_their_values(
    tmp_path, capsys, monkeypatch, band_reads, preset, suffix
):
    # 16M: a chunk of rows is 1.3 MB of values, and was charged the 17 MB of the passes'
    # buffers for as many rows (26 bytes a pixel): "its chunks of 1024 rows need more
    # memory than this run may use"
    image = tall_input(tmp_path / "in.zarr")
    monkeypatch.setenv("NAPARI_LABYRINTH_MEMORY", "16M")
    assert render(tmp_path / "in.zarr", "-o", tmp_path / f"out{suffix}", "--preset", preset,
                  "--seed", "4") == 0  # fmt: skip
    assert "rendered band by band" in capsys.readouterr().err
    assert set(band_reads) == {1024, 512}  # each chunk of rows whole, never the plane
    monkeypatch.delenv("NAPARI_LABYRINTH_MEMORY")
    expected = labyrinth(image, preset=preset, seed=4)
    np.testing.assert_array_equal(read_image(tmp_path / f"out{suffix}"), expected)


@pytest.mark.parametrize("source", ["zarr of 1024-row chunks", "tif of one strip"])
def test_a_refusal_names_the_least_budget_that_renders(tmp_path, capsys, monkeypatch, source):
    if source.startswith("zarr"):
        image = tall_input(tmp_path / "in.zarr")
        path, rows = tmp_path / "in.zarr", 1024
    else:
        image = smooth(np.uint16)
        path, rows = tmp_path / "in.tif", SHAPE[0]
        tifffile.imwrite(path, image, compression="zlib", rowsperstrip=SHAPE[0])
    target = tmp_path / "out.zarr"
    monkeypatch.setenv("NAPARI_LABYRINTH_MEMORY", "2M")
    assert render(path, "-o", target) == 1
    err = capsys.readouterr().err
    assert f"its chunks of {rows} rows need more memory than this run may use (2.0 MiB)" in err
    least = re.search(r"NAPARI_LABYRINTH_MEMORY=(\d+)K at least", err)
    assert least is not None, err
    kib = int(least.group(1))
    # two chunks of rows of raw values (one read, and a copy), a quarter of the budget
    assert kib == -(-4 * 2 * rows * image.shape[1] * 2 // 1024)
    monkeypatch.setenv("NAPARI_LABYRINTH_MEMORY", f"{kib - 1}K")
    assert render(path, "-o", target) == 1
    assert f"NAPARI_LABYRINTH_MEMORY={kib}K at least" in capsys.readouterr().err
    assert not target.exists()
    monkeypatch.setenv("NAPARI_LABYRINTH_MEMORY", f"{kib}K")
    assert render(path, "-o", target, "--seed", "6") == 0
    assert "rendered band by band" in capsys.readouterr().err
    monkeypatch.delenv("NAPARI_LABYRINTH_MEMORY")
    np.testing.assert_array_equal(read_image(target), labyrinth(image, seed=6))


@pytest.mark.parametrize("side", [16_000, 40_000])
def test_the_usual_chunks_of_a_large_plane_fit_in_a_gigabyte(side):
    # what ome-zarr and bioio write: chunks of 1024 x 1024, uint16
    plane = plane_bands.PlaneBands(Path("big.zarr"), (side, side), np.uint16, 1024, None)
    plan = streaming.band_plan(plane, passes=4, limit=1 << 30)
    assert plan.read == 1024  # one chunk of rows, 33 or 82 MB of values
    assert plan.bytes <= (1 << 30) // streaming.BAND_SHARE
    assert plan.bytes == streaming.plan_bytes(plane.shape, plane.dtype, 4, plan.read,
                                              plan.rendered, plan.written)  # fmt: skip
    assert plan.rendered >= 100  # pieces of the passes of many rows still
    assert plan.written * side * 2 <= plane_bands.BAND_BYTES  # the output's chunks: 16 MB
    # the least budget: two chunks of rows of values (one read, and a copy), times four
    least = 4 * 2 * 1024 * side * 2
    with pytest.raises(ImageFileError, match=rf"NAPARI_LABYRINTH_MEMORY={-(-least >> 20)}M at"):
        streaming.band_plan(plane, passes=4, limit=least - (1 << 20))
    assert streaming.band_plan(plane, passes=4, limit=-(-least >> 20) << 20).read == 1024


def test_more_memory_gives_larger_pieces_never_more_than_their_share():
    plane = plane_bands.PlaneBands(Path("big.zarr"), (40_000, 40_000), np.uint16, 1024, None)
    plans = [streaming.band_plan(plane, 4, limit=n << 28) for n in range(3, 16)]
    assert all(p.bytes <= (n << 28) // 4 for p, n in zip(plans, range(3, 16), strict=True))
    rendered = [p.rendered for p in plans]
    assert rendered == sorted(rendered) and rendered[0] < rendered[-1]
    per_row = streaming.stream_bytes_per_row(40_000, np.uint16, 4)
    assert rendered[-1] == streaming.STREAM_BYTES // per_row  # capped


def test_a_band_read_is_let_go_before_the_next_is_read(tmp_path, small_budget):
    image = smooth(np.uint16)
    plane = plane_bands.open_plane_bands(written_input(tmp_path / "in.zarr", image))
    held = []
    read = plane.read

    def recorded(start, stop):
        assert all(band() is None for band in held), "a band read is still held"
        band = read(start, stop)
        held.append(weakref.ref(band))
        return band

    plane.read = recorded
    limits = (0, 50000)
    sigma = tone_noise_sigma(image, resolve_tone_scale(image, limits))  # as in memory
    stream = streaming.plane_stream(plane, resolve_parameters("labyrinth"), 3,
                                    tone_limits=limits, noise_sigma=sigma)  # fmt: skip
    assert stream.rows < SHAPE[0]
    result = np.empty_like(image)
    for start, values in stream.bands:
        result[start : start + len(values)] = values
    assert len(held) > 4
    np.testing.assert_array_equal(result, labyrinth(image, seed=3, tone_limits=limits))


def test_the_tone_limits_are_read_in_no_more_bands_at_once_than_their_share_holds(
    tmp_path, monkeypatch
):
    image = smooth(np.uint16)
    plane = plane_bands.open_plane_bands(written_input(tmp_path / "in.zarr", image))
    reading, most = [], []
    read = plane.read

    def recorded(start, stop):
        reading.append(start)
        most.append(len(reading))
        time.sleep(0.01)  # long enough for another thread to start a read
        try:
            return read(start, stop)
        finally:
            reading.remove(start)

    plane.read = recorded
    # a quarter of 200K holds one band of 32 rows of values (44800 bytes), not two
    monkeypatch.setenv("NAPARI_LABYRINTH_MEMORY", "200K")
    scale = resolve_tone_scale(image, None)
    assert streaming.plane_tone_limits(plane, 32) == (scale.low, scale.high)
    assert len(most) == SHAPE[0] // 32 and max(most) == 1
