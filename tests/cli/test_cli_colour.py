"""``--colour``: colour images rendered in their luminance or per channel, in memory and lazily."""

from __future__ import annotations

import numpy as np
import pytest

from napari_labyrinth import labyrinth, labyrinth_stack
from napari_labyrinth.cli import EXIT_FAILED, EXIT_OK, EXIT_USAGE, main
from napari_labyrinth.core.colour import COLOUR_MODES, luminance
from napari_labyrinth.io import read_image, write_image

OPTIONS = ["--passes", "2", "--seed", "7"]
API_OPTIONS = {"passes": 2, "seed": 7}


def colour_image(shape=(40, 48), dtype=np.uint8, seed=0) -> np.ndarray:
    """Coloured blobs on a dark, noisy background, different in every channel."""
    rng = np.random.default_rng(seed)
    y, x = np.mgrid[: shape[-2], : shape[-1]]
    channels = []
    for c in range(3):
        blob = 200 * np.exp(-((y - 10 - 8 * c) ** 2 + (x - 12 - 9 * c) ** 2) / 60.0)
        channels.append(blob + rng.poisson(3.0, shape))
    image = np.clip(np.stack(channels, axis=-1), 0, 255)
    if np.dtype(dtype) == np.uint16:
        return (image * 257).astype(np.uint16)
    return image.astype(dtype)


def render(*argv) -> int:
    return main(["render", *map(str, argv)])


def error_lines(stderr: str) -> list[str]:
    return [line for line in stderr.splitlines() if line.startswith("napari-labyrinth: error:")]


def test_rgb_png_renders_its_luminance_by_default_and_channels_on_request(tmp_path):
    image = colour_image()
    write_image(tmp_path / "rgb.png", image)
    assert render(tmp_path / "rgb.png", "-o", tmp_path / "default.png", *OPTIONS) == EXIT_OK
    luminance_mode = labyrinth(image, channel_axis=-1, colour="luminance", **API_OPTIONS)
    np.testing.assert_array_equal(read_image(tmp_path / "default.png"), luminance_mode)
    argv = ["--colour", "channels", *OPTIONS]
    assert render(tmp_path / "rgb.png", "-o", tmp_path / "channels.png", *argv) == EXIT_OK
    channels = labyrinth(image, channel_axis=-1, colour="channels", **API_OPTIONS)
    np.testing.assert_array_equal(read_image(tmp_path / "channels.png"), channels)
    assert not np.array_equal(channels, luminance_mode)
    argv = ["--colour", "luminance", "--stack", *OPTIONS]
    assert render(tmp_path / "rgb.png", "-o", tmp_path / "stack.tif", *argv) == EXIT_OK
    stack = labyrinth_stack(image, channel_axis=-1, **API_OPTIONS)
    np.testing.assert_array_equal(read_image(tmp_path / "stack.tif"), stack)


@pytest.mark.parametrize("colour", ["luminance", "channels"])
def test_colour_of_a_grey_tiff_fails_naming_the_options(tmp_path, capsys, colour):
    # named the API's colour='luminance' and channel_axis; --colour channels passed silently
    write_image(tmp_path / "grey.tif", colour_image()[..., 0])
    argv = ["--colour", colour]
    assert render(tmp_path / "grey.tif", "-o", tmp_path / "out.tif", *argv) == EXIT_FAILED
    (line,) = error_lines(capsys.readouterr().err)
    assert f"grey.tif: --colour {colour} applies to colour images" in line
    assert "--channel-axis names one" in line and "colour=" not in line
    assert not (tmp_path / "out.tif").exists()


def test_luminance_of_grey_and_alpha_fails_naming_the_options(tmp_path, capsys):
    image = np.stack([colour_image()[..., 0], np.full((40, 48), 255, np.uint8)], axis=-1)
    write_image(tmp_path / "la.png", image)
    argv = ["--colour", "luminance"]
    assert render(tmp_path / "la.png", "-o", tmp_path / "out.png", *argv) == EXIT_FAILED
    (line,) = error_lines(capsys.readouterr().err)
    assert "needs red, green and blue, and this image has 1 colour channel(s) and alpha" in line


def test_one_bit_images_are_refused_saying_so(tmp_path, capsys):
    from PIL import Image

    Image.fromarray(colour_image()[..., 0] > 100).save(tmp_path / "mask.png")  # mode "1"
    assert render(tmp_path / "mask.png", "-o", tmp_path / "out.png") == EXIT_FAILED
    (line,) = error_lines(capsys.readouterr().err)
    assert "mask.png: is a 1-bit (black and white) image" in line and "8-bit grey" in line


def test_an_output_below_a_file_is_refused_naming_it(tmp_path, capsys):
    # -o /dev/null/x.png said "File exists: /dev/null"
    write_image(tmp_path / "in.png", colour_image())
    (tmp_path / "notes.txt").write_text("mine")
    assert render(tmp_path / "in.png", "-o", tmp_path / "notes.txt" / "x.png") == EXIT_USAGE
    assert "notes.txt is not a directory" in capsys.readouterr().err
    assert (tmp_path / "notes.txt").read_text() == "mine"


