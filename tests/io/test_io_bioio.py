"""Files of the formats the package does not read itself, read through bioio: CZI files
written by pylibCZIrw here (2-D, a z-stack, several scenes), and the one line a file gets
when bioio is missing or no installed reader reads it."""

from __future__ import annotations

import sys

import numpy as np
import pytest

from napari_labyrinth.io import (
    FORMATS_EXTRA,
    ImageFileError,
    input_format,
    open_image,
    read_image,
    read_metadata,
)

RNG = np.random.default_rng(3)
PLANE = RNG.integers(0, 60000, (40, 50), dtype=np.uint16)
ZSTACK = RNG.integers(0, 4000, (3, 2, 24, 30), dtype=np.uint16)  # Z, C, Y, X
LEFT = RNG.integers(0, 255, (20, 24), dtype=np.uint8)
RIGHT = RNG.integers(0, 255, (20, 24), dtype=np.uint8)


def write_czi(path, planes: dict, *, name: str, channels=None, scale=None, scenes=None):
    """A CZI file of ``{(scene, z, c): plane}`` written by pylibCZIrw (``scale``: metres per
    pixel along X, Y, Z), its scenes named ``scenes`` (pylibCZIrw names none)."""
    czi = pytest.importorskip("pylibCZIrw.czi")
    x, y, z = scale or (None, None, None)
    with czi.create_czi(str(path), exist_ok=True) as writer:
        for (scene, depth, channel), plane in planes.items():
            location = (0, 0) if scene == 0 else (1000 * scene, 0)
            writer.write(
                plane[..., None], plane={"Z": depth, "C": channel, "T": 0}, scene=scene,
                location=location,
            )  # fmt: skip
        writer.write_metadata(
            document_name=name, channel_names=channels, scale_x=x, scale_y=y, scale_z=z
        )
    if scenes:
        listed = "".join(f'<Scene Index="{i}" Name="{n}"/>' for i, n in enumerate(scenes))
        with czi.edit_czi(str(path)) as editor, editor.edit_session() as builder:
            xml = builder.get_xml()
            builder.set_xml(xml.replace("</Channels>", f"</Channels><S><Scenes>{listed}"
                                        "</Scenes></S>", 1))  # fmt: skip
    return path


@pytest.fixture
def plane_czi(tmp_path):
    pytest.importorskip("bioio_czi")
    return write_czi(
        tmp_path / "plane.czi", {(0, 0, 0): PLANE}, name="plane", channels={0: "BF"},
        scale=(0.5e-6, 0.5e-6, None),
    )  # fmt: skip


@pytest.fixture
def zstack_czi(tmp_path):
    pytest.importorskip("bioio_czi")
    planes = {(0, z, c): ZSTACK[z, c] for z in range(3) for c in range(2)}
    return write_czi(
        tmp_path / "zstack.czi", planes, name="zstack", channels={0: "DAPI", 1: "GFP"},
        scale=(0.2e-6, 0.2e-6, 1e-6),
    )  # fmt: skip


@pytest.fixture
def scenes_czi(tmp_path):
    pytest.importorskip("bioio_czi")
    planes = {(0, 0, 0): LEFT, (1, 0, 0): RIGHT}
    return write_czi(
        tmp_path / "scenes.czi", planes, name="scenes", channels={0: "BF"},
        scale=(1e-6, 1e-6, None), scenes=("left", "right"),
    )  # fmt: skip


def test_a_suffix_the_package_does_not_read_is_read_through_bioio():
    assert input_format("a.czi") == "BIOIO" and input_format("a.ND2") == "BIOIO"
    assert input_format("a.tif") == "TIFF" and input_format("a.zarr/0") == "ZARR"


def test_a_2d_czi_is_read_with_its_pixel_sizes_and_channel_name(plane_czi):
    np.testing.assert_array_equal(read_image(plane_czi), PLANE)
    metadata = read_metadata(plane_czi)
    assert metadata.axes == "YX" and metadata.channel_axis is None and metadata.ome
    assert metadata.pixel_sizes == {"X": (0.5, "micrometer"), "Y": (0.5, "micrometer")}
    assert metadata.channel_names == ("BF",)
    assert metadata.scene == "Image:0" and metadata.image_name is None  # bioio's made-up id


