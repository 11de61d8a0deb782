"""Every shell command and Python block of README.md and docs/*.md runs, on small inputs.

The fenced ``bash`` and ``python`` blocks of each page are extracted (other fences, such as
a bare one holding ``pip install`` or a benchmark's output, are text); each
``napari-labyrinth`` command runs through ``cli.main`` (in this process: seconds, not a
process each) in a directory holding small files named as in the pages, and must exit with
0; each ``make`` target named must exist (``make -n``: a dry run; ``make test`` is what runs
this file); each Python block runs as written, in the same directory.

A line of a Python block that shows a value says so with an arrow, and the value is checked::

    metadata.channel_axis, metadata.colour   # -> (2, 'TIFF photometric RGB, 3 samples per pixel')
    resolve_parameters("paper", passes=3).passes   # -> 3  # words may follow

The expression's value must equal the Python literal after ``# ->`` (:func:`shows`): ``...``
stands for any value, a dict holding ``...`` names keys the value has (it may have more), and
a float matches a value that rounds to it at the digits shown. Any other comment is prose.
"""

from __future__ import annotations

import ast
import decimal
import io
import re
import shlex
import shutil
import subprocess
import tokenize
from collections.abc import Mapping
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


#: The comment of a line of a Python block that shows the value of its expression.
ARROW = "# ->"


def shown_values(source: str) -> dict[int, str]:
    """``{line: value text}`` of the lines of ``source`` whose comment is ``# -> value``."""
    shown = {}
    for token in tokenize.generate_tokens(io.StringIO(source).readline):
        if token.type == tokenize.COMMENT and token.string.startswith(ARROW):
            shown[token.start[0]] = token.string[len(ARROW) :].strip()
    return shown


def shown_literal(text: str, where: str):
    """The Python literal a ``# ->`` comment shows (words after ``  #`` are prose)."""
    candidates = [text] + [text[:i] for i in range(len(text)) if text.startswith("  #", i)]
    for candidate in candidates:
        try:
            return ast.literal_eval(candidate.strip())
        except (ValueError, SyntaxError, TypeError, MemoryError, RecursionError):
            continue
    raise AssertionError(f"{where}: '{ARROW} {text}' shows no Python literal")


def shows(actual, expected) -> bool:
    """Whether ``actual`` is the value a page shows as ``expected`` (see the module's doc)."""
    if expected is Ellipsis:
        return True
    if isinstance(expected, dict):
        if not isinstance(actual, Mapping):
            return False
        partial = any(value is Ellipsis for value in expected.values())
        if not partial and set(actual) != set(expected):
            return False
        return all(key in actual and shows(actual[key], v) for key, v in expected.items())
    if isinstance(expected, (tuple, list)):
        return (
            isinstance(actual, type(expected))
            and len(actual) == len(expected)
            and all(shows(a, e) for a, e in zip(actual, expected))
        )
    if isinstance(expected, bool) or isinstance(actual, (bool, np.bool_)):
        return isinstance(actual, (bool, np.bool_)) and bool(actual) is expected
    if isinstance(expected, float) and isinstance(actual, (int, float, np.number)):
        digits = len(decimal.Decimal(repr(expected)).normalize().as_tuple().digits)
        return float(f"{float(actual):.{digits}g}") == expected
    if isinstance(expected, (int, str, bytes, type(None))):
        try:
            return type(actual) is not np.ndarray and bool(actual == expected)
        except (TypeError, ValueError):
            return False
    return False


class _ShownValuesChecked(ast.NodeTransformer):
    """Every expression statement whose last line shows a value becomes a check of it."""

    def __init__(self, source: str, name: str):
        self.source, self.name = source, name
        self.shown = shown_values(source)

    def visit_Expr(self, node: ast.Expr) -> ast.AST:
        text = self.shown.pop(node.end_lineno, None)
        if text is None:
            return node
        where = f"{self.name}, line {node.end_lineno}"
        shown_literal(text, where)  # a misused arrow fails before the block runs
        check = ast.Call(
            func=ast.Name("__shown__", ast.Load()),
            args=[
                node.value,
                ast.Constant(text),
                ast.Constant(ast.get_source_segment(self.source, node.value)),
                ast.Constant(where),
            ],
            keywords=[],
        )
        return ast.copy_location(ast.Expr(check), node)


def _shown(actual, text: str, expression: str, where: str) -> None:
    if not shows(actual, shown_literal(text, where)):
        raise AssertionError(f"{where}: {expression} is {actual!r}; the page shows {text}")


