"""The ``napari-labyrinth`` command line, run in-process and as the installed script."""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from napari_labyrinth import __version__, labyrinth, labyrinth_stack, labyrinth_sweep
from napari_labyrinth.cli import main
from napari_labyrinth.cli.demo import LABEL_HEIGHT
from napari_labyrinth.io import read_image, read_metadata, write_image

RNG = np.random.default_rng(42)
OPTIONS = ["--passes", "2", "--seed", "7"]
API_OPTIONS = {"passes": 2, "seed": 7}


def gradient_image(dtype, shape=(48, 40)) -> np.ndarray:
    """A ramp with noise and a bright square: something for the algorithm to change."""
    y, x = np.mgrid[: shape[0], : shape[1]]
    base = 40 + 150 * (x / shape[1]) + 20 * RNG.standard_normal(shape)
    base[10:25, 12:30] += 60
    base = np.clip(base, 0, 255)
    if np.dtype(dtype) == np.uint16:
        return (base * 257).astype(np.uint16)
    if np.dtype(dtype).kind == "f":
        return (base / 255).astype(dtype)
    return base.astype(dtype)


def leftovers(directory) -> list[str]:
    return [p.name for p in Path(directory).rglob("*.tmp")]


def error_lines(stderr: str) -> list[str]:
    return [line for line in stderr.splitlines() if line.startswith("napari-labyrinth: error:")]


# -- single files ---------------------------------------------------------------------------------


@pytest.mark.parametrize(
    ("suffix", "dtype"),
    [(".png", np.uint8), (".tif", np.uint8), (".tif", np.uint16), (".tif", np.float32)],
)
def test_render_one_file_equals_the_api(tmp_path, capsys, suffix, dtype):
    image = gradient_image(dtype)
    source = tmp_path / f"in{suffix}"
    write_image(source, image)
    target = tmp_path / f"out{suffix}"
    assert main(["render", str(source), "-o", str(target), *OPTIONS]) == 0
    result = read_image(target)
    assert result.dtype == image.dtype and result.shape == image.shape
    expected = labyrinth(image, **API_OPTIONS)
    assert not np.array_equal(expected, image)  # the comparison means something
    np.testing.assert_array_equal(result, expected)
    captured = capsys.readouterr()
    assert captured.out.strip() == str(target)
    assert "rendered 1 file" in captured.err
    assert leftovers(tmp_path) == []


def test_every_option_reaches_the_api(tmp_path):
    image = gradient_image(np.uint16)
    source = tmp_path / "in.tif"
    write_image(source, image)
    argv = [
        "render",
        str(source),
        "-o",
        str(tmp_path / "out.tif"),
        "--preset",
        "paper",
        "--passes",
        "3",
        "--seed",
        "11",
        "--mean-threshold",
        "0.05",
        "--variance-threshold",
        "0.3",
        "--max-tries",
        "4",
        "--tone-limits",
        "1000",
        "60000",
    ]
    assert main(argv) == 0
    expected = labyrinth(
        image,
        preset="paper",
        passes=3,
        seed=11,
        mean_threshold=0.05,
        variance_threshold=0.3,
        max_tries=4,
        tone_limits=(1000.0, 60000.0),
    )
    np.testing.assert_array_equal(read_image(tmp_path / "out.tif"), expected)


def test_set_passes_any_other_parameter(tmp_path):
    image = gradient_image(np.uint8)
    write_image(tmp_path / "in.png", image)
    argv = [
        "render",
        str(tmp_path / "in.png"),
        "-o",
        str(tmp_path / "out.png"),
        "--set",
        "border=mirror",
        "--set",
        "scan=serpentine",
        "--set",
        "include-centre=true",
        "--set",
        "tone_ranges=4",
        *OPTIONS,
    ]
    assert main(argv) == 0
    expected = labyrinth(
        image,
        border="mirror",
        scan="serpentine",
        include_centre=True,
        tone_ranges=4,
        **API_OPTIONS,
    )
    np.testing.assert_array_equal(read_image(tmp_path / "out.png"), expected)


