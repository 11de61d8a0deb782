"""Every shell command and Python block of README.md and docs/*.md runs, on small inputs.

The fenced ``bash`` and ``python`` blocks of each page are extracted (other fences, such as
a bare one holding ``pip install`` or a benchmark's output, are text); each
``napari-labyrinth`` command runs through ``cli.main`` (in this process: seconds, not a
process each) in a directory holding small files named as in the pages, and must exit with
0; each ``make`` target named must exist (``make -n``: a dry run; ``make test`` is what runs
this file); each Python block runs as written, in the same directory.
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
PAGES = [README, *sorted((ROOT / "docs").glob("*.md"))]
FENCE = re.compile(r"^```(\w*)\n(.*?)^```", re.DOTALL | re.MULTILINE)

#: The README is the newcomer's two minutes: what it is, install, a few examples, where to go.
README_LINES = 150


def page_name(page: Path) -> str:
    return page.relative_to(ROOT).as_posix()


def blocks(page: Path, language: str) -> list[str]:
    return [body for lang, body in FENCE.findall(page.read_text()) if lang == language]


def block_commands(body: str) -> list[str]:
    """The commands of a shell block, comments dropped."""
    lines = []
    for line in body.splitlines():
        words = shlex.split(line, comments=True)
        if words:
            lines.append(" ".join(shlex.quote(w) for w in words))
    return lines


def commands(pages=PAGES) -> list[str]:
    return [c for page in pages for body in blocks(page, "bash") for c in block_commands(body)]


def numbered(language: str) -> list:
    """``(page, index)`` of every block of ``language``, with a readable test id."""
    return [
        pytest.param(page, index, id=f"{page_name(page)}-{index}")
        for page in PAGES
        for index in range(len(blocks(page, language)))
    ]


def test_the_pages_have_commands_and_snippets():
    assert len(commands()) >= 30 and sum(len(blocks(p, "python")) for p in PAGES) >= 8
    assert all(c.split()[0] in ("napari-labyrinth", "make") for c in commands()), commands()
    readme = commands([README])
    assert "make demo" in readme and "make test" in readme and blocks(README, "python")


def test_the_readme_is_short_and_its_links_resolve():
    text = README.read_text()
    assert len(text.splitlines()) <= README_LINES
    for target in re.findall(r"\]\(([^)#\s]+)(?:#[^)]*)?\)", text):
        if "://" not in target:
            assert (ROOT / target).exists(), f"README.md links to {target}, which is missing"


@pytest.fixture(scope="module")
def inputs(tmp_path_factory):
    """A directory with small files named as in the pages' commands and snippets."""
    import imageio.v3 as iio
    import tifffile
    import zarr

    rng = np.random.default_rng(0)
    here = tmp_path_factory.mktemp("docs")
    grey = rng.integers(0, 256, (24, 32), dtype=np.uint8)
    rgb = rng.integers(0, 256, (24, 32, 3), dtype=np.uint8)
    stack16 = rng.integers(100, 4000, (3, 24, 32), dtype=np.uint16)
    tifffile.imwrite(here / "cells.tif", stack16[0])
    tifffile.imwrite(here / "big_stack.tif", stack16, photometric="minisblack")
    tifffile.imwrite(here / "ihc.tif", rgb, photometric="rgb")
    tifffile.imwrite(here / "grey_rgb.tif", rgb, photometric="minisblack")  # 3 planes, unnamed
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
    plane = rng.integers(100, 4000, (384, 320), dtype=np.uint16)  # "one plane too large"
    zarr.create_array(here / "big.zarr", shape=plane.shape, chunks=(32, 320), dtype="uint16")[
        ...
    ] = plane
    tifffile.imwrite(here / "big.tif", plane)
    plate = zarr.open_group(here / "plate.zarr", mode="w")
    plate.create_array("raw", shape=stack16.shape, dtype="uint16")[...] = stack16
    plate.create_array("mask", shape=stack16.shape, dtype="uint8")
    # an output of `render`, as the pages' first command writes it, for the snippets reading one
    rendered = ["render", "cells.tif", "-o", "cells_labyrinth.tif", "--passes", "4", "--seed", "1"]
    with pytest.MonkeyPatch.context() as patch:
        patch.chdir(here)
        assert main(rendered) == 0
    return here


@pytest.mark.subprocess
@pytest.mark.parametrize(("page", "index"), numbered("bash"))
def test_page_commands(page, index, inputs, monkeypatch, capsys):
    """The commands of one shell block, in order (``reproduce`` reads what ``render`` wrote)."""
    monkeypatch.chdir(inputs)
    for command in block_commands(blocks(page, "bash")[index]):
        words = shlex.split(command)
        if words[0] == "make":
            if shutil.which("make") is None:
                continue
            dry = subprocess.run(
                ["make", "-n", *words[1:]], cwd=ROOT, capture_output=True, text=True, check=False
            )
            assert dry.returncode == 0, f"{command}: {dry.stderr}"
            continue
        again = ["--overwrite"] if words[1] in ("render", "demo") else []
        code = main(words[1:] + [word for word in again if word not in words])
        assert code == 0, f"{page_name(page)}: {command}: {capsys.readouterr().err}"


@pytest.mark.parametrize(("page", "index"), numbered("python"))
def test_page_python(page, index, inputs, monkeypatch):
    monkeypatch.chdir(inputs)
    shutil.rmtree(inputs / "movie_labyrinth_paper.zarr", ignore_errors=True)
    name = f"{page_name(page)} python block {index}"
    exec(compile(blocks(page, "python")[index], name, "exec"), {})  # noqa: S102 - the pages run as written


def test_the_sweep_examples_bracket_the_default_preset():
    from napari_labyrinth.core.presets import DEFAULT_PRESET, PRESETS

    centre = PRESETS[DEFAULT_PRESET]["variance_threshold"]
    sweeps = [c for c in commands() if "--sweep variance_threshold=" in c]
    assert sweeps
    for command in sweeps:
        values = [float(v) for v in command.split("variance_threshold=")[1].split()[0].split(",")]
        assert min(values) < centre < max(values) and max(values) < 2 * centre
