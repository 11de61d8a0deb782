"""OME-Zarr outputs with lower resolution levels: the local-mean pyramid, the levels and
metadata ome-zarr writes, napari-ome-zarr reading them, and one level without ome-zarr."""

from __future__ import annotations

import json
import sys

import numpy as np
import pytest

from napari_labyrinth import io as file_io
from napari_labyrinth.io._pyramid import SMALLEST_SIDE, halved, halved_shape, level_count

pytest.importorskip("zarr")

RNG = np.random.default_rng(27)
SIZES = {"Y": (0.5, "micrometer"), "X": (0.25, "micrometer"), "Z": (2.0, "micrometer")}


def _metadata(**changes):
    values = {"axes": "CZYX", "ome": True, "pixel_sizes": SIZES}
    values.update(channel_names=("dapi", "gfp"), image_name="zstack")
    values.update(changes)
    return file_io.ImageMetadata(**values)


def _image():
    # 2 channels, 3 planes, 600 x 1100: levels 600, 300, 150 on the smaller side
    return RNG.integers(0, 65536, (2, 3, 600, 1100), dtype=np.uint16)


def _attributes(path):
    with open(path / "zarr.json") as handle:
        return json.load(handle)["attributes"]


# --- the pyramid itself (numpy only) ---


def test_halving_is_the_local_mean_rounded_in_the_dtype():
    image = np.array([[0, 255, 10, 11], [0, 255, 10, 12]], np.uint8)
    np.testing.assert_array_equal(halved(image, (0, 1)), [[128, 11]])  # 127.5 and 10.75
    floats = np.array([[0.0, 1.0], [1.0, 1.0]], np.float32)
    assert halved(floats, (0, 1)).dtype == np.float32 and halved(floats, (0, 1))[0, 0] == 0.75


def test_a_one_pixel_wall_is_kept_at_half_contrast_not_dropped():
    # every second pixel (nearest neighbour) would drop the wall in column 3 entirely
    image = np.zeros((4, 8), np.uint8)
    image[:, 3] = 200
    np.testing.assert_array_equal(halved(image, (0, 1))[:, 1], [100, 100])
    assert image[::2, ::2].max() == 0


def test_odd_sides_repeat_their_last_row_and_column():
    image = np.arange(15, dtype=np.uint16).reshape(3, 5)
    half = halved(image, (0, 1))
    assert half.shape == (2, 3)
    assert half[1, 2] == image[2, 4]  # the corner: four copies of the last pixel
    assert half[0, 2] == round((image[0, 4] + image[1, 4]) / 2)


@pytest.mark.parametrize("dtype", [np.uint8, np.int8, np.uint16, np.int16, np.uint32, np.int32])
def test_integer_halving_rounds_half_to_even_as_the_float_mean_does(dtype):
    info = np.iinfo(dtype)
    image = RNG.integers(info.min, info.max, (37, 52), endpoint=True, dtype=dtype)
    image[:4, :4] = [[0, 1, 2, 3], [1, 2, 1, 0], [info.max] * 4, [info.max - 1] * 4]
    # the float mean, rounded half to even (every block of the image: its sides are made even)
    blocks = np.pad(image, ((0, 1), (0, 0)), mode="edge").reshape(19, 2, 26, 2)
    expected = np.rint(blocks.mean(axis=(1, 3), dtype=np.float64)).astype(dtype)
    np.testing.assert_array_equal(halved(image, (0, 1)), expected)
    assert halved(image, (0, 1))[0, 0] == 1 and halved(image, (0, 1))[0, 1] == 2  # 1.0, 1.5


def test_only_the_named_axes_are_halved():
    image = RNG.integers(0, 100, (3, 8, 6), dtype=np.uint16)
    half = halved(image, (-2, -1))
    assert half.shape == halved_shape(image.shape, (-2, -1)) == (3, 4, 3)
    assert halved(half, (1, 2)).shape == (3, 2, 2)
    np.testing.assert_array_equal(half[1], halved(image[1], (0, 1)))


@pytest.mark.parametrize(
    "side,count",
    [(SMALLEST_SIDE, 1), (SMALLEST_SIDE + 1, 2), (600, 3), (4096, 5), (40_000, 9)],
)
def test_levels_end_when_the_smaller_side_is_at_most_the_smallest_side(side, count):
    assert level_count((3, side, side * 2), (1, 2)) == count


# --- the files ---