def test_default_options_are_the_api_defaults(tmp_path):
    image = gradient_image(np.uint8)
    write_image(tmp_path / "in.png", image)
    assert main(["render", str(tmp_path / "in.png"), "-o", str(tmp_path / "out.png")]) == 0
    np.testing.assert_array_equal(read_image(tmp_path / "out.png"), labyrinth(image))


def test_rgb_png_is_rendered_with_its_channel_axis(tmp_path):
    image = np.stack([gradient_image(np.uint8) for _ in range(3)], axis=-1)
    write_image(tmp_path / "rgb.png", image)
    assert (
        main(["render", str(tmp_path / "rgb.png"), "-o", str(tmp_path / "out.png"), *OPTIONS]) == 0
    )
    expected = labyrinth(image, channel_axis=-1, **API_OPTIONS)
    np.testing.assert_array_equal(read_image(tmp_path / "out.png"), expected)


def test_channel_axis_for_a_tiff(tmp_path):
    image = np.stack([gradient_image(np.uint16) for _ in range(3)])  # channels first
    write_image(tmp_path / "c.tif", image)
    argv = [
        "render",
        str(tmp_path / "c.tif"),
        "-o",
        str(tmp_path / "o.tif"),
        "--channel-axis",
        "0",
    ]
    assert main(argv + OPTIONS) == 0
    expected = labyrinth(image, channel_axis=0, **API_OPTIONS)
    np.testing.assert_array_equal(read_image(tmp_path / "o.tif"), expected)


def test_one_input_into_an_existing_directory(tmp_path):
    write_image(tmp_path / "a.tif", gradient_image(np.uint8))
    (tmp_path / "out").mkdir()
    assert main(["render", str(tmp_path / "a.tif"), "-o", str(tmp_path / "out")]) == 0
    assert (tmp_path / "out" / "a_labyrinth.tif").is_file()



def test_ome_results_keep_the_ome_suffix_whole(tmp_path):
    # they were named cells.ome_labyrinth.tif and img.ome_labyrinth.zarr: not .ome.tif
    import tifffile
    import zarr

    tifffile.imwrite(
        tmp_path / "cells.ome.tif", gradient_image(np.uint16)[None], ome=True,
        metadata={"axes": "CYX"},
    )  # fmt: skip
    zarr.create_array(str(tmp_path / "img.ome.zarr"), shape=(16, 16), dtype="u1")[...] = 9
    write_image(tmp_path / "cells.tif", gradient_image(np.uint8))  # its result: no collision
    inputs = [tmp_path / name for name in ("cells.ome.tif", "img.ome.zarr", "cells.tif")]
    assert main(["render", *map(str, inputs), "-o", str(tmp_path / "out"), *OPTIONS]) == 0
    names = sorted(os.listdir(tmp_path / "out"))
    assert names == ["cells_labyrinth.ome.tif", "cells_labyrinth.tif", "img_labyrinth.ome.zarr"]
    assert read_metadata(tmp_path / "out" / "cells_labyrinth.ome.tif").ome

# -- batches, stacks and sweeps -------------------------------------------------------------------


def test_several_inputs_into_a_new_directory(tmp_path, capsys):
    images = {
        "one.png": gradient_image(np.uint8),
        "two.tif": gradient_image(np.uint16),
        "three.tiff": gradient_image(np.float32),
    }
    for name, image in images.items():
        write_image(tmp_path / name, image)
    out = tmp_path / "results" / "nested"
    argv = ["render", *(str(tmp_path / n) for n in images), "-o", str(out), *OPTIONS]
    assert main(argv) == 0
    for name, image in images.items():
        stem, suffix = os.path.splitext(name)
        result = read_image(out / f"{stem}_labyrinth{suffix}")
        np.testing.assert_array_equal(result, labyrinth(image, **API_OPTIONS))
    captured = capsys.readouterr()
    assert len(captured.out.splitlines()) == 3
    assert "rendered 3 files" in captured.err
    assert leftovers(tmp_path) == []


