"""The package's imports go one way, in the order docs/architecture.md states.

The layers are read from the table of ``docs/architecture.md`` (between its
``<!-- layers -->`` markers): each row a layer, lowest first, naming modules or
packages of ``napari_labyrinth``. Every import of one of the package's own modules,
at module level or inside a function, is read from the source (``ast``) and must go
to the importer's own layer or a lower one; the imports form no circle; an import of
the package's own modules inside a function says why in a comment (it keeps an
optional dependency or start-up time away from the importer); and nothing outside
``_qt`` imports Qt or napari.
"""

from __future__ import annotations

import ast
import re
from dataclasses import dataclass
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
PACKAGE = ROOT / "src" / "napari_labyrinth"
ARCHITECTURE = ROOT / "docs" / "architecture.md"
NAME = "napari_labyrinth"
#: Imported only by ``_qt``: the GUI toolkits and napari itself.
GUI_MODULES = ("napari", "qtpy", "PyQt5", "PyQt6", "PySide2", "PySide6", "magicgui", "superqt", "vispy")


@dataclass(frozen=True)
class Import:
    importer: str
    imported: str
    line: int
    in_function: bool
    reason: str  # the comment on the import's line or the line above ('' if none)


def _modules() -> dict[str, Path]:
    """Dotted module name -> file, for every module of the package (a package is its __init__)."""
    modules = {}
    for path in sorted(PACKAGE.rglob("*.py")):
        parts = path.relative_to(PACKAGE.parent).with_suffix("").parts
        if parts[-1] == "__init__":
            parts = parts[:-1]
        modules[".".join(parts)] = path
    return modules


MODULES = _modules()


def _is_package(module: str) -> bool:
    return MODULES[module].name == "__init__.py"


def _targets(node: ast.Import | ast.ImportFrom, importer: str) -> list[str]:
    """The package's own modules an import statement imports."""
    if isinstance(node, ast.Import):
        return [alias.name for alias in node.names if alias.name in MODULES]
    if node.level:
        base = importer.split(".")
        if not _is_package(importer):
            base = base[:-1]
        base = base[: len(base) - node.level + 1]
        source = ".".join(base + ([node.module] if node.module else []))
    else:
        source = node.module or ""
    if source.split(".")[0] != NAME or source not in MODULES:
        return []
    submodules = [f"{source}.{alias.name}" for alias in node.names]
    found = [name for name in submodules if name in MODULES]
    # ``from package import function`` imports the package itself (its __init__)
    return found + ([source] if len(found) < len(submodules) else [])


def _comment(lines: list[str], number: int) -> str:
    """The comment on line ``number`` (1-based), on an import just above it (a group of
    imports shares one reason), or on the line above the group."""
    index = number - 1
    while index >= 0:
        text = lines[index]
        if "#" in text:
            return text.split("#", 1)[1].strip()
        if index < number - 1 and not text.strip().startswith(("from ", "import ")):
            return ""
        index -= 1
    return ""


def _under_type_checking(node: ast.AST, parents: dict) -> bool:
    while node in parents:
        node = parents[node]
        if isinstance(node, ast.If) and "TYPE_CHECKING" in ast.unparse(node.test):
            return True
    return False


def _in_function(node: ast.AST, parents: dict) -> bool:
    while node in parents:
        node = parents[node]
        if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef, ast.Lambda)):
            return True
    return False


def _read_imports() -> tuple[list[Import], list[tuple[str, str, int]]]:
    """The package's own imports, and the imports of GUI modules (module, name, line)."""
    found, gui = [], []
    for module, path in MODULES.items():
        source = path.read_text()
        lines = source.splitlines()
        tree = ast.parse(source)
        parents = {child: node for node in ast.walk(tree) for child in ast.iter_child_nodes(node)}
        for node in ast.walk(tree):
            if not isinstance(node, (ast.Import, ast.ImportFrom)):
                continue
            if _under_type_checking(node, parents):
                continue
            names = [a.name for a in node.names] if isinstance(node, ast.Import) else [node.module or ""]
            if not getattr(node, "level", 0):
                gui += [(module, n, node.lineno) for n in names if n.split(".")[0] in GUI_MODULES]
            inside = _in_function(node, parents)
            for target in _targets(node, module):
                if target != module:
                    reason = _comment(lines, node.lineno) if inside else ""
                    found.append(Import(module, target, node.lineno, inside, reason))
    return found, gui


IMPORTS, GUI_IMPORTS = _read_imports()


def _layers() -> list[list[str]]:
    """The layers of docs/architecture.md's table, lowest first."""
    text = ARCHITECTURE.read_text()
    table = re.search(r"<!-- layers -->(.*?)<!-- /layers -->", text, re.S)
    assert table, "docs/architecture.md has no <!-- layers --> table"
    layers = []
    for row in table.group(1).splitlines():
        cells = [cell.strip() for cell in row.strip().strip("|").split("|")]
        if len(cells) >= 2 and cells[0].isdigit():
            layers.append(re.findall(r"`([\w.]+)`", cells[1]))
    assert layers, "the layers table of docs/architecture.md has no rows"
    return layers