def run_block(source: str, name: str) -> dict:
    """Run a Python block of a page as written, checking the values its lines show."""
    checked = _ShownValuesChecked(source, name)
    tree = ast.fix_missing_locations(checked.visit(ast.parse(source, name)))
    if checked.shown:
        line = min(checked.shown)
        raise AssertionError(
            f"{name}, line {line}: '{ARROW}' ends no expression statement (an assignment "
            "shows no value: write the expression on a line of its own)"
        )
    namespace = {"__shown__": _shown}
    exec(compile(tree, name, "exec"), namespace)  # noqa: S102 - the pages run as written
    return namespace


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
    run_block(blocks(page, "python")[index], f"{page_name(page)} python block {index}")


@pytest.mark.parametrize(
    "line",
    [
        "1 + 1  # -> 2",
        "'a b'.split()  # -> ['a', 'b']",
        "(2, 'RGB')  # -> (2, 'RGB')",
        "{'a': 1, 'b': 2}  # -> {'a': ..., 'b': 2}",
        "{'a': 1, 'b': 2}  # -> {'b': ...}",
        "0.0070710678  # -> 0.0071",
        "np.float64(0.5)  # -> 0.5",
        "np.int64(3)  # -> 3  # a count",
        "None  # -> None",
        "'V = 1: x'  # -> 'V = 1: x'",
        "x = 1  # a comment in words: not checked",
    ],
)
def test_a_shown_value_that_is_the_value_passes(line):
    run_block(f"import numpy as np\n{line}\n", "page")


@pytest.mark.parametrize(
    "line, said",
    [
        ("1 + 1  # -> 3", "1 + 1 is 2; the page shows 3"),
        ("(2, 'RGB')  # -> (-1, 'RGB')", "is (2, 'RGB'); the page shows (-1, 'RGB')"),
        ("(2, 'RGB')  # -> [2, 'RGB']", "the page shows [2, 'RGB']"),
        ("{'a': 1, 'b': 2}  # -> {'a': 1}", "the page shows {'a': 1}"),
        ("{'a': 1}  # -> {'c': ...}", "the page shows {'c': ...}"),
        ("0.0075  # -> 0.0071", "the page shows 0.0071"),
        ("True  # -> 1", "the page shows 1"),
        ("np.arange(2)  # -> 0", "the page shows 0"),
        ("'abc'  # -> 'abd'", "'abc' is 'abc'; the page shows 'abd'"),
    ],
)
def test_a_shown_value_the_code_does_not_give_fails(line, said):
    with pytest.raises(AssertionError, match=re.escape(said)) as raised:
        run_block(f"import numpy as np\n{line}\n", "page")
    assert str(raised.value).startswith("page, line 2: ")


@pytest.mark.parametrize(
    "line, said",
    [
        ("x = 2  # -> 2", "ends no expression statement"),
        ("1 + 1  # -> two", "shows no Python literal"),
    ],
)
def test_a_misused_arrow_fails(line, said):
    with pytest.raises(AssertionError, match=said):
        run_block(f"{line}\n", "page")


def test_a_value_shown_in_a_loop_is_checked_at_every_turn():
    run_block("for n in (1, 1):\n    n  # -> 1\n", "page")
    with pytest.raises(AssertionError, match="n is 2; the page shows 1"):
        run_block("for n in (1, 2):\n    n  # -> 1\n", "page")


def test_the_pages_show_values_with_the_arrow():
    """A comment that is a bare Python literal looks like a shown value: it must say so with
    ``# ->`` (and so be checked)."""
    unchecked = []
    for page in PAGES:
        for index, body in enumerate(blocks(page, "python")):
            tokens = tokenize.generate_tokens(io.StringIO(body).readline)
            for token in tokens:
                if token.type != tokenize.COMMENT or token.string.startswith(ARROW):
                    continue
                try:
                    ast.literal_eval(token.string[1:].strip())
                except (ValueError, SyntaxError, TypeError, MemoryError, RecursionError):
                    continue
                unchecked.append(f"{page_name(page)} block {index}: {token.line.strip()}")
    assert unchecked == []
    shown = [shown_values(body) for page in PAGES for body in blocks(page, "python")]
    assert sum(map(len, shown)) >= 6


def test_the_sweep_examples_bracket_the_default_preset():
    from napari_labyrinth.core.presets import DEFAULT_PRESET, PRESETS

    centre = PRESETS[DEFAULT_PRESET]["variance_threshold"]
    sweeps = [c for c in commands() if "--sweep variance_threshold=" in c]
    assert sweeps
    for command in sweeps:
        values = [float(v) for v in command.split("variance_threshold=")[1].split()[0].split(",")]
        assert min(values) < centre < max(values) and max(values) < 2 * centre