@pytest.mark.parametrize("name", ["two.png", "two.TIF", "two.ome.tiff", "two.jpg", "two.bmp"])
def test_several_inputs_into_an_image_file_name_are_refused(tmp_path, capsys, name):
    # -o two.png made a directory two.png holding both results
    for stem in ("a", "b"):
        write_image(tmp_path / f"{stem}.png", gradient_image(np.uint8))
    output = tmp_path / name
    argv = ["render", str(tmp_path / "a.png"), str(tmp_path / "b.png"), "-o", str(output)]
    assert main([*argv, *OPTIONS]) == 2
    (line,) = error_lines(capsys.readouterr().err)
    assert f"-o {output}:" in line and "several inputs need an output directory" in line
    assert "image file" in line
    assert sorted(p.name for p in tmp_path.iterdir()) == ["a.png", "b.png"]
    # a directory of that name, or one named with a final /, is what the user asks for
    assert main([*argv[:-1], f"{output}/", *OPTIONS]) == 0
    assert sorted(os.listdir(output)) == ["a_labyrinth.png", "b_labyrinth.png"]
    assert main([*argv, "--overwrite", *OPTIONS]) == 0


@pytest.mark.parametrize("passes", [None, 3])
def test_stack(tmp_path, passes):
    image = gradient_image(np.uint8)
    write_image(tmp_path / "in.png", image)
    argv = [
        "render",
        str(tmp_path / "in.png"),
        "-o",
        str(tmp_path / "out"),
        "--stack",
        "--seed",
        "3",
    ]
    if passes is not None:
        argv += ["--passes", str(passes)]
    assert main(argv) == 0
    stack = read_image(tmp_path / "out" / "in_labyrinth_stack.tif")  # PNG input: TIFF output
    expected_passes = 4 if passes is None else passes
    assert stack.shape == (expected_passes + 1,) + image.shape
    assert stack.dtype == np.uint8
    np.testing.assert_array_equal(stack[0], image)
    np.testing.assert_array_equal(stack, labyrinth_stack(image, passes=expected_passes, seed=3))


def test_stack_to_a_tiff_file(tmp_path):
    image = gradient_image(np.float32)
    write_image(tmp_path / "in.tif", image)
    argv = [
        "render",
        str(tmp_path / "in.tif"),
        "-o",
        str(tmp_path / "s.tif"),
        "--stack",
        "--passes",
        "2",
    ]
    assert main(argv) == 0
    assert read_image(tmp_path / "s.tif").shape == (3,) + image.shape


@pytest.mark.parametrize(
    ("spec", "parameter", "values"),
    [
        ("variance_threshold=0.3,0.5,0.7", "variance_threshold", [0.3, 0.5, 0.7]),
        ("mean-threshold=0.05,0.12", "mean_threshold", [0.05, 0.12]),
        ("seed=1,2,3,4", "seed", [1, 2, 3, 4]),
        ("passes=0,1,2", "passes", [0, 1, 2]),
        ("border=inside,mirror", "border", ["inside", "mirror"]),
    ],
)
def test_sweep(tmp_path, spec, parameter, values):
    image = gradient_image(np.uint16)
    write_image(tmp_path / "in.tif", image)
    argv = ["render", str(tmp_path / "in.tif"), "-o", str(tmp_path / "out"), "--sweep", spec]
    assert main(argv) == 0
    sweep = read_image(tmp_path / "out" / "in_labyrinth_sweep.tif")
    assert sweep.shape == (len(values),) + image.shape
    np.testing.assert_array_equal(sweep, labyrinth_sweep(image, parameter, values))



def test_a_sweep_with_a_decimal_comma_is_refused_before_rendering(tmp_path, capsys):
    # --sweep variance_threshold=0,04 rendered the sweep [0, 4]
    write_image(tmp_path / "in.tif", gradient_image(np.uint16))
    argv = ["render", str(tmp_path / "in.tif"), "-o", str(tmp_path / "out"), "--sweep"]
    assert main([*argv, "variance_threshold=0,04"]) == 2
    assert "'0,04' has a decimal comma" in capsys.readouterr().err
    assert not (tmp_path / "out").exists()
    assert main([*argv, "variance_threshold=0.02 0.04"]) == 0  # spaces separate, as in napari
    assert read_image(tmp_path / "out" / "in_labyrinth_sweep.tif").shape[0] == 2


