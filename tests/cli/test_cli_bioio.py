"""``render`` of files read through bioio (CZI written by pylibCZIrw here): the rendering,
axes, pixel sizes, channel names and scene kept in the output; the line a file gets
without the extra; the image name of an OME-TIFF kept."""

from __future__ import annotations

import sys

import numpy as np
import pytest

from napari_labyrinth import labyrinth
from napari_labyrinth.cli import EXIT_FAILED, EXIT_OK, main
from napari_labyrinth.io import (
    FORMATS_EXTRA,
    open_image,
    read_image,
    read_metadata,
    read_provenance,
)

from ..io.test_io_bioio import LEFT, PLANE, RIGHT, ZSTACK, write_czi

OPTIONS = ["--passes", "2", "--seed", "7"]


def render(*argv) -> int:
    return main(["render", *map(str, argv), *OPTIONS])


@pytest.fixture(autouse=True)
def _czi_readers():
    pytest.importorskip("bioio_czi")
    pytest.importorskip("pylibCZIrw")


@pytest.mark.parametrize("output", ["out.ome.tif", "out.zarr"])
def test_a_czi_z_stack_renders_with_its_axes_sizes_and_channels(tmp_path, output):
    planes = {(0, z, c): ZSTACK[z, c] for z in range(3) for c in range(2)}
    source = write_czi(
        tmp_path / "zstack.czi", planes, name="zstack", channels={0: "DAPI", 1: "GFP"},
        scale=(0.2e-6, 0.2e-6, 1e-6),
    )  # fmt: skip
    assert render(source, "-o", tmp_path / output, "--tone-limits", "0", "4000") == EXIT_OK
    expected = labyrinth(ZSTACK.transpose(1, 0, 2, 3), passes=2, seed=7, tone_limits=(0, 4000))
    np.testing.assert_array_equal(np.asarray(open_image(tmp_path / output, lazy=False)), expected)
    metadata = read_metadata(tmp_path / output)
    assert metadata.ome and metadata.axes == "CZYX"
    assert metadata.pixel_sizes == {
        "X": (0.2, "micrometer"),
        "Y": (0.2, "micrometer"),
        "Z": (1.0, "micrometer"),
    }
    assert metadata.channel_names == ("DAPI", "GFP")
    assert read_provenance(tmp_path / output)["input"]["scene"] == "Image:0"


def test_a_2d_czi_renders_into_a_directory_as_ome_tiff(tmp_path):
    source = write_czi(
        tmp_path / "plane.czi", {(0, 0, 0): PLANE}, name="plane", channels={0: "BF"},
        scale=(0.5e-6, 0.5e-6, None),
    )  # fmt: skip
    assert render(source, "-o", tmp_path / "out") == EXIT_OK
    result = tmp_path / "out" / "plane_labyrinth.ome.tif"
    np.testing.assert_array_equal(read_image(result), labyrinth(PLANE, passes=2, seed=7))
    metadata = read_metadata(result)
    assert metadata.axes == "YX" and metadata.channel_names == ("BF",)
    assert metadata.pixel_sizes == {"X": (0.5, "micrometer"), "Y": (0.5, "micrometer")}


@pytest.mark.parametrize("scene", ["1", "right"])
def test_scene_chooses_the_scene_rendered_and_reproduce_reads_it_again(tmp_path, capsys, scene):
    source = write_czi(
        tmp_path / "scenes.czi", {(0, 0, 0): LEFT, (1, 0, 0): RIGHT}, name="scenes",
        channels={0: "BF"}, scale=(1e-6, 1e-6, None), scenes=("left", "right"),
    )  # fmt: skip
    assert render(source, "-o", tmp_path / "first.tif") == EXIT_OK
    np.testing.assert_array_equal(
        read_image(tmp_path / "first.tif"), labyrinth(LEFT, passes=2, seed=7)
    )
    assert render(source, "-o", tmp_path / "right.ome.tif", "--scene", scene) == EXIT_OK
    np.testing.assert_array_equal(
        read_image(tmp_path / "right.ome.tif"), labyrinth(RIGHT, passes=2, seed=7)
    )
    assert read_provenance(tmp_path / "right.ome.tif")["input"]["scene"] == "right"
    assert read_metadata(tmp_path / "right.ome.tif").image_name == "right"
    capsys.readouterr()
    assert main(["reproduce", str(tmp_path / "right.ome.tif")]) == EXIT_OK
    assert "identical bit for bit" in capsys.readouterr().out


def test_an_unknown_scene_is_refused_naming_the_scenes(tmp_path, capsys):
    source = write_czi(
        tmp_path / "scenes.czi", {(0, 0, 0): LEFT, (1, 0, 0): RIGHT}, name="scenes",
        scale=(1e-6, 1e-6, None), scenes=("left", "right"),
    )  # fmt: skip
    assert render(source, "-o", tmp_path / "out.tif", "--scene", "2") == EXIT_FAILED
    err = capsys.readouterr().err
    assert "has no scene '2'; its scenes are 0 ('left'), 1 ('right')" in err
    assert "Traceback" not in err and not (tmp_path / "out.tif").exists()


def test_without_the_extra_a_czi_gets_one_line_naming_it(tmp_path, capsys, monkeypatch):
    source = write_czi(tmp_path / "cells.czi", {(0, 0, 0): LEFT}, name="cells",
                       scale=(1e-6, 1e-6, None))  # fmt: skip
    monkeypatch.setitem(sys.modules, "bioio", None)  # import bioio raises ImportError
    assert render(source, "-o", tmp_path / "out.tif") == EXIT_FAILED
    err = capsys.readouterr().err
    line = next(line for line in err.splitlines() if "error" in line)
    assert line == (
        f"napari-labyrinth: error: {source}: .czi files are read through bioio, which is not "
        f"installed: {FORMATS_EXTRA} (napari-labyrinth itself reads .tif, .tiff, .png, .jpg, "
        ".jpeg, .bmp, .zarr)"
    )
    assert "unknown image format" not in err and "Traceback" not in err