def test_a_czi_z_stack_keeps_its_axes_sizes_and_channels(zstack_czi):
    metadata = read_metadata(zstack_czi)
    assert metadata.axes == "CZYX"  # bioio's order, T of length 1 left out
    assert metadata.pixel_sizes == {
        "X": (0.2, "micrometer"),
        "Y": (0.2, "micrometer"),
        "Z": (1.0, "micrometer"),
    }
    assert metadata.channel_names == ("DAPI", "GFP")
    np.testing.assert_array_equal(read_image(zstack_czi), ZSTACK.transpose(1, 0, 2, 3))


def test_a_czi_is_opened_lazily_in_blocks_of_whole_planes(zstack_czi):
    import dask.array as da

    image = open_image(zstack_czi, lazy=True)
    assert isinstance(image, da.Array) and image.shape == (2, 3, 24, 30)
    assert all(chunk == (24, 30) for chunk in {c[-2:] for c in _block_shapes(image)})
    np.testing.assert_array_equal(image.compute(), ZSTACK.transpose(1, 0, 2, 3))
    assert isinstance(open_image(zstack_czi), np.ndarray)  # small: read into memory


def _block_shapes(image):
    import itertools

    return [tuple(sizes) for sizes in itertools.product(*image.chunks)]


def test_a_scene_is_chosen_by_index_or_name_the_first_by_default(scenes_czi):
    np.testing.assert_array_equal(read_image(scenes_czi), LEFT)
    np.testing.assert_array_equal(read_image(scenes_czi, scene=1), RIGHT)
    np.testing.assert_array_equal(read_image(scenes_czi, scene="right"), RIGHT)
    np.testing.assert_array_equal(open_image(scenes_czi, scene="1"), RIGHT)
    metadata = read_metadata(scenes_czi, scene="right")
    assert metadata.scene == "right" and metadata.image_name == "right"


@pytest.mark.parametrize("scene", [2, "middle", -1])
def test_a_scene_the_file_has_not_is_refused_naming_its_scenes(scenes_czi, scene):
    with pytest.raises(ImageFileError, match=r"has no scene .*0 \('left'\), 1 \('right'\)"):
        read_metadata(scenes_czi, scene=scene)


def test_a_file_the_package_reads_itself_has_no_other_scene(tmp_path):
    from napari_labyrinth.io import write_image

    write_image(tmp_path / "a.tif", PLANE)
    np.testing.assert_array_equal(read_image(tmp_path / "a.tif", scene=0), PLANE)
    with pytest.raises(ImageFileError, match="holds one image"):
        read_image(tmp_path / "a.tif", scene=1)


def test_without_bioio_another_format_names_the_extra_to_install(tmp_path, monkeypatch):
    monkeypatch.setitem(sys.modules, "bioio", None)  # import bioio raises ImportError
    path = tmp_path / "cells.czi"
    path.write_bytes(b"ZISRAWFILE")
    for read in (read_metadata, read_image, open_image):
        with pytest.raises(ImageFileError) as error:
            read(path)
        message = str(error.value)
        assert FORMATS_EXTRA in message and "\n" not in message
        assert message.startswith(f"{path}: .czi files are read through bioio")


def test_a_file_no_installed_reader_reads_is_named_with_its_format(tmp_path):
    pytest.importorskip("bioio")
    path = tmp_path / "cells.xyz"
    path.write_bytes(b"not an image")
    with pytest.raises(ImageFileError, match=r"cells\.xyz: no installed bioio reader reads "
                       r"\.xyz files"):  # fmt: skip
        read_metadata(path)


def test_a_czi_its_reader_cannot_lay_out_is_refused_in_one_line(tmp_path):
    pytest.importorskip("bioio_czi")
    path = write_czi(tmp_path / "unscaled.czi", {(0, 0, 0): LEFT}, name="unscaled")
    with pytest.raises(ImageFileError) as error:  # bioio-czi needs the scaling pylibCZIrw omits
        read_image(path)
    assert "cannot read it with bioio-czi" in str(error.value)
    assert "\n" not in str(error.value)


def test_a_corrupt_czi_is_named_with_its_reader(tmp_path):
    pytest.importorskip("bioio_czi")
    path = tmp_path / "bad.czi"
    path.write_bytes(b"garbage")
    with pytest.raises(ImageFileError, match=r"bad\.czi: bioio-czi cannot read it as a \.czi"):
        read_image(path)