@pytest.mark.parametrize(
    ("spec", "message"),
    [
        # rendered the sweep [0.03, 0.05] with exit 0, the empty value skipped
        ("variance_threshold=0.03,,0.05", "value 2 of '0.03,,0.05' is empty (between 0.03 and"),
        ("variance_threshold=0.03,0.05,", "value 3 of '0.03,0.05,' is empty (after 0.05)"),
        ("seed=,1,2", "seed: value 1 of ',1,2' is empty (before 1)"),
        ("variance_threshold=,,", "type at least one value of variance_threshold to sweep"),
        ("variance_threshold=0.03,abc", "variance_threshold must be a number; got 'abc'"),
        ("variance_threshold=0.03:0.05", "got '0.03:0.05': a sweep has no range syntax"),
        ("passes=1-4", "got '1-4': a sweep has no range syntax"),
    ],
)
def test_a_malformed_sweep_is_refused_in_one_line_before_rendering(
    tmp_path, capsys, spec, message
):
    write_image(tmp_path / "in.tif", gradient_image(np.uint16))
    argv = ["render", str(tmp_path / "in.tif"), "-o", str(tmp_path / "out"), "--sweep", spec]
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert message in err and "Traceback" not in err
    assert len(err.strip().splitlines()) == 1
    assert not (tmp_path / "out").exists()

def test_stack_and_sweep_of_a_png_need_a_tiff_output(tmp_path, capsys):
    write_image(tmp_path / "in.png", gradient_image(np.uint8))
    for variant in (["--stack"], ["--sweep", "seed=1,2"]):
        argv = ["render", str(tmp_path / "in.png"), "-o", str(tmp_path / "out.png"), *variant]
        assert main(argv) == 2
        assert ".tif" in capsys.readouterr().err
    assert not (tmp_path / "out.png").exists()


# -- overwriting ----------------------------------------------------------------------------------


def test_refuses_to_overwrite_an_existing_output(tmp_path, capsys):
    write_image(tmp_path / "in.png", gradient_image(np.uint8))
    target = tmp_path / "out.png"
    target.write_bytes(b"keep me")
    assert main(["render", str(tmp_path / "in.png"), "-o", str(target)]) == 1
    assert target.read_bytes() == b"keep me"
    err = capsys.readouterr().err
    assert "out.png" in err and "--overwrite" in err and "Traceback" not in err
    assert main(["render", str(tmp_path / "in.png"), "-o", str(target), "--overwrite"]) == 0
    assert read_image(target).shape == (48, 40)


def test_refuses_to_overwrite_an_input(tmp_path, capsys):
    image = gradient_image(np.uint8)
    source = tmp_path / "in.png"
    write_image(source, image)
    before = source.read_bytes()
    assert main(["render", str(source), "-o", str(source), *OPTIONS]) == 1
    assert source.read_bytes() == before
    assert "input" in capsys.readouterr().err
    assert main(["render", str(source), "-o", str(source), "--overwrite", *OPTIONS]) == 0
    np.testing.assert_array_equal(read_image(source), labyrinth(image, **API_OPTIONS))
    assert leftovers(tmp_path) == []


def test_refusal_in_a_batch_renders_nothing(tmp_path):
    for name in ("a.png", "b.png"):
        write_image(tmp_path / name, gradient_image(np.uint8))
    out = tmp_path / "out"
    out.mkdir()
    (out / "b_labyrinth.png").write_bytes(b"old")
    argv = ["render", str(tmp_path / "a.png"), str(tmp_path / "b.png"), "-o", str(out)]
    assert main(argv) == 1
    assert sorted(os.listdir(out)) == ["b_labyrinth.png"]
    assert (out / "b_labyrinth.png").read_bytes() == b"old"


