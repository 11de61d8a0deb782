"""Cold start: a first call against the second, with numba's cache empty. Prints, asserts nothing.

Each row runs in a new process with a new, empty numba cache directory
(``NUMBA_CACHE_DIR`` set to a temporary directory), and times, wall clock, the
first call of the process and then the second, the same, in the same process:

- ``import``: ``import napari_labyrinth`` (second: the same in another new process
  sharing the row's cache directory);
- ``labyrinth-u8``, ``labyrinth-u16``, ``labyrinth-f32``: ``labyrinth()`` of a 1024²
  camera image (scikit-image's, resized) scaled to the dtype's range (float32: 0..1),
  default arguments; only the call is timed (the import is in the notes);
- ``describe``: ``metrics.describe(image, rendered)`` of the uint8 image and its
  ``labyrinth()`` as float32, after that first ``labyrinth()`` (untimed), as users do
  (the second call reuses the maps of the same original, as it does for them);
- ``find_window``: ``window.find_window`` of the uint16 image, first thing the process does;
- ``cli``: ``napari-labyrinth render in.png -o out.png`` of a 1024² uint8 PNG, the whole
  command as a subprocess (``python -m napari_labyrinth.cli`` with a source tree), twice;
- ``widget-single``, ``widget-stack``: a shown viewer with the 1024² uint16 image, the
  widget opened through the Plugins menu, Run clicked at once (stack: mode ``stack``,
  metrics on); from the click until the widget has shown the result layer (in
  ``viewer.layers``, the widget settled), then Run again (the result is updated in
  place: "replace last", the default). The widget's warm-up process runs, as it does for
  a user, into the same cache. The notes give the longest gap of the Qt event loop
  (a 10 ms QTimer) during each Run ("freeze"). Needs a display: run under Xvfb.

Columns: the row, the tree, the first and second call in seconds, the files in numba's
cache after the row (the widget rows: as the second Run ended; a warm-up process still
running then is ended, and the notes say so), the 1-minute load average as the row ended.
A row over ``--timeout`` seconds is reported as such.

``--wheel WHEEL`` adds two columns measured in a fresh venv (uv) where WHEEL and
napari are installed, as a user installs them: ``wheel`` (its shipped kernels
used, if it carries them) and ``wheel-jit`` (the same install with
``NAPARI_LABYRINTH_SHIPPED_KERNELS=0``: numba compiles, as an install without
them does). The column ``compiled`` counts the kernels numba compiled in the
row's processes (``NAPARI_LABYRINTH_COMPILE_LOG``).

Trees: by default the installed package (``current`` when it is this checkout's src,
an editable install); ``--tree PATH`` measures PATH/src instead
(prepended to PYTHONPATH in every process, the napari manifest included, as
``napari_labyrinth`` is imported from there); ``--before REF`` adds ``git archive REF src
napari.yaml`` extracted to a temporary directory (byte-compiled first), run interleaved
with the other tree row by row. ``--repeat N`` keeps, per row and tree, the run with the
best first call.

Run: ``make bench-cold`` or ``xvfb-run -a python benchmarks/bench_cold_start.py
[--before f22d86f] [--tree PATH] [--wheel dist/X.whl] [--rows labyrinth-u8 widget-single]
[--repeat N]``.
"""

from __future__ import annotations

import argparse
import contextlib
import json
import os
import pathlib
import shutil
import subprocess
import sys
import tempfile
import time

ROOT = pathlib.Path(__file__).resolve().parent.parent
SIZE = 1024
ROWS = (
    "import",
    "labyrinth-u8",
    "labyrinth-u16",
    "labyrinth-f32",
    "describe",
    "find_window",
    "cli",
    "widget-single",
    "widget-stack",
)
WIDGET_ROWS = ("widget-single", "widget-stack")
#: The line of a child's standard output that carries its figures.
MARK = "COLD-START-RESULT "
#: Seconds a child keeps for itself before the parent's timeout (a widget row's child
#: gives up waiting for a Run then, and ends the warm-up process it started).
MARGIN = 15.0


# -- the child: one row in a new process --------------------------------------------------


def camera(dtype_name: str):
    import numpy as np
    from skimage import data, transform

    image = transform.resize(data.camera(), (SIZE, SIZE), order=1, preserve_range=True)
    if dtype_name == "uint8":
        return np.clip(np.rint(image), 0, 255).astype(np.uint8)
    if dtype_name == "uint16":
        return np.clip(np.rint(image * 257), 0, 65535).astype(np.uint16)
    return (image / 255).astype(np.float32)


