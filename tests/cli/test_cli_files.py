"""Files in, files out: lossless outputs, colour and OME metadata from the file, provenance,
``reproduce``, progress labels."""

from __future__ import annotations

import numpy as np
import pytest

from napari_labyrinth import __version__, labyrinth, labyrinth_stack
from napari_labyrinth.cli import EXIT_FAILED, EXIT_OK, EXIT_USAGE, main
from napari_labyrinth.cli.render import PROGRESS_LABELS
from napari_labyrinth.io import read_image, read_metadata, read_provenance, write_image
from napari_labyrinth.provenance import SCHEMA, file_checksum

from .test_cli_colour import colour_image

OPTIONS = ["--passes", "2", "--seed", "7"]


def render(*argv) -> int:
    return main(["render", *map(str, argv)])


def noise(shape, dtype=np.uint8, seed=0):
    rng = np.random.default_rng(seed)
    high = 4000 if np.dtype(dtype) == np.uint16 else 256
    return rng.integers(0, high, shape).astype(dtype)


# -- never lossy by surprise ----------------------------------------------------------------------


def test_an_explicit_jpeg_output_is_refused_without_lossy(tmp_path, capsys):
    write_image(tmp_path / "in.png", noise((16, 16)))
    assert render(tmp_path / "in.png", "-o", tmp_path / "out.jpg") == EXIT_USAGE
    err = capsys.readouterr().err
    assert "JPEG is lossy" in err and "--lossy" in err
    assert not (tmp_path / "out.jpg").exists()
    assert render(tmp_path / "in.png", "-o", tmp_path / "out.jpg", "--lossy") == EXIT_OK
    assert read_provenance(tmp_path / "out.jpg")["input"]["name"] == str(tmp_path / "in.png")


def test_a_directory_batch_writes_jpeg_and_bmp_inputs_as_png(tmp_path, capsys):
    image = noise((16, 16))
    for name in ("a.jpg", "b.bmp", "c.png", "c.jpg"):
        write_image(tmp_path / name, image)
    inputs = [tmp_path / n for n in ("a.jpg", "b.bmp", "c.png", "c.jpg")]
    assert render(*inputs, "-o", tmp_path / "out", *OPTIONS) == EXIT_OK
    names = sorted(p.name for p in (tmp_path / "out").iterdir())
    assert names == [
        "a_labyrinth.png",
        "b_labyrinth.png",
        "c_jpg_labyrinth.png",  # c.png takes c_labyrinth.png
        "c_labyrinth.png",
    ]
    written = read_image(tmp_path / "out" / "a_labyrinth.png")
    expected = labyrinth(read_image(tmp_path / "a.jpg"), passes=2, seed=7)
    np.testing.assert_array_equal(written, expected)
    # with --lossy a JPEG input keeps its format
    assert render(tmp_path / "a.jpg", "-o", tmp_path / "lossy", "--lossy") == EXIT_OK
    assert [p.name for p in (tmp_path / "lossy").iterdir()] == ["a_labyrinth.jpg"]


# -- colour and axes from the file ----------------------------------------------------------------


def test_an_rgb_tiff_is_read_as_colour(tmp_path):
    import tifffile

    image = colour_image()
    tifffile.imwrite(tmp_path / "rgb.tif", image, photometric="rgb")
    assert render(tmp_path / "rgb.tif", "-o", tmp_path / "out.tif", *OPTIONS) == EXIT_OK
    expected = labyrinth(image, channel_axis=-1, passes=2, seed=7)
    np.testing.assert_array_equal(read_image(tmp_path / "out.tif"), expected)
    assert read_metadata(tmp_path / "out.tif").channel_axis == 2  # written as RGB again
    # --channel-axis none: three planes of 48 x 3 pixels, as the user asks
    argv = [tmp_path / "rgb.tif", "-o", tmp_path / "planes.tif", *OPTIONS]
    assert render(*argv, "--channel-axis", "none") == EXIT_OK
    planes = labyrinth(image, passes=2, seed=7)
    np.testing.assert_array_equal(read_image(tmp_path / "planes.tif"), planes)