def test_result_of_one_input_may_not_replace_another_input(tmp_path, capsys):
    write_image(tmp_path / "a.png", gradient_image(np.uint8))
    write_image(tmp_path / "a_labyrinth.png", gradient_image(np.uint8))
    before = (tmp_path / "a_labyrinth.png").read_bytes()
    argv = [
        "render",
        str(tmp_path / "a.png"),
        str(tmp_path / "a_labyrinth.png"),
        "-o",
        str(tmp_path),
        "--overwrite",
    ]
    assert main(argv) == 2
    assert (tmp_path / "a_labyrinth.png").read_bytes() == before
    assert len(error_lines(capsys.readouterr().err)) == 1


def test_colliding_outputs_are_refused(tmp_path):
    for folder in ("x", "y"):
        (tmp_path / folder).mkdir()
        write_image(tmp_path / folder / "img.png", gradient_image(np.uint8))
    argv = [
        "render",
        str(tmp_path / "x" / "img.png"),
        str(tmp_path / "y" / "img.png"),
        "-o",
        str(tmp_path / "o"),
    ]
    assert main(argv) == 2


# -- failures -------------------------------------------------------------------------------------


def test_bad_file_in_a_batch(tmp_path, capsys):
    write_image(tmp_path / "good1.png", gradient_image(np.uint8))
    (tmp_path / "corrupt.png").write_bytes(b"\x89PNG\r\n\x1a\n but then garbage")
    write_image(tmp_path / "labels.tif", np.arange(48 * 40, dtype=np.int64).reshape(48, 40))
    write_image(tmp_path / "good2.tif", gradient_image(np.uint16))
    names = ["good1.png", "corrupt.png", "missing.png", "labels.tif", "notes.txt", "good2.tif"]
    (tmp_path / "notes.txt").write_text("not an image")
    out = tmp_path / "out"
    assert main(["render", *(str(tmp_path / n) for n in names), "-o", str(out)]) == 1
    captured = capsys.readouterr()
    assert "Traceback" not in captured.err
    errors = error_lines(captured.err)
    assert len(errors) == 4
    bad_files = ["corrupt.png", "missing.png", "labels.tif", "notes.txt"]
    for line, bad in zip(errors, bad_files, strict=True):
        assert line.startswith(f"napari-labyrinth: error: {tmp_path / bad}: ")
        assert len(line) > len(f"napari-labyrinth: error: {tmp_path / bad}: ")
    assert "int64" in errors[2]
    summary = captured.err.strip().splitlines()[-1]
    assert "rendered 2 of 6 files" in summary
    assert "corrupt.png" in summary and "labels.tif" in summary and "good1" not in summary
    assert (out / "good1_labyrinth.png").is_file()
    assert (out / "good2_labyrinth.tif").is_file()
    assert sorted(os.listdir(out)) == ["good1_labyrinth.png", "good2_labyrinth.tif"]


@pytest.mark.parametrize(
    "bad",
    [
        ["--passes", "-1"],
        ["--mean-threshold", "-0.5"],
        ["--variance-threshold", "nan"],
        ["--max-tries", "100000000"],
        ["--tone-limits", "10", "5"],
        ["--sweep", "colour=1,2"],
        ["--sweep", "passes=1,-2"],
        ["--sweep", "seed=1,x"],
        ["--sweep", "variance_threshold=0.1", "--variance-threshold", "0.2"],
        ["--sweep", "border=inside,mirror", "--set", "border=wrap"],
        ["--set", "border=sideways"],
        ["--set", "colour=blue"],
        ["--set", "passes=2", "--passes", "3"],
        ["--set", "passes=2.5"],
        ["--set", "tones=1,2"],
        ["--passes", "5000"],
        ["--include-centre", "maybe"],
        ["--sweep", "variance_threshold=auto,0.04"],
    ],
)
def test_bad_parameter_is_one_line_without_traceback(tmp_path, capsys, bad):
    write_image(tmp_path / "in.png", gradient_image(np.uint8))
    code = main(["render", str(tmp_path / "in.png"), "-o", str(tmp_path / "out.tif"), *bad])
    assert code == 2
    err = capsys.readouterr().err
    assert "Traceback" not in err
    assert len(error_lines(err)) == 1
    assert not (tmp_path / "out.tif").exists()