def _timed(call) -> float:
    start = time.perf_counter()
    call()
    return time.perf_counter() - start


def _import() -> tuple[float, object]:
    start = time.perf_counter()
    import napari_labyrinth

    return time.perf_counter() - start, napari_labyrinth


def child_import() -> dict:
    seconds, package = _import()
    return {"first": seconds, "file": package.__file__}


def child_labyrinth(dtype_name: str) -> dict:
    image = camera(dtype_name)
    imported, package = _import()
    first = _timed(lambda: package.labyrinth(image))
    second = _timed(lambda: package.labyrinth(image))
    return {"first": first, "second": second, "import": imported, "file": package.__file__}


def child_describe() -> dict:
    import numpy as np

    image = camera("uint8")
    imported, package = _import()
    from napari_labyrinth import metrics

    rendered = np.asarray(package.labyrinth(image))
    before, after = image.astype(np.float32), rendered.astype(np.float32)
    first = _timed(lambda: metrics.describe(before, after))
    second = _timed(lambda: metrics.describe(before, after))
    return {"first": first, "second": second, "import": imported, "file": package.__file__}


def child_find_window() -> dict:
    image = camera("uint16")
    imported, package = _import()
    from napari_labyrinth.window import find_window

    first = _timed(lambda: find_window(image))
    second = _timed(lambda: find_window(image))
    return {"first": first, "second": second, "import": imported, "file": package.__file__}


def child_cli(tree: str | None) -> dict:
    from skimage import io

    work = pathlib.Path(tempfile.mkdtemp(prefix="cold-cli-"))
    try:
        source = work / "in.png"
        io.imsave(source, camera("uint8"), check_contrast=False)
        if tree:
            command = [sys.executable, "-m", "napari_labyrinth.cli"]
        else:
            command = [str(pathlib.Path(sys.executable).with_name("napari-labyrinth"))]
        seconds, notes = [], []
        for k in (1, 2):
            output = work / f"out{k}.png"
            start = time.perf_counter()
            done = subprocess.run(
                [*command, "render", str(source), "-o", str(output)],
                capture_output=True,
                text=True,
                check=False,
            )
            seconds.append(time.perf_counter() - start)
            if done.returncode != 0 or not output.exists():
                notes.append(f"run {k} failed ({done.returncode}): {done.stderr.strip()[-200:]}")
        return {"first": seconds[0], "second": seconds[1], "error": "; ".join(notes)}
    finally:
        shutil.rmtree(work, ignore_errors=True)


def _events(seconds: float = 0.0) -> None:
    from qtpy.QtWidgets import QApplication

    end = time.perf_counter() + seconds
    QApplication.processEvents()
    while time.perf_counter() < end:
        QApplication.processEvents()
        time.sleep(0.001)


def _plugin_action(menu_bar, name: str):
    """The action of the Plugins menu that opens the widget ``name`` (napari 0.5-0.9 name it
    ``name``, ``name (plugin)``, or put it in a submenu of the plugin)."""

    def text(action) -> str:
        return action.text().replace("&", "").strip()

    def leaves(menu, depth=0):
        menu.aboutToShow.emit()  # app-model menus fill themselves as they are about to show
        for action in menu.actions():
            sub = action.menu()
            if sub is not None and depth < 3:
                if text(action) == name or text(action).startswith(name + " ("):
                    yield from ((a, True) for a, _ in leaves(sub, depth + 1))
                else:
                    yield from leaves(sub, depth + 1)
            elif sub is None:
                yield action, False

    plugins = [a.menu() for a in menu_bar.actions() if text(a) == "Plugins" and a.menu()]
    if not plugins:
        raise RuntimeError("no Plugins menu in the menu bar")
    found = []
    for action, in_submenu in leaves(plugins[0]):
        label = text(action)
        if label == name or label.startswith(name + " (") or (in_submenu and name in label):
            found.append(action)
    if not found:
        raise RuntimeError(f"no {name!r} action in the Plugins menu")
    return found[0]


def _docked_widget(viewer, kind):
    docks = getattr(viewer.window, "dock_widgets", None)
    if docks is None:  # napari < 0.5.5: a dict of dock widgets
        docks = {k: d.widget() for k, d in getattr(viewer.window, "_dock_widgets", {}).items()}
    for widget in dict(docks).values():
        if isinstance(widget, kind):
            return widget
    children = viewer.window._qt_window.findChildren(kind)
    return children[0] if children else None


