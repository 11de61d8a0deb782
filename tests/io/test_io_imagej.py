"""ImageJ (Fiji) hyperstacks in and out: axes, z spacing, unit, resolution and the provenance
record kept, in memory and when rendered block by block; what ImageJ cannot hold falls back to a
plain TIFF that keeps the axes and pixel sizes."""

from __future__ import annotations

import dataclasses
import json

import numpy as np
import pytest

from napari_labyrinth import io as file_io
from napari_labyrinth import labyrinth, labyrinth_stack, labyrinth_sweep
from napari_labyrinth.cli import EXIT_OK, main
from napari_labyrinth.io import (
    ImageMetadata,
    open_image,
    read_image,
    read_metadata,
    read_provenance,
    write_array,
    write_image,
)
from napari_labyrinth.provenance import KEY

tifffile = pytest.importorskip("tifffile")

OPTIONS = ["--passes", "2", "--seed", "7", "--tone-limits", "0", "60000"]
API_OPTIONS = {"passes": 2, "seed": 7, "tone_limits": (0, 60000)}
SIZES = {"X": (0.25, "micrometer"), "Y": (0.25, "micrometer"), "Z": (1.5, "micrometer")}
CALIBRATION = ImageMetadata(axes="ZCYX", pixel_sizes=SIZES, resolution=(4.0, 4.0, None))


def stack(shape=(3, 2, 32, 32), dtype=np.uint16, seed=0) -> np.ndarray:
    rng = np.random.default_rng(seed)
    return rng.integers(0, 60000 if dtype == np.uint16 else 256, shape).astype(dtype)


def imagej_file(path, image, axes="ZCYX", unit="um", **options):
    """An ImageJ hyperstack as Fiji writes it: X and Y as the resolution, Z as spacing."""
    metadata = {"axes": axes, "spacing": 1.5, "unit": unit}
    tifffile.imwrite(path, image, imagej=True, resolution=(4, 4), metadata=metadata, **options)
    return path


def render(*argv) -> int:
    return main(["render", *map(str, argv), *OPTIONS])


def assert_calibrated(path, axes):
    metadata = read_metadata(path)
    assert metadata.imagej and metadata.axes == axes
    assert metadata.pixel_sizes == SIZES and metadata.resolution == (4.0, 4.0, None)
    with tifffile.TiffFile(path) as tif:  # what ImageJ itself reads
        assert tif.is_imagej and tif.series[0].axes == axes
        entries = tif.imagej_metadata
        assert entries["spacing"] == 1.5 and entries["unit"] == "um"
        assert tif.pages[0].resolution == (4.0, 4.0)
    return metadata


def test_an_imagej_hyperstack_is_read_with_its_calibration(tmp_path):
    path = imagej_file(tmp_path / "ij.tif", stack())
    metadata = read_metadata(path)
    assert metadata == dataclasses.replace(CALIBRATION, imagej=True)
    assert metadata.channel_axis is None and not metadata.ambiguous and not metadata.ome


@pytest.mark.parametrize("unit,name", [("micron", "micrometer"), ("nm", "nanometer")])
def test_imagej_units_are_read_as_ome_zarr_names(tmp_path, unit, name):
    path = imagej_file(tmp_path / "ij.tif", stack(), unit=unit)
    assert {u for _, u in read_metadata(path).pixel_sizes.values()} == {name}


def test_a_unit_without_a_name_is_kept_as_the_file_says_it(tmp_path):
    source = imagej_file(tmp_path / "ij.tif", stack(), unit="furlong")
    metadata = read_metadata(source)
    assert metadata.pixel_sizes["Z"] == (1.5, "furlong")
    write_image(tmp_path / "out.tif", read_image(source), metadata=metadata)
    assert read_metadata(tmp_path / "out.tif").pixel_sizes == metadata.pixel_sizes


@pytest.mark.parametrize("lazy", [False, True], ids=["in-memory", "lazy"])
@pytest.mark.parametrize("mode", ["single", "stack", "sweep"])
def test_a_rendering_of_an_imagej_hyperstack_is_one_too(tmp_path, monkeypatch, capsys, lazy, mode):
    image = stack()
    source, out = imagej_file(tmp_path / "ij.tif", image), tmp_path / "out.tif"
    if lazy:  # a TIFF stack over this size is read and rendered block by block
        monkeypatch.setattr(file_io, "LAZY_TIFF_BYTES", 0)
        from napari_labyrinth.lazy import is_lazy

        assert is_lazy(open_image(source))
    extra = {"single": [], "stack": ["--stack"]}.get(
        mode, ["--sweep", "variance_threshold=0.03,0.05"]
    )
    assert render(source, "-o", out, *extra) == EXIT_OK
    # a stack's passes, a sweep's values: ImageJ has no Q axis, they become its time axis
    metadata = assert_calibrated(out, "ZCYX" if mode == "single" else "TZCYX")
    if mode == "single":
        expected = labyrinth(image, **API_OPTIONS)
    elif mode == "stack":
        expected = labyrinth_stack(image, **API_OPTIONS)
    else:
        expected = labyrinth_sweep(image, "variance_threshold", [0.03, 0.05], **API_OPTIONS)
    np.testing.assert_array_equal(read_image(out), expected)
    assert metadata.provenance == read_provenance(out) and metadata.provenance["mode"] == mode
    capsys.readouterr()
    assert main(["reproduce", str(out)]) == EXIT_OK
    assert "identical bit for bit" in capsys.readouterr().out