@pytest.mark.parametrize(
    "argv",
    [
        ["render", "in.png"],  # no -o
        ["render", "-o", "out"],  # no input
        ["render", "in.png", "-o", "o", "--passes", "two"],
        ["render", "in.png", "-o", "o", "--seed", "-1"],
        ["render", "in.png", "-o", "o", "--preset", "nonsense"],
        ["render", "in.png", "-o", "o", "--stack", "--sweep", "seed=1"],
        ["render", "in.png", "-o", "o", "--set", "border"],
        ["frobnicate"],
        [],
    ],
)
def test_usage_errors_exit_2(argv, capsys):
    assert main(argv) == 2
    assert "Traceback" not in capsys.readouterr().err


@pytest.mark.parametrize(
    "output,said", [("", "is empty"), ("  ", "is empty"), ("-", "not supported")]
)
def test_an_empty_or_dash_output_is_refused(tmp_path, capsys, monkeypatch, output, said):
    # "" wrote into the current directory, "-" made a directory named "-"
    write_image(tmp_path / "in.png", gradient_image(np.uint8))
    monkeypatch.chdir(tmp_path)
    assert main(["render", "in.png", "-o", output]) == 2
    assert said in capsys.readouterr().err
    assert sorted(p.name for p in tmp_path.iterdir()) == ["in.png"]


def test_unsupported_output_format(tmp_path, capsys):
    write_image(tmp_path / "in.png", gradient_image(np.uint8))
    assert main(["render", str(tmp_path / "in.png"), "-o", str(tmp_path / "out.gif")]) == 2
    assert "unknown image format" in capsys.readouterr().err


def test_float_result_cannot_go_to_png(tmp_path, capsys):
    write_image(tmp_path / "in.tif", gradient_image(np.float32))
    assert main(["render", str(tmp_path / "in.tif"), "-o", str(tmp_path / "out.png")]) == 1
    (line,) = error_lines(capsys.readouterr().err)
    assert "in.tif" in line and ".tif" in line
    assert leftovers(tmp_path) == [] and not (tmp_path / "out.png").exists()


def _refuses_new_files(directory: Path) -> bool:
    try:
        with open(directory / ".probe", "x"):
            pass
    except OSError:
        return True
    os.unlink(directory / ".probe")
    return False


@pytest.mark.skipif(
    not os.path.isdir("/proc") or not _refuses_new_files(Path("/proc")),
    reason="no /proc that refuses new files",
)
@pytest.mark.parametrize("name", ["x.png", "x.tif", "x.zarr", "x.bmp"])
def test_an_output_that_cannot_be_written_is_named_with_the_reason(tmp_path, capsys, name):
    # said "a.png: No such file or directory: /proc/.x.png.0a7c9c-18609-5ef55aa3.tmp"
    write_image(tmp_path / "a.png", gradient_image(np.uint8))
    output = f"/proc/{name}"
    assert main(["render", str(tmp_path / "a.png"), "-o", output, "--passes", "1"]) == 1
    (line,) = error_lines(capsys.readouterr().err)
    assert line == f"napari-labyrinth: error: cannot write {output}: No such file or directory"


def test_an_output_directory_that_takes_no_file_is_named(tmp_path, capsys, monkeypatch):
    from napari_labyrinth import io as file_io

    write_image(tmp_path / "a.png", gradient_image(np.uint8))
    read_only = tmp_path / "read-only"
    read_only.mkdir()
    argv = ["render", str(tmp_path / "a.png"), "-o", str(read_only / "x.png"), "--passes", "1"]
    if sys.platform != "win32":
        read_only.chmod(0o555)
    try:
        if not _refuses_new_files(read_only):  # root writes there: as a read-only mount
            monkeypatch.setattr(file_io.os, "access", lambda path, mode: False)
        assert main(argv) == 1
    finally:
        read_only.chmod(0o755)
    (line,) = error_lines(capsys.readouterr().err)
    assert line.startswith(f"napari-labyrinth: error: cannot write {read_only / 'x.png'}: ")
    assert line.count("x.png") == 1 and ".tmp" not in line and "a.png" not in line
    assert os.listdir(read_only) == []