def test_unknown_colour_is_a_usage_error(tmp_path, capsys):
    write_image(tmp_path / "rgb.png", colour_image())
    assert render(tmp_path / "rgb.png", "-o", tmp_path / "o.png", "--colour", "hsv") == EXIT_USAGE
    err = capsys.readouterr().err
    assert "--colour" in err and "Traceback" not in err


def test_help_lists_the_colour_modes(capsys):
    assert main(["render", "--help"]) == EXIT_OK
    out = " ".join(capsys.readouterr().out.split())
    assert "--colour {luminance,channels}" in out
    for name in COLOUR_MODES:
        assert f"{name}: " in out


def test_a_colour_store_renders_lazily_as_in_memory(tmp_path, capsys):
    zarr = pytest.importorskip("zarr")
    pytest.importorskip("dask.array")
    image = np.stack([colour_image(dtype=np.uint16, seed=k) for k in range(3)])  # (3, 40, 48, 3)
    image[..., 2] //= 4  # the channels' percentiles differ from the luminance's
    array = zarr.create_array(
        store=str(tmp_path / "in.zarr"),
        shape=image.shape,
        chunks=(2, 40, 48, 2),
        dtype=image.dtype,
    )
    array[...] = image
    argv = ["--channel-axis", "-1", *OPTIONS]
    assert render(tmp_path / "in.zarr", "-o", tmp_path / "out.zarr", *argv) == EXIT_OK
    expected = labyrinth(image, channel_axis=-1, **API_OPTIONS)  # limits found in memory
    np.testing.assert_array_equal(zarr.open_array(str(tmp_path / "out.zarr"))[...], expected)
    low, high = (float(v) for v in np.percentile(luminance(image), (0.5, 99.5)))
    assert f"tone limits {low!r} {high!r}" in capsys.readouterr().err  # the luminance's
    argv = ["--channel-axis", "-1", "--colour", "channels", *OPTIONS]
    assert render(tmp_path / "in.zarr", "-o", tmp_path / "channels.zarr", *argv) == EXIT_OK
    np.testing.assert_array_equal(
        zarr.open_array(str(tmp_path / "channels.zarr"))[...],
        labyrinth(image, channel_axis=-1, colour="channels", **API_OPTIONS),
    )


def test_the_provenance_record_names_the_colour_mode_the_default_chose(tmp_path):
    """Reproducible even if the default changed: the record says "luminance", not nothing."""
    from napari_labyrinth.io import read_provenance

    write_image(tmp_path / "rgb.png", colour_image())
    write_image(tmp_path / "grey.png", colour_image()[..., 0])
    for name in ("rgb", "grey"):
        assert render(tmp_path / f"{name}.png", "-o", tmp_path / f"{name}_out.png", *OPTIONS) == 0
    assert read_provenance(tmp_path / "rgb_out.png")["arguments"]["colour"] == "luminance"
    assert "colour" not in read_provenance(tmp_path / "grey_out.png")["arguments"]
    assert main(["reproduce", str(tmp_path / "rgb_out.png")]) == EXIT_OK


@pytest.mark.parametrize("suffix", [".zarr", ".tif"])
def test_a_last_axis_read_as_colour_is_written_as_colour(tmp_path, suffix):
    # a (Y, X, 3) store rendered with --channel-axis -1 was written to a TIFF as 40 grey
    # pages of 48 x 3 pixels, as the file's (absent) colour metadata said
    tifffile = pytest.importorskip("tifffile")
    zarr = pytest.importorskip("zarr")
    image = colour_image()
    source = tmp_path / f"rgb{suffix}"
    if suffix == ".zarr":
        zarr.create_array(str(source), shape=image.shape, dtype=image.dtype)[...] = image
    else:
        tifffile.imwrite(source, image, photometric="minisblack", planarconfig="separate")
    out = tmp_path / "out.tif"
    assert render(source, "-o", out, "--channel-axis", "-1", *OPTIONS) == EXIT_OK
    with tifffile.TiffFile(out) as tif:
        assert (tif.series[0].axes, tif.pages[0].photometric.name) == ("YXS", "RGB")
    expected = labyrinth(image, channel_axis=-1, **API_OPTIONS)
    np.testing.assert_array_equal(read_image(out), expected)


def test_planes_read_from_a_last_axis_of_three_are_not_written_as_a_colour_png(
    tmp_path, capsys
):
    # the 40 planes of 48 x 3 pixels were written as an RGB picture
    zarr = pytest.importorskip("zarr")
    image = colour_image()
    source = tmp_path / "rgb.zarr"
    zarr.create_array(str(source), shape=image.shape, dtype=image.dtype)[...] = image
    assert render(source, "-o", tmp_path / "planes.png", *OPTIONS) == EXIT_FAILED
    (line,) = error_lines(capsys.readouterr().err)
    assert "cannot store 40 planes of 48x3 pixels as PNG" in line and "--channel-axis -1" in line
    assert not (tmp_path / "planes.png").exists()
    assert render(source, "-o", tmp_path / "rgb.png", "--channel-axis", "-1", *OPTIONS) == EXIT_OK