class FreezeMeter:
    """The longest interval between the ticks of a 10 ms QTimer while on."""

    def __init__(self) -> None:
        from qtpy.QtCore import QTimer

        self.longest = 0.0
        self._last = None
        self._timer = QTimer()
        self._timer.setInterval(10)
        self._timer.timeout.connect(self._tick)

    def _tick(self) -> None:
        now = time.perf_counter()
        if self._last is not None:
            self.longest = max(self.longest, now - self._last)
        self._last = now

    def __enter__(self):
        self.longest, self._last = 0.0, time.perf_counter()
        self._timer.start()
        return self

    def __exit__(self, *exc) -> None:
        self._tick()
        self._timer.stop()


def _click_and_wait(viewer, widget, deadline: float) -> tuple[float, float]:
    """Click Run; seconds until the widget has shown the result layer, and the longest
    freeze of the event loop meanwhile."""
    with FreezeMeter() as meter:
        start = time.perf_counter()
        widget.run_button.native.click()
        if widget.worker is None:
            raise RuntimeError(f"Run did not start: {widget.status.value}")
        while not (widget.worker is None and widget.last_result in viewer.layers):
            if time.perf_counter() > deadline:
                raise TimeoutError("timeout: no result layer in time")
            if widget.worker is None and not str(widget.status.value).startswith("Added"):
                raise RuntimeError(f"the run ended without a layer: {widget.status.value}")
            _events(0.001)
        seconds = time.perf_counter() - start
    return seconds, meter.longest


def child_widget(stack: bool, deadline: float) -> dict:
    if not os.environ.get("DISPLAY") and not os.environ.get("WAYLAND_DISPLAY"):
        return {"error": "no display: run under xvfb-run -a"}
    import psutil

    result: dict = {}
    try:
        _widget_runs(stack, deadline, result)
    except (RuntimeError, TimeoutError) as error:
        result["error"] = str(error)
    # the cache as the Runs left it; the warm-up process, if it still runs, is ended (a
    # niced process on a loaded machine can take minutes more)
    result["cache"] = _cache_files(pathlib.Path(os.environ["NUMBA_CACHE_DIR"]))
    alive = [p for p in psutil.Process().children(recursive=True) if _running(p)]
    for process in alive:
        with contextlib.suppress(psutil.Error):
            process.kill()
    psutil.wait_procs(alive, timeout=10)
    notes = [result["notes"]] if "notes" in result else []
    notes.append("warm-up still running, ended" if alive else "warm-up had ended")
    result["notes"] = "; ".join(notes)
    return result


def _running(process) -> bool:
    import psutil

    try:
        return process.status() != psutil.STATUS_ZOMBIE
    except psutil.Error:
        return False


def _widget_runs(stack: bool, deadline: float, result: dict) -> None:
    """The two Runs, their figures put in ``result`` as they come."""
    import napari

    image = camera("uint16")
    viewer = napari.Viewer(show=True)
    try:
        viewer.window._qt_window.resize(1400, 900)
        viewer.add_image(image, name="camera")
        _events(0.3)
        from napari_labyrinth._qt.widget import LabyrinthWidget

        _plugin_action(viewer.window._qt_window.menuBar(), "Labyrinthine tiling").trigger()
        widget = _docked_widget(viewer, LabyrinthWidget)
        if widget is None:
            raise RuntimeError("the Plugins menu action docked no LabyrinthWidget")
        if stack:
            widget.mode.value = "stack"
            widget.measure.value = True
        import napari_labyrinth

        result["file"] = napari_labyrinth.__file__
        result["widget_file"] = sys.modules[LabyrinthWidget.__module__].__file__
        result["first"], freeze = _click_and_wait(viewer, widget, deadline)
        result["notes"] = f"freeze {freeze:.2f} s"
        _events(0.3)
        result["second"], freeze = _click_and_wait(viewer, widget, deadline)
        result["notes"] += f" / {freeze:.2f} s"
        _events(0.3)
    finally:
        viewer.close()
        _events(0.2)


def child(row: str, tree: str | None, deadline: float) -> dict:
    if row in ("import", "import-again"):
        return child_import()
    if row.startswith("labyrinth-"):
        return child_labyrinth({"u8": "uint8", "u16": "uint16", "f32": "float32"}[row[10:]])
    if row == "describe":
        return child_describe()
    if row == "find_window":
        return child_find_window()
    if row == "cli":
        return child_cli(tree)
    if row in WIDGET_ROWS:
        return child_widget(row == "widget-stack", deadline)
    raise ValueError(row)


# -- the parent: rows, trees, table --------------------------------------------------------


def _load() -> str:
    return f"{os.getloadavg()[0]:.2f}"