def test_a_write_that_fails_names_the_output_not_the_input(tmp_path, capsys, monkeypatch):
    from napari_labyrinth.io import _atomic

    write_image(tmp_path / "a.png", gradient_image(np.uint8))
    real = _atomic.create_temporary

    def full(directory, name, made):
        temporary, handle = real(directory, name, made)
        handle.close()
        raise OSError(28, "No space left on device", str(temporary))

    monkeypatch.setattr(_atomic, "create_temporary", full)
    monkeypatch.setattr("napari_labyrinth.io.create_temporary", full)
    output = tmp_path / "out" / "a_labyrinth.png"
    assert main(["render", str(tmp_path / "a.png"), "-o", str(output), "--passes", "1"]) == 1
    (line,) = error_lines(capsys.readouterr().err)
    assert line == f"napari-labyrinth: error: cannot write {output}: No space left on device"
    assert leftovers(tmp_path) == []


def test_version(capsys):
    assert main(["--version"]) == 0
    assert capsys.readouterr().out.strip() == f"napari-labyrinth {__version__}"


def test_help(capsys):
    assert main(["render", "--help"]) == 0
    out = capsys.readouterr().out
    for flag in ("--stack", "--sweep", "--overwrite", "--tone-limits", "--channel-axis"):
        assert flag in out


# -- demo -----------------------------------------------------------------------------------------


def test_demo_writes_the_files_it_prints(tmp_path, capsys):
    out = tmp_path / "demo"
    assert main(["demo", "-o", str(out)]) == 0
    printed = [Path(line) for line in capsys.readouterr().out.splitlines()]
    assert len(printed) == 8
    assert all(path.is_absolute() and path.is_file() for path in printed)
    assert sorted(p.name for p in printed) == sorted(os.listdir(out))
    names = {p.name for p in printed}
    for sample in ("nematic_schlieren", "camera"):
        assert {
            f"{sample}.png",
            f"{sample}_labyrinth.png",
            f"{sample}_labyrinth_stack.tif",
            f"{sample}_comparison.png",
        } <= names
        source = read_image(out / f"{sample}.png")
        assert source.dtype == np.uint8 and source.ndim == 2
        # The demo renders exactly what it writes, so `render` reproduces it.
        np.testing.assert_array_equal(
            read_image(out / f"{sample}_labyrinth.png"), labyrinth(source)
        )
        stack = read_image(out / f"{sample}_labyrinth_stack.tif")
        assert stack.shape == (5,) + source.shape
        comparison = read_image(out / f"{sample}_comparison.png")
        height, width = source.shape
        band = LABEL_HEIGHT
        assert comparison.shape == (band + height, 3 * width + 2 * 4)
        assert comparison.dtype == np.uint8
        np.testing.assert_array_equal(comparison[band:, :width], source)
        np.testing.assert_array_equal(comparison[band:, width + 4 : 2 * width + 4], stack[1])
        np.testing.assert_array_equal(comparison[:, width : width + 4], 255)
        np.testing.assert_array_equal(comparison[band:, -width:], stack[4])
        for panel in range(3):  # each label band holds dark text on white
            label = comparison[:band, panel * (width + 4) : panel * (width + 4) + width]
            assert label.max() == 255 and label.min() < 100
        # every rendering reproduces from its record
        for name in (f"{sample}_labyrinth.png", f"{sample}_labyrinth_stack.tif"):
            assert main(["reproduce", str(out / name)]) == 0


def test_demo_refuses_existing_files(tmp_path, capsys):
    out = tmp_path / "demo"
    out.mkdir()
    (out / "camera.png").write_bytes(b"mine")
    assert main(["demo", "-o", str(out)]) == 1
    err = capsys.readouterr().err
    assert "camera.png" in err and "--overwrite" in err and "Traceback" not in err
    assert (out / "camera.png").read_bytes() == b"mine"
    assert os.listdir(out) == ["camera.png"]
    assert main(["demo", "-o", str(out), "--overwrite"]) == 0
    assert read_image(out / "camera.png").shape == (512, 512)