def test_an_ambiguous_last_axis_gets_a_note_saying_how_to_read_it(tmp_path, capsys):
    import tifffile

    image = colour_image()
    tifffile.imwrite(tmp_path / "grey3.tif", image, photometric="minisblack")
    assert render(tmp_path / "grey3.tif", "-o", tmp_path / "out.tif", *OPTIONS) == EXIT_OK
    notes = [line for line in capsys.readouterr().err.splitlines() if "colour metadata" in line]
    assert len(notes) == 1
    assert "read as 40 planes of 48x3 pixels" in notes[0] and "--channel-axis -1" in notes[0]
    np.testing.assert_array_equal(
        read_image(tmp_path / "out.tif"), labyrinth(image, passes=2, seed=7)
    )
    # given the axis, no note
    argv = [tmp_path / "grey3.tif", "-o", tmp_path / "rgb.tif", *OPTIONS, "--channel-axis", "-1"]
    assert render(*argv) == EXIT_OK
    assert "colour metadata" not in capsys.readouterr().err
    np.testing.assert_array_equal(
        read_image(tmp_path / "rgb.tif"), labyrinth(image, channel_axis=-1, passes=2, seed=7)
    )


@pytest.mark.parametrize("output", ["out.ome.tif", "out.zarr"])
def test_ome_axes_and_pixel_sizes_survive_a_stack(tmp_path, output):
    import tifffile

    image = noise((3, 16, 16), np.uint16)
    sizes = {"PhysicalSizeX": 0.325, "PhysicalSizeY": 0.325, "PhysicalSizeZ": 2.0}
    tifffile.imwrite(tmp_path / "in.ome.tif", image, ome=True, metadata={"axes": "ZYX", **sizes})
    argv = [tmp_path / "in.ome.tif", "-o", tmp_path / output, "--stack", *OPTIONS]
    assert render(*argv, "--tone-limits", "0", "4000") == EXIT_OK
    metadata = read_metadata(tmp_path / output)
    assert metadata.axes == "QZYX" and metadata.ome
    assert metadata.pixel_sizes == {
        "X": (0.325, "micrometer"),
        "Y": (0.325, "micrometer"),
        "Z": (2.0, "micrometer"),
    }
    stack = labyrinth_stack(image, passes=2, seed=7, tone_limits=(0, 4000))
    from napari_labyrinth.io import open_image

    np.testing.assert_array_equal(np.asarray(open_image(tmp_path / output, lazy=False)), stack)


# -- provenance and reproduce ---------------------------------------------------------------------


def test_the_record_of_an_output_names_everything(tmp_path):
    image = noise((16, 16), np.uint16)
    write_image(tmp_path / "in.tif", image)
    argv = [tmp_path / "in.tif", "-o", tmp_path / "out.tif", *OPTIONS, "--border", "mirror"]
    assert render(*argv) == EXIT_OK
    record = read_provenance(tmp_path / "out.tif")
    assert record["schema"] == SCHEMA and record["version"] == __version__
    assert record["mode"] == "single" and record["function"] == "labyrinth"
    assert record["preset"] == "labyrinth" and record["seed"] == 7
    assert record["overrides"] == {"passes": 2, "border": "mirror"}
    assert record["parameters"]["passes"] == 2 and record["parameters"]["border"] == "mirror"
    assert record["parameters"]["variance_threshold"] == 0.04  # from the preset
    low, high = record["tone_limits"]  # the default percentiles, found in memory
    assert (low, high) == tuple(np.percentile(image, (0.5, 99.5)))
    assert record["arguments"]["tone_limits"] == [low, high]
    assert record["input"] == {
        "name": str(tmp_path / "in.tif"),
        "sha256": file_checksum(tmp_path / "in.tif"),
        "shape": [16, 16],
        "dtype": "uint16",
    }