def _cache_files(path: pathlib.Path) -> int:
    return sum(len(files) for _, _, files in os.walk(path))


class Variant:
    """What a column runs: a tree (PYTHONPATH), or the Python of a venv, with extra variables."""

    def __init__(self, label: str, tree: str | None = None, python: str | None = None,
                 env: dict | None = None):  # fmt: skip
        self.label, self.tree, self.python, self.env = label, tree, python, env or {}


def _compiles(log: pathlib.Path) -> int:
    return len(log.read_text().splitlines()) if log.exists() else 0


def _spawn(row: str, variant: Variant, cache: pathlib.Path, timeout: float) -> dict:
    tree = variant.tree
    env = dict(os.environ, NUMBA_CACHE_DIR=str(cache), **variant.env)
    env["NAPARI_LABYRINTH_COMPILE_LOG"] = str(cache.parent / f"{cache.name}.compiled")
    if tree:
        env["PYTHONPATH"] = os.pathsep.join(
            [str(pathlib.Path(tree) / "src"), *filter(None, [os.environ.get("PYTHONPATH")])]
        )
    python = variant.python or sys.executable
    command = [python, str(pathlib.Path(__file__).resolve()), "--child", row]
    command += ["--timeout", str(timeout)] + (["--tree", tree] if tree else [])
    process = subprocess.Popen(
        command, env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True
    )
    try:
        out, err = process.communicate(timeout=timeout)
    except subprocess.TimeoutExpired:
        _kill_tree(process)
        process.communicate()
        return {"error": f"timeout ({timeout:.0f} s)"}
    for line in out.splitlines():
        if line.startswith(MARK):
            return json.loads(line[len(MARK) :])
    tail = (err.strip().splitlines() or ["no output"])[-1]
    return {"error": f"exit {process.returncode}: {tail[:150]}"}


def _kill_tree(process: subprocess.Popen) -> None:
    """End the child and the processes it started (the widget's warm-up), by their ids."""
    with contextlib.suppress(ImportError, OSError, LookupError):
        import psutil

        with contextlib.suppress(psutil.Error):
            for descendant in psutil.Process(process.pid).children(recursive=True):
                descendant.kill()
    process.kill()


def run_row(row: str, variant: Variant, timeout: float) -> dict:
    cache = pathlib.Path(tempfile.mkdtemp(prefix="cold-numba-"))
    log = cache.parent / f"{cache.name}.compiled"
    try:
        result = _spawn(row, variant, cache, timeout)
        if row == "import" and "error" not in result:
            again = _spawn("import-again", variant, cache, timeout)
            result["second"] = again.get("first")
        result.setdefault("cache", _cache_files(cache))
        result["compiled"] = _compiles(log)
    finally:
        shutil.rmtree(cache, ignore_errors=True)
        log.unlink(missing_ok=True)
    result["load"] = _load()
    return result


def _check_tree(result: dict, variant: Variant) -> None:
    """Say so when the package was not imported from the tree or venv meant."""
    if variant.python:
        expected = str(pathlib.Path(variant.python).parent.parent)
    else:
        expected = str(pathlib.Path(variant.tree).resolve() / "src") if variant.tree else None
    for key in ("file", "widget_file"):
        path = result.get(key)
        if path and expected and not str(pathlib.Path(path).resolve()).startswith(expected):
            result["error"] = f"imported from {path}, not the tree"


def _seconds(value) -> str:
    return "-" if value is None else f"{value:.2f}"


def _line(row: str, label: str, result: dict) -> str:
    notes = []
    if "import" in result:
        notes.append(f"import {result['import']:.2f} s")
    if result.get("notes"):
        notes.append(result["notes"])
    if result.get("error"):
        notes.append(result["error"])
    return (
        f"{row:<14}| {label:<10}| {_seconds(result.get('first')):>8} | "
        f"{_seconds(result.get('second')):>8} | {result.get('compiled', '-'):>8} | "
        f"{result.get('cache', '-'):>11} | {result['load']:>5} | {'; '.join(notes)}".rstrip()
    )


def _installed_label() -> str:
    """``current`` when the installed package is this checkout's src (an editable install)."""
    import importlib.util

    spec = importlib.util.find_spec("napari_labyrinth")  # finds it without running it
    origin = pathlib.Path(spec.origin).resolve() if spec and spec.origin else None
    return "current" if origin and (ROOT / "src") in origin.parents else "installed"