# -- the installed script -------------------------------------------------------------------------


def installed_script() -> str | None:
    here = Path(sys.executable).parent
    return shutil.which("napari-labyrinth", path=str(here)) or shutil.which("napari-labyrinth")


@pytest.mark.subprocess
@pytest.mark.skipif(installed_script() is None, reason="console script not installed")
def test_installed_console_script(tmp_path):
    script = installed_script()
    image = gradient_image(np.uint8)
    write_image(tmp_path / "in.png", image)
    (tmp_path / "bad.png").write_bytes(b"junk")
    env = dict(os.environ, NO_COLOR="1")
    done = subprocess.run(
        [
            script,
            "render",
            str(tmp_path / "in.png"),
            str(tmp_path / "bad.png"),
            "-o",
            str(tmp_path / "out"),
            *OPTIONS,
        ],
        capture_output=True,
        text=True,
        env=env,
        timeout=300,
    )
    assert done.returncode == 1, done.stderr
    assert "Traceback" not in done.stderr
    assert f"napari-labyrinth: error: {tmp_path / 'bad.png'}: " in done.stderr
    assert "rendered 1 of 2 files; failed:" in done.stderr
    result = read_image(tmp_path / "out" / "in_labyrinth.png")
    np.testing.assert_array_equal(result, labyrinth(image, **API_OPTIONS))

    version = subprocess.run([script, "--version"], capture_output=True, text=True, timeout=60)
    assert version.returncode == 0 and __version__ in version.stdout

    usage = subprocess.run([script, "render"], capture_output=True, text=True, timeout=60)
    assert usage.returncode == 2 and "usage:" in usage.stderr


def test_every_one_word_parameter_has_a_flag_with_its_defaults_in_help(capsys):
    from napari_labyrinth.core.parameters import PARAMETERS, SWEEPABLE, format_value
    from napari_labyrinth.core.presets import DEFAULT_PRESET, PRESETS

    assert main(["render", "--help"]) == 0
    out = " ".join(capsys.readouterr().out.split())
    for name, parameter in SWEEPABLE.items():
        assert "--" + name.replace("_", "-") in out, name
    assert f"(default 0.04 with the {DEFAULT_PRESET} preset; paper 0.5)" in out
    assert f"(default 4 with the {DEFAULT_PRESET} preset; paper 1)" in out  # passes
    for name, parameter in PARAMETERS.items():
        if parameter.kind == "tones":
            continue
        default = format_value(PRESETS[DEFAULT_PRESET][name])
        text = f"default {default} with the {DEFAULT_PRESET} preset; paper "
        assert text + format_value(parameter.paper) in out, name


def test_tone_ranges_in_help_read_as_they_are_typed(capsys):
    # printed "(default (0.0, 10.0, 91.66666666666667, 173.33333333333334, 255.0) with ..."
    assert main(["render", "--help"]) == 0
    out = " ".join(capsys.readouterr().out.split())
    assert "(default 0,10,91.67,173.3,255 with the labyrinth preset; paper 3)" in out
    assert "91.666" not in out and "(0.0," not in out


@pytest.mark.parametrize(
    "flag,assignment",
    [
        (["--border", "mirror"], ["--set", "border=mirror"]),
        (["--include-centre", "true"], ["--set", "include_centre=yes"]),
        (["--tone-ranges", "10,120,255"], ["--set", "tone-ranges=10, 120, 255"]),
    ],
)
def test_a_parameter_flag_and_set_give_the_same_rendering(tmp_path, flag, assignment):
    write_image(tmp_path / "in.tif", gradient_image(np.uint16))
    for name, extra in (("flag", flag), ("set", assignment)):
        argv = ["render", str(tmp_path / "in.tif"), "-o", str(tmp_path / f"{name}.tif")]
        assert main([*argv, "--passes", "1", *extra]) == 0
    np.testing.assert_array_equal(
        read_image(tmp_path / "flag.tif"), read_image(tmp_path / "set.tif")
    )
