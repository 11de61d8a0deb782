"""Every shell command and Python snippet of README.md runs, on small inputs of the same names.

The fenced ``bash`` and ``python`` blocks are extracted; each ``napari-labyrinth``
command runs through ``cli.main`` (in this process: seconds, not a process each) in a
directory holding small files named as in the README, and must exit with 0; each
``make`` target named must exist (``make -n``: a dry run; ``make test`` is what runs
this file); each Python block runs as written.
"""

from __future__ import annotations

import re
import shlex
import shutil
import subprocess
from pathlib import Path

import numpy as np
import pytest

from napari_labyrinth.cli import main

ROOT = Path(__file__).resolve().parents[1]
README = ROOT / "README.md"
FENCE = re.compile(r"^```(\w*)\n(.*?)^```", re.S | re.M)


def blocks(language: str) -> list[str]:
    return [body for lang, body in FENCE.findall(README.read_text()) if lang == language]


def block_commands(body: str) -> list[str]:
    """The commands of a shell block, comments dropped."""
    lines = []
    for line in body.splitlines():
        words = shlex.split(line, comments=True)
        if words:
            lines.append(" ".join(shlex.quote(w) for w in words))
    return lines


def commands() -> list[str]:
    return [command for body in blocks("bash") for command in block_commands(body)]


def test_the_readme_has_commands_and_snippets():
    assert len(commands()) >= 10 and len(blocks("python")) >= 2
    assert all(c.split()[0] in ("napari-labyrinth", "make") for c in commands()), commands()


@pytest.fixture(scope="module")
def inputs(tmp_path_factory):
    """A directory with small files named as in the README's commands."""
    import imageio.v3 as iio
    import tifffile
    import zarr

    rng = np.random.default_rng(0)
    here = tmp_path_factory.mktemp("readme")
    grey = rng.integers(0, 256, (24, 32), dtype=np.uint8)
    rgb = rng.integers(0, 256, (24, 32, 3), dtype=np.uint8)
    stack16 = rng.integers(100, 4000, (3, 24, 32), dtype=np.uint16)
    tifffile.imwrite(here / "cells.tif", stack16[0])
    tifffile.imwrite(here / "big_stack.tif", stack16, photometric="minisblack")
    tifffile.imwrite(here / "ihc.tif", rgb, photometric="rgb")
    for name in ("a.png", "b.png"):
        iio.imwrite(here / name, grey)
    iio.imwrite(here / "rgb.png", rgb)
    iio.imwrite(here / "photo.jpg", rgb)
    zarr.create_array(here / "movie.zarr", shape=stack16.shape, dtype="uint16")[...] = stack16
    ome = zarr.open_group(here / "image.ome.zarr", mode="w")
    ome.create_array("0", shape=stack16.shape, dtype="uint16")[...] = stack16
    scale = {"type": "scale", "scale": [2.0, 1.0, 1.0]}
    ome.attrs["ome"] = {
        "version": "0.5",
        "multiscales": [
            {
                "axes": [{"name": n, "type": "space", "unit": "micrometer"} for n in "zyx"],
                "datasets": [{"path": "0", "coordinateTransformations": [scale]}],
            }
        ],
    }
    plate = zarr.open_group(here / "plate.zarr", mode="w")
    plate.create_array("raw", shape=stack16.shape, dtype="uint16")[...] = stack16
    plate.create_array("mask", shape=stack16.shape, dtype="uint8")
    return here


@pytest.mark.parametrize("index", range(len(blocks("bash"))))
def test_readme_commands(index, inputs, monkeypatch, capsys):
    """The commands of one shell block, in order (``reproduce`` reads what ``render`` wrote)."""
    monkeypatch.chdir(inputs)
    for command in block_commands(blocks("bash")[index]):
        words = shlex.split(command)
        if words[0] == "make":
            if shutil.which("make") is None:
                continue
            dry = subprocess.run(
                ["make", "-n", *words[1:]], cwd=ROOT, capture_output=True, text=True
            )
            assert dry.returncode == 0, f"{command}: {dry.stderr}"
            continue
        again = ["--overwrite"] if words[1] in ("render", "demo") else []
        code = main(words[1:] + again)
        assert code == 0, f"{command}: {capsys.readouterr().err}"


@pytest.mark.parametrize("index", range(len(blocks("python"))))
def test_readme_python(index, inputs, monkeypatch):
    monkeypatch.chdir(inputs)
    shutil.rmtree(inputs / "movie_labyrinth_paper.zarr", ignore_errors=True)
    exec(compile(blocks("python")[index], f"README.md python block {index}", "exec"), {})


def test_the_sweep_example_brackets_the_default_preset():
    from napari_labyrinth.core.presets import DEFAULT_PRESET, PRESETS

    centre = PRESETS[DEFAULT_PRESET]["variance_threshold"]
    sweeps = [c for c in commands() if "--sweep variance_threshold=" in c]
    assert sweeps
    for command in sweeps:
        values = [float(v) for v in command.split("variance_threshold=")[1].split()[0].split(",")]
        assert min(values) < centre < max(values) and max(values) < 2 * centre