@pytest.mark.parametrize(
    "source,output,extra",
    [
        ("in.tif", "out.tif", []),
        ("in.png", "out.png", []),
        ("in.tif", "out.zarr", ["--stack"]),
        ("in.zarr", "out.tif", ["--sweep", "variance_threshold=0.03,0.04,0.05"]),
        ("rgb.png", "rgb.png", []),
    ],
)
def test_reproduce_checks_bit_for_bit(tmp_path, capsys, monkeypatch, source, output, extra):
    images = {"rgb.png": colour_image(), "in.png": noise((16, 16))}
    image = images.get(source, noise((2, 16, 16)))
    monkeypatch.chdir(tmp_path)
    (tmp_path / "out").mkdir()
    from napari_labyrinth.io import write_array

    write_array(source, image)
    assert render(source, "-o", f"out/{output}", *OPTIONS, *extra) == EXIT_OK
    capsys.readouterr()
    assert main(["reproduce", f"out/{output}"]) == EXIT_OK
    assert "identical bit for bit" in capsys.readouterr().out


def test_reproduce_finds_a_changed_output_and_a_changed_input(tmp_path, capsys):
    write_image(tmp_path / "in.tif", noise((16, 16)))
    assert render(tmp_path / "in.tif", "-o", tmp_path / "out.tif", *OPTIONS) == EXIT_OK
    record = read_provenance(tmp_path / "out.tif")
    from napari_labyrinth.io import ImageMetadata

    changed = read_image(tmp_path / "out.tif")
    changed[3, 4] ^= 1
    metadata = ImageMetadata(provenance=record)
    write_image(tmp_path / "out.tif", changed, overwrite=True, metadata=metadata)
    capsys.readouterr()
    assert main(["reproduce", str(tmp_path / "out.tif")]) == EXIT_FAILED
    out = capsys.readouterr().out
    assert "DIFFERS" in out and "1 of 256 values differ" in out
    write_image(tmp_path / "in.tif", noise((16, 16), seed=1), overwrite=True)
    assert main(["reproduce", str(tmp_path / "out.tif")]) == EXIT_FAILED
    assert "not the file that was rendered" in capsys.readouterr().err



def test_reproduce_in_the_outputs_directory_finds_the_input_named_from_above(
    tmp_path, capsys, monkeypatch
):
    # render raw/cells.png -o results/, then reproduce in results: "raw/cells.png is not at
    # raw/cells.png, cells.png; give --input"
    (tmp_path / "raw").mkdir()
    write_image(tmp_path / "raw" / "cells.png", noise((16, 16)))
    monkeypatch.chdir(tmp_path)
    assert render("raw/cells.png", "-o", "results/", *OPTIONS) == EXIT_OK
    monkeypatch.chdir(tmp_path / "results")
    capsys.readouterr()
    assert main(["reproduce", "cells_labyrinth.png"]) == EXIT_OK
    assert "identical bit for bit" in capsys.readouterr().out


def test_reproduce_of_a_lossy_output_says_why_it_differs(tmp_path, capsys):
    write_image(tmp_path / "in.png", colour_image())
    out = tmp_path / "out.jpg"
    assert render(tmp_path / "in.png", "-o", out, "--lossy", *OPTIONS) == EXIT_OK
    capsys.readouterr()
    assert main(["reproduce", str(out)]) == EXIT_FAILED
    assert "DIFFERS" in (said := capsys.readouterr().out) and "(JPEG is lossy" in said


def test_reproduce_names_the_values_of_a_sweep(tmp_path, capsys):
    # a sweep of seeds 1, 2, 3 was said to be of "seed 0"
    write_image(tmp_path / "in.tif", noise((16, 16)))
    for spec, said in (("seed=1,2,3", "seeds 1, 2, 3;"), ("passes=1,2", "seed 0, passes 1, 2;")):
        out = tmp_path / f"{spec[:4]}.tif"
        assert render(tmp_path / "in.tif", "-o", out, "--sweep", spec) == EXIT_OK
        capsys.readouterr()
        assert main(["reproduce", str(out)]) == EXIT_OK
        assert said in capsys.readouterr().out