def _before_tree(ref: str) -> pathlib.Path:
    target = pathlib.Path(tempfile.mkdtemp(prefix=f"cold-{ref}-"))
    archive = subprocess.run(
        ["git", "-C", str(ROOT), "archive", ref, "src", "napari.yaml"],
        capture_output=True,
        check=True,
    )
    subprocess.run(["tar", "-x", "-C", str(target)], input=archive.stdout, check=True)
    subprocess.run([sys.executable, "-m", "compileall", "-q", str(target / "src")], check=True)
    return target


def _wheel_venv(wheel: str) -> pathlib.Path:
    """A fresh venv (uv) holding ``wheel`` and napari with PyQt6, as a user installs them."""
    from uv import find_uv_bin

    venv = pathlib.Path(tempfile.mkdtemp(prefix="cold-wheel-")) / "venv"
    uv = find_uv_bin()
    subprocess.run([uv, "venv", "-q", "--python", sys.executable, str(venv)], check=True)
    python = venv / "bin" / "python"
    requirement = f"napari-labyrinth[napari] @ {pathlib.Path(wheel).resolve().as_uri()}"
    # byte-compiled, as pip installs (uv leaves that to the first import)
    subprocess.run([uv, "pip", "install", "-q", "--compile-bytecode", "--python", str(python),
                    requirement], check=True)  # fmt: skip
    return python


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--rows", nargs="+", choices=ROWS, default=list(ROWS))
    parser.add_argument("--tree", help="measure PATH/src instead of the installed package")
    parser.add_argument("--before", metavar="REF", help="also measure git REF's src, interleaved")
    parser.add_argument("--wheel", help="also measure this wheel installed in a fresh venv")
    parser.add_argument("--repeat", type=int, default=1, help="runs per row; best first kept")
    parser.add_argument("--timeout", type=float, default=300.0, help="seconds per process")
    parser.add_argument("--child", help=argparse.SUPPRESS)
    args = parser.parse_args(argv)

    if args.child:
        deadline = time.perf_counter() + max(args.timeout - MARGIN, args.timeout / 2)
        result = child(args.child, args.tree, deadline)
        print(MARK + json.dumps(result), flush=True)
        return 0

    variants = [
        Variant(pathlib.Path(args.tree).name if args.tree else _installed_label(), args.tree)
    ]
    before = _before_tree(args.before) if args.before else None
    if before is not None:
        variants.append(Variant(args.before, str(before)))
    wheel_python = _wheel_venv(args.wheel) if args.wheel else None
    if wheel_python is not None:
        variants.append(Variant("wheel", python=str(wheel_python)))
        variants.append(
            Variant("wheel-jit", python=str(wheel_python),
                    env={"NAPARI_LABYRINTH_SHIPPED_KERNELS": "0"})  # fmt: skip
        )
    rows = [row for row in ROWS if row in args.rows]
    display = os.environ.get("DISPLAY") or os.environ.get("WAYLAND_DISPLAY")
    print(
        f"load average at the start: {_load()}  cores: {os.cpu_count()}  "
        f"image: {SIZE}²  repeat: {args.repeat}  timeout: {args.timeout:.0f} s"
    )
    for variant in variants:
        if variant.python:
            where = f"{args.wheel} in a fresh venv ({variant.python})"
            where += ", shipped kernels off" if variant.env else ""
        else:
            where = f"{variant.tree}/src" if variant.tree else "the installed package"
            where += ", this checkout's src" if variant.label == "current" else ""
        print(f"tree {variant.label}: {where}")
    if not display and any(row in WIDGET_ROWS for row in rows):
        print("no DISPLAY: the widget rows are skipped (run under xvfb-run -a)")
        rows = [row for row in rows if row not in WIDGET_ROWS]
    print(
        f"\n{'row':<14}| {'tree':<10}| {'first s':>8} | {'second s':>8} | {'compiled':>8} | "
        f"{'cache files':>11} | {'load':>5} | notes"
    )
    try:
        for row in rows:
            best: dict[str, dict] = {}
            for _ in range(args.repeat):
                for variant in variants:  # interleaved: a passing load falls on all
                    result = run_row(row, variant, args.timeout)
                    _check_tree(result, variant)
                    kept = best.get(variant.label)
                    if kept is None or (
                        result.get("first") is not None
                        and (kept.get("first") is None or result["first"] < kept["first"])
                    ):
                        best[variant.label] = result
            for variant in variants:
                print(_line(row, variant.label, best[variant.label]), flush=True)
    finally:
        if before is not None:
            shutil.rmtree(before, ignore_errors=True)
        if wheel_python is not None:
            shutil.rmtree(wheel_python.parent.parent.parent, ignore_errors=True)
    print(f"\nload average at the end: {_load()}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
