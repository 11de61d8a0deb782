"""One plane too large for the run's memory: rendered band by band from file to file.

A small memory budget (``NAPARI_LABYRINTH_MEMORY``) makes a 512 x 700 plane
"too large": it was refused, and is now read, rendered and written in bands of
16 rows, bit for bit what ``labyrinth()`` renders in memory.
"""

from __future__ import annotations

import os
import signal
import sys
from pathlib import Path

import numpy as np
import pytest
import tifffile

zarr = pytest.importorskip("zarr")
pytest.importorskip("dask.array")

from napari_labyrinth import labyrinth, streaming
from napari_labyrinth.cli import main
from napari_labyrinth.core.noise import tone_noise_sigma
from napari_labyrinth.core.tone_scale import resolve_tone_scale
from napari_labyrinth.io import bands as plane_bands
from napari_labyrinth.io import read_image, read_metadata

from .. import textures

SHAPE = (512, 700)
ROWS = 16  # the chunks and strips of the inputs
#: The memory of every rendering below: too little for the plane, enough for bands of 16 to
#: 48 rows (the more passes, the fewer rows).
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
    assert 0 < max(band_reads) <= 3 * ROWS  # never the whole plane at once
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