def test_reproduce_without_a_record_or_input_says_why(tmp_path, capsys):
    write_image(tmp_path / "plain.tif", noise((8, 8)))
    assert main(["reproduce", str(tmp_path / "plain.tif")]) == EXIT_FAILED
    assert "no napari-labyrinth provenance record" in capsys.readouterr().err
    write_image(tmp_path / "in.tif", noise((8, 8)))
    assert render(tmp_path / "in.tif", "-o", tmp_path / "out.tif", *OPTIONS) == EXIT_OK
    (tmp_path / "in.tif").rename(tmp_path / "moved.tif")
    capsys.readouterr()
    assert main(["reproduce", str(tmp_path / "out.tif")]) == EXIT_FAILED
    assert "give --input" in capsys.readouterr().err
    argv = ["reproduce", str(tmp_path / "out.tif"), "--input", str(tmp_path / "moved.tif")]
    assert main(argv) == EXIT_OK


def test_reproduce_of_a_record_naming_an_impossible_input_says_so(tmp_path, capsys):
    # a name longer than any the file system holds: an OSError traceback from Path.exists
    write_image(tmp_path / "in.tif", noise((8, 8)))
    assert render(tmp_path / "in.tif", "-o", tmp_path / "out.tif", *OPTIONS) == EXIT_OK
    from napari_labyrinth.io import ImageMetadata

    record = read_provenance(tmp_path / "out.tif")
    record["input"] = dict(record["input"], name="x" * 5000)
    metadata = ImageMetadata(provenance=record)
    write_image(tmp_path / "out.tif", read_image(tmp_path / "out.tif"), overwrite=True,
                metadata=metadata)  # fmt: skip
    capsys.readouterr()
    assert main(["reproduce", str(tmp_path / "out.tif")]) == EXIT_FAILED
    assert "give --input" in capsys.readouterr().err


@pytest.mark.parametrize("source,counted", [("in.tif", "passes"), ("in.zarr", "planes written")])
def test_progress_bars_say_what_they_count(tmp_path, capsys, monkeypatch, source, counted):
    from napari_labyrinth.cli import render as render_module
    from napari_labyrinth.io import write_array

    monkeypatch.setattr(render_module, "_isatty", lambda stream: True)
    write_array(tmp_path / source, noise((3, 16, 16)))
    assert render(tmp_path / source, "-o", tmp_path / "out.tif", *OPTIONS) == EXIT_OK
    err = capsys.readouterr().err
    assert "files: 100%" in err and f"{counted}:" in err
    assert PROGRESS_LABELS["pass" if counted == "passes" else "plane"] == counted
    if counted == "passes":
        assert "planes" not in err


@pytest.mark.parametrize("stack", [False, True])
def test_grey_plus_alpha_renders_the_grey_and_keeps_the_alpha(tmp_path, capsys, stack):
    import imageio.v3 as iio

    grey, alpha = noise((16, 16), seed=1), noise((16, 16), seed=2)
    iio.imwrite(tmp_path / "la.png", np.stack([grey, alpha], -1), mode="LA")
    output = tmp_path / ("out.tif" if stack else "out.png")
    argv = [tmp_path / "la.png", "-o", output, *OPTIONS] + (["--stack"] if stack else [])
    assert render(*argv) == EXIT_OK
    written = read_image(output)
    expected = (labyrinth_stack if stack else labyrinth)(grey, passes=2, seed=7)
    np.testing.assert_array_equal(written[..., 0], expected)
    np.testing.assert_array_equal(written[..., 1], np.broadcast_to(alpha, expected.shape))
    assert main(["reproduce", str(output)]) == EXIT_OK


def test_a_bmp_output_is_written_with_a_note_that_it_holds_no_record(tmp_path, capsys):
    write_image(tmp_path / "in.png", noise((16, 16)))
    assert render(tmp_path / "in.png", "-o", tmp_path / "out.bmp", *OPTIONS) == EXIT_OK
    assert "BMP holds no provenance record" in capsys.readouterr().err
    assert main(["reproduce", str(tmp_path / "out.bmp")]) == EXIT_FAILED


def test_a_bad_channel_axis_is_a_usage_error(tmp_path, capsys):
    write_image(tmp_path / "in.png", noise((16, 16)))
    argv = [tmp_path / "in.png", "-o", tmp_path / "o.png", "--channel-axis", "last"]
    assert render(*argv) == EXIT_USAGE
    assert "expected an integer or none, got 'last'" in capsys.readouterr().err