def test_the_record_is_an_entry_of_the_imagej_properties(tmp_path):
    source, out = imagej_file(tmp_path / "ij.tif", stack()), tmp_path / "out.tif"
    assert render(source, "-o", out) == EXIT_OK
    with tifffile.TiffFile(out) as tif:
        text = tif.imagej_metadata["Properties"][KEY]
        assert KEY not in tif.pages[0].description  # ImageJ's own description, untouched
    assert json.loads(text) == read_provenance(out)


@pytest.mark.parametrize("lazy", [False, True], ids=["in-memory", "lazy"])
def test_an_imagej_rgb_stack_stays_imagej_rgb(tmp_path, monkeypatch, lazy):
    image = stack((2, 32, 32, 3), np.uint8)
    source = imagej_file(tmp_path / "rgb.tif", image, axes="ZYXS", photometric="rgb")
    if lazy:
        monkeypatch.setattr(file_io, "LAZY_TIFF_BYTES", 0)
    assert main(["render", str(source), "-o", str(tmp_path / "out.tif"), "--stack"]) == EXIT_OK
    metadata = assert_calibrated(tmp_path / "out.tif", "TZYXS")
    assert metadata.channel_axis == 4 and "RGB" in metadata.colour


def test_a_stack_of_a_hyperstack_with_time_keeps_its_metadata_in_a_plain_tiff(tmp_path, capsys):
    image = stack((2, 3, 2, 16, 16))
    source, out = imagej_file(tmp_path / "ij.tif", image, axes="TZCYX"), tmp_path / "out.tif"
    assert render(source, "-o", out, "--stack") == EXIT_OK
    metadata = read_metadata(out)
    # ImageJ has one time axis: QTZCYX is no hyperstack, but nothing is lost
    assert not metadata.imagej and metadata.axes == "QTZCYX"
    assert metadata.pixel_sizes == SIZES and metadata.resolution == (4.0, 4.0, None)
    np.testing.assert_array_equal(read_image(out), labyrinth_stack(image, **API_OPTIONS))
    capsys.readouterr()
    assert main(["reproduce", str(out)]) == EXIT_OK


@pytest.mark.parametrize("lazy", [False, True], ids=["in-memory", "lazy"])
@pytest.mark.parametrize("dtype", [np.float64, np.int32, np.uint32])
def test_a_dtype_imagej_cannot_hold_gives_a_plain_tiff_keeping_the_metadata(
    tmp_path, lazy, dtype
):
    import dask.array as da

    image = stack().astype(dtype)
    array = da.from_array(image, chunks=(1, 1, 32, 32)) if lazy else image
    metadata = dataclasses.replace(CALIBRATION, imagej=True)
    write_array(tmp_path / "out.tif", array, metadata=metadata)
    back = read_metadata(tmp_path / "out.tif")
    assert not back.imagej and back.axes == "ZCYX"
    assert back.pixel_sizes == SIZES and back.resolution == (4.0, 4.0, None)
    np.testing.assert_array_equal(read_image(tmp_path / "out.tif"), image)


def test_pixel_sizes_without_a_resolution_become_the_imagej_resolution(tmp_path):
    metadata = ImageMetadata(axes="ZCYX", pixel_sizes=SIZES, imagej=True)
    write_image(tmp_path / "out.tif", stack(), metadata=metadata)
    assert_calibrated(tmp_path / "out.tif", "ZCYX")


def test_ome_axes_outside_ome_tiff_are_kept_in_the_description(tmp_path):
    # OME-XML cannot hold a Q axis before T: the plain description keeps them instead
    sizes = {"X": (0.5, "micrometer"), "Z": (2.0, "micrometer")}
    metadata = ImageMetadata(axes="QTZCYX", pixel_sizes=sizes, ome=True)
    write_image(tmp_path / "out.tif", np.zeros((2, 2, 2, 2, 4, 4), np.uint16), metadata=metadata)
    back = read_metadata(tmp_path / "out.tif")
    assert back.axes == "QTZCYX" and back.pixel_sizes == sizes and not back.ome