LAYERS = _layers()


def layer_of(module: str) -> int:
    """The layer of ``module``: that of the longest listed name it is or lies under."""
    best, depth = None, -1
    for index, names in enumerate(LAYERS):
        for name in names:
            full = NAME if name == NAME else f"{NAME}.{name}"
            if (module == full or module.startswith(full + ".")) and full.count(".") > depth:
                best, depth = index, full.count(".")
    if best is None:
        raise LookupError(module)
    return best


def test_every_module_has_a_layer():
    missing = []
    for module in MODULES:
        try:
            layer_of(module)
        except LookupError:
            missing.append(module)
    assert not missing, f"not in docs/architecture.md's layers table: {missing}"


def test_the_table_names_only_modules_that_exist():
    listed = [name for names in LAYERS for name in names]
    stale = [name for name in listed if name != NAME and f"{NAME}.{name}" not in MODULES]
    assert not stale, f"docs/architecture.md's layers table names modules that do not exist: {stale}"


def test_imports_go_down_the_layers():
    upward = [
        f"{i.importer} (layer {layer_of(i.importer)}) imports {i.imported} "
        f"(layer {layer_of(i.imported)}), line {i.line}"
        for i in IMPORTS
        if layer_of(i.imported) > layer_of(i.importer)
    ]
    assert not upward, "imports against the order of docs/architecture.md:\n" + "\n".join(upward)


def _circles(edges: dict[str, set[str]]) -> list[list[str]]:
    """Strongly connected components of more than one module (Tarjan, iterative)."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on_stack: set[str] = set()
    circles = []
    for start in edges:
        if start in index:
            continue
        work = [(start, iter(sorted(edges.get(start, ()))))]
        index[start] = low[start] = len(index)
        stack.append(start)
        on_stack.add(start)
        while work:
            node, children = work[-1]
            child = next(children, None)
            if child is not None:
                if child not in index:
                    index[child] = low[child] = len(index)
                    stack.append(child)
                    on_stack.add(child)
                    work.append((child, iter(sorted(edges.get(child, ())))))
                elif child in on_stack:
                    low[node] = min(low[node], index[child])
                continue
            work.pop()
            if work:
                low[work[-1][0]] = min(low[work[-1][0]], low[node])
            if low[node] == index[node]:
                component = []
                while True:
                    member = stack.pop()
                    on_stack.discard(member)
                    component.append(member)
                    if member == node:
                        break
                if len(component) > 1:
                    circles.append(sorted(component))
    return circles


def test_no_import_circles():
    edges: dict[str, set[str]] = {module: set() for module in MODULES}
    for i in IMPORTS:
        # a package's __init__ importing its own modules is how a package exports them
        if not (_is_package(i.imported) and i.importer.startswith(i.imported + ".")):
            edges[i.importer].add(i.imported)
    assert not _circles(edges), f"import circles: {_circles(edges)}"


def test_imports_inside_functions_say_why():
    unexplained = [
        f"{i.importer}, line {i.line}: {i.imported}" for i in IMPORTS if i.in_function and not i.reason
    ]
    assert not unexplained, (
        "an import of the package's own module inside a function, without a comment saying "
        "why (an optional dependency or start-up time kept away):\n" + "\n".join(unexplained)
    )


def test_only_qt_imports_qt_or_napari():
    outside = [f"{m}, line {line}: {name}" for m, name, line in GUI_IMPORTS if not m.startswith(f"{NAME}._qt")]
    assert not outside, "Qt or napari imported outside _qt:\n" + "\n".join(outside)


@pytest.mark.parametrize(
    ("source", "importer", "expected"),
    [
        ("from .core import parameters", f"{NAME}.api", [f"{NAME}.core.parameters"]),
        ("from . import labyrinth", f"{NAME}._warmup", [NAME]),
        ("from ..core.planes import split", f"{NAME}.cli.render", [f"{NAME}.core.planes"]),
        ("from .parameters import PARAMETERS", f"{NAME}.core", [f"{NAME}.core.parameters"]),
        ("import numpy", f"{NAME}.api", []),
    ],
)
def test_the_reader_resolves_relative_imports(source, importer, expected):
    assert _targets(ast.parse(source).body[0], importer) == expected


def test_the_circle_finder_finds_a_circle_and_only_it():
    edges = {"a": {"b"}, "b": {"c"}, "c": {"a"}, "d": {"a"}}
    assert _circles(edges) == [["a", "b", "c"]]
    assert _circles({"a": {"b"}, "b": set()}) == []


def test_a_reason_is_read_from_the_import_its_group_or_the_line_above():
    lines = [
        "def f():",
        "    # numba on first use only",
        "    from .a import b",
        "    from .c import d",
        "    x = 1",
        "    from .e import g",
        "    from .h import i  # dask is optional",
    ]
    assert _comment(lines, 4) == _comment(lines, 3) == "numba on first use only"
    assert _comment(lines, 6) == ""
    assert _comment(lines, 7) == "dask is optional"