def test_an_ome_zarr_output_has_its_levels_and_metadata_through_ome_zarr(tmp_path):
    pytest.importorskip("ome_zarr")
    image = _image()
    out = file_io.write_array(tmp_path / "out.zarr", image, metadata=_metadata())
    ome = _attributes(out)["ome"]
    multiscale = ome["multiscales"][0]
    assert multiscale["name"] == "zstack"
    assert [d["path"] for d in multiscale["datasets"]] == ["0", "1", "2"]
    scales = [d["coordinateTransformations"][0]["scale"] for d in multiscale["datasets"]]
    assert scales == [[1.0, 2.0, 0.5, 0.25], [1.0, 2.0, 1.0, 0.5], [1.0, 2.0, 2.0, 1.0]]
    assert [channel["label"] for channel in ome["omero"]["channels"]] == ["dapi", "gfp"]
    import zarr

    group = zarr.open_group(out, mode="r")
    assert group["0"].chunks == (1, 1, 600, 1100)  # one plane a chunk, as before
    assert group["2"].shape == (2, 3, 150, 275) and group["2"].chunks == (1, 1, 150, 275)
    np.testing.assert_array_equal(group["0"][...], image)  # the full level as rendered
    np.testing.assert_array_equal(group["1"][...], halved(image, (2, 3)))
    # the package reads the full level and what the file says about it
    np.testing.assert_array_equal(file_io.read_image(out), image)
    back = file_io.read_metadata(out)
    assert back.axes == "CZYX" and back.pixel_sizes == SIZES and back.ome
    assert back.channel_names == ("dapi", "gfp") and back.image_name == "zstack"


@pytest.mark.parametrize("lazy", [False, True], ids=["in-memory", "lazy"])
def test_every_level_names_its_dimensions_as_the_axes(tmp_path, lazy):
    # OME-Zarr 0.5: each level's dimension_names MUST match the axes; they had none
    pytest.importorskip("ome_zarr")
    image = _image()
    if lazy:
        image = pytest.importorskip("dask.array").from_array(image, chunks=(1, 1, 600, 1100))
    out = file_io.write_array(tmp_path / "out.zarr", image, metadata=_metadata())
    import zarr

    group = zarr.open_group(out, mode="r")
    for level in ("0", "1", "2"):
        assert group[level].metadata.dimension_names == ("c", "z", "y", "x")


def test_napari_ome_zarr_reads_the_levels_without_a_viewer(tmp_path):
    pytest.importorskip("ome_zarr")
    reader_plugin = pytest.importorskip("napari_ome_zarr")
    image = _image()
    out = file_io.write_array(tmp_path / "out.zarr", image, metadata=_metadata())
    reader = reader_plugin.napari_get_reader(str(out))
    assert reader is not None
    [(data, kwargs, kind)] = reader(str(out))
    assert kind == "image"
    assert [level.shape for level in data] == [
        (2, 3, 600, 1100), (2, 3, 300, 550), (2, 3, 150, 275)
    ]  # fmt: skip
    assert kwargs["channel_axis"] == 0 and kwargs["name"] == ["zstack: dapi", "zstack: gfp"]
    assert list(kwargs["scale"]) == [2.0, 0.5, 0.25]
    np.testing.assert_array_equal(np.asarray(data[0]), image)


@pytest.mark.parametrize(
    "axes,shape,names",
    [("CYX", (2, 300, 320), ("dapi", "gfp")), ("YX", (300, 320), ("BF",))],
    ids=["two-channels", "one-channel"],
)
def test_napari_shows_the_named_channels_of_an_output_in_a_viewer(tmp_path, axes, shape, names):
    # the omero channels had a label only: napari-ome-zarr failed on one channel (no colour to
    # take the first of) and napari refused two (no colormap for either)
    pytest.importorskip("ome_zarr")
    reader_plugin = pytest.importorskip("napari_ome_zarr")
    components = pytest.importorskip("napari.components")
    image = RNG.integers(100, 4000, shape, dtype=np.uint16)
    metadata = _metadata(axes=axes, pixel_sizes={}, channel_names=names)
    out = file_io.write_array(tmp_path / "out.zarr", image, metadata=metadata)
    viewer = components.ViewerModel()
    for data, kwargs, kind in reader_plugin.napari_get_reader(str(out))(str(out)):
        getattr(viewer, f"add_{kind}")(data, **kwargs)
    assert [layer.name for layer in viewer.layers] == [f"zstack: {name}" for name in names]
    planes = image if axes == "CYX" else image[None]
    for layer, plane in zip(viewer.layers, planes, strict=True):
        assert list(layer.contrast_limits) == [plane.min(), plane.max()]
        np.testing.assert_array_equal(np.asarray(layer.data[0]), plane)


@pytest.mark.parametrize("variant", ["in-memory", "lazy", "one level", "without ome-zarr"])
def test_each_named_channel_has_a_colour_and_its_range_as_window(tmp_path, monkeypatch, variant):
    # OME-Zarr's omero channels hold a colour and a window beside the label; they had neither
    pytest.importorskip("ome_zarr")
    image = _image() // 20 + 100  # 100 to 3376
    image[1, 2, 198:200, 298:300] = [[7, 60000], [60000, 60000]]  # in the last plane
    if variant == "one level":
        image = image[..., :200, :300]
    if variant == "without ome-zarr":
        monkeypatch.setitem(sys.modules, "ome_zarr.writer", None)
        monkeypatch.setitem(sys.modules, "ome_zarr.format", None)
    if variant == "lazy":
        image = pytest.importorskip("dask.array").from_array(image, chunks=(1, 1, 600, 1100))
    out = file_io.write_array(tmp_path / "out.zarr", image, metadata=_metadata())
    channels = _attributes(out)["ome"]["omero"]["channels"]
    assert [channel["label"] for channel in channels] == ["dapi", "gfp"]
    assert [channel["color"] for channel in channels] == ["FFFFFF", "FFFFFF"]
    values = np.asarray(image)
    low, high = int(values[0].min()), int(values[0].max())
    assert channels[0]["window"] == {"min": low, "max": high, "start": low, "end": high}
    assert channels[1]["window"] == {"min": 7, "max": 60000, "start": 7, "end": 60000}
    assert file_io.read_metadata(out).channel_names == ("dapi", "gfp")


def test_a_constant_channel_gets_a_window_napari_accepts(tmp_path):
    pytest.importorskip("ome_zarr")
    image = np.zeros((2, 40, 50), np.float32)
    image[1] = np.nan
    image[1, 0, 0] = 0.5
    out = file_io.write_array(tmp_path / "out.zarr", image, metadata=_metadata(axes="CYX"))
    windows = [channel["window"] for channel in _attributes(out)["ome"]["omero"]["channels"]]
    assert windows == [
        {"min": 0.0, "max": 0.0, "start": 0.0, "end": 1.0},
        {"min": 0.5, "max": 0.5, "start": 0.5, "end": 1.5},
    ]


@pytest.mark.parametrize("axes,names", [("CZYX", ("dapi", "gfp")), ("CZYX", ()), ("ZYX", ("x",))])
def test_an_output_is_a_valid_ome_zarr_image(tmp_path, axes, names):
    models = pytest.importorskip("ome_zarr_models.v05")
    image = _image() if axes.startswith("C") else _image()[0]
    metadata = _metadata(axes=axes, channel_names=names)
    out = file_io.write_array(tmp_path / "out.zarr", image, metadata=metadata)
    import zarr

    models.Image.from_zarr(zarr.open_group(out, mode="r"))  # raises if it is not
    if names:  # the (transitional) omero metadata, which the image's model leaves out
        from ome_zarr_models.common.omero import Omero

        Omero.model_validate(_attributes(out)["ome"]["omero"])


def test_without_ome_zarr_the_output_keeps_one_level_and_its_metadata(tmp_path, monkeypatch):
    monkeypatch.setitem(sys.modules, "ome_zarr", None)  # import ome_zarr raises ImportError
    monkeypatch.setitem(sys.modules, "ome_zarr.writer", None)
    monkeypatch.setitem(sys.modules, "ome_zarr.format", None)
    image = _image()
    out = file_io.write_array(tmp_path / "out.zarr", image, metadata=_metadata())
    multiscale = _attributes(out)["ome"]["multiscales"][0]
    assert [d["path"] for d in multiscale["datasets"]] == ["0"]
    np.testing.assert_array_equal(file_io.read_image(out), image)
    back = file_io.read_metadata(out)
    assert back.pixel_sizes == SIZES and back.image_name == "zstack"
    assert back.channel_names == ("dapi", "gfp")


def test_a_small_image_has_one_level_and_no_name_made_up(tmp_path):
    pytest.importorskip("ome_zarr")
    image = RNG.integers(0, 256, (2, 40, 50), dtype=np.uint8)
    metadata = _metadata(axes="CYX", pixel_sizes={}, image_name=None)
    out = file_io.write_array(tmp_path / "out.zarr", image, metadata=metadata)
    multiscale = _attributes(out)["ome"]["multiscales"][0]
    assert [d["path"] for d in multiscale["datasets"]] == ["0"]
    assert "name" not in multiscale  # ome-zarr would name it "/" after the group
    assert file_io.read_metadata(out).image_name is None


def test_a_lazy_result_gets_the_same_levels_read_back_plane_by_plane(tmp_path):
    pytest.importorskip("ome_zarr")
    da = pytest.importorskip("dask.array")
    image = _image()
    lazy = da.from_array(image, chunks=(1, 1, 600, 1100))
    out = file_io.write_array(tmp_path / "lazy.zarr", lazy, metadata=_metadata())
    whole = file_io.write_array(tmp_path / "whole.zarr", image, metadata=_metadata())
    assert _attributes(out) == _attributes(whole)
    import zarr

    lazy_group, whole_group = zarr.open_group(out, mode="r"), zarr.open_group(whole, mode="r")
    for level in ("0", "1", "2"):
        assert lazy_group[level].chunks == whole_group[level].chunks
        np.testing.assert_array_equal(lazy_group[level][...], whole_group[level][...])
