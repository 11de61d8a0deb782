"""Scrolling a lazy result in a real viewer: event-loop freezes, wall time, peak RSS.

Run under Xvfb: ``xvfb-run -a python benchmarks/bench_lazy_scroll.py``. A 40 × 2048² uint16
dask layer (each plane made when it is read), mode single, all planes, Run; then the result
is scrolled from plane 0 to 39 at about 30 Hz (a QTimer steps ``viewer.dims.set_current_step``,
the input layer hidden), twice: at once, while its planes render, and again once they are all
rendered; last, the input alone is scrolled the same way (the result hidden), for comparison.
A 10 ms QTimer heartbeat watches the event loop: a freeze is a gap between its ticks over
100, 150 or 200 ms.

A third variant, ``numpy``, scrolls the same planes held in memory by napari alone: what a
step costs this viewer at best on this machine (its repaint under software OpenGL).

Each run is a process of its own (its peak RSS is its own): ``--variant after`` is the package
on this script's path, ``--before SRC`` adds runs of another checkout's ``src`` (e.g. main's:
``git worktree add --detach /tmp/lazy_before main``), interleaved with these. Prints figures;
asserts nothing; the machine's load is printed before and after.
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _qt_loop import process_events, wait_until

PLANES, SIZE = 40, 2048
STEP_MS = 33  # ~30 Hz
HEARTBEAT_MS = 10
FREEZES_MS = (100, 150, 200)
HERE = Path(__file__).resolve().parent


def _events(seconds: float = 0.0) -> None:
    process_events(seconds, nap=0.001)


def _wait(condition, timeout: float = 600.0) -> None:
    wait_until(condition, timeout)


def _memory() -> tuple[float, float]:
    """(current, peak) resident memory of this process, in GB."""
    values = {}
    with open("/proc/self/status") as status:
        for line in status:
            key, _, rest = line.partition(":")
            if key in ("VmRSS", "VmHWM"):
                values[key] = int(rest.split()[0]) / 1024**2
    return values.get("VmRSS", float("nan")), values.get("VmHWM", float("nan"))


def lazy_stack():
    """A 40 × 2048² uint16 dask array, one chunk per plane, each plane made when read."""
    import dask.array as da

    def plane(block_info=None):
        index = block_info[None]["array-location"][0][0]
        rng = np.random.default_rng(index)
        y, x = np.ogrid[:SIZE, :SIZE]
        smooth = 1500 + 1000 * np.sin(x / (60 + index)) * np.cos(y / 85)
        noise = rng.normal(0, 300, (SIZE, SIZE))
        return np.clip(smooth + noise, 0, 4095).astype(np.uint16)[None]

    return da.map_blocks(
        plane, dtype=np.uint16, chunks=((1,) * PLANES, (SIZE,), (SIZE,)), meta=np.empty((0, 0, 0))
    )


def scroll(viewer, axis: int = 0) -> dict:
    """Step the slider from 0 to the last plane every ``STEP_MS``; the event loop's gaps."""
    from qtpy.QtCore import QTimer

    ticks: list[float] = []
    heartbeat = QTimer()
    heartbeat.setInterval(HEARTBEAT_MS)
    heartbeat.timeout.connect(lambda: ticks.append(time.perf_counter()))
    stepper = QTimer()
    stepper.setInterval(STEP_MS)
    position = {"step": 0, "done": None}
    stepped: list[float] = []  # when each step began

    def step() -> None:
        stepped.append(time.perf_counter())
        position["step"] += 1
        viewer.dims.set_current_step(axis, position["step"])
        if position["step"] >= PLANES - 1:
            stepper.stop()
            position["done"] = time.perf_counter()

    viewer.dims.set_current_step(axis, 0)
    _events(0.5)
    stepper.timeout.connect(step)
    started = time.perf_counter()
    ticks.append(started)
    heartbeat.start()
    stepper.start()
    _wait(lambda: position["done"] is not None)
    _events(0.2)  # the last plane drawn
    heartbeat.stop()
    wall = position["done"] - started
    gaps = np.diff(ticks) * 1000
    longest = int(np.argmax(gaps))
    # the step under way when the longest gap began (0: before the first step)
    at = int(np.searchsorted(stepped, ticks[longest], side="right"))
    result = {"wall": wall, "longest": float(gaps.max()), "longest at step": at}
    for limit in FREEZES_MS:
        result[f"over{limit}"] = int((gaps > limit).sum())
    return result


def reference(args) -> dict:
    """napari alone: the same planes in memory (numpy), scrolled the same way: the floor of
    what a step costs in this viewer."""
    import napari

    viewer = napari.Viewer(show=True)
    viewer.window._qt_window.resize(1400, 900)
    viewer.window.add_plugin_dock_widget("napari-labyrinth", "Labyrinthine tiling")
    viewer.add_image(lazy_stack().compute(), name="numpy", contrast_limits=(0, 4095))
    _events(1.0)
    figures = {"variant": args.variant, "in memory": scroll(viewer), "peak RSS": _memory()[1]}
    viewer.close()
    return figures


def child(args) -> dict:
    import napari

    from napari_labyrinth import api

    if args.variant == "numpy":
        return reference(args)

    api.labyrinth(np.zeros((64, 64), np.uint16) + np.arange(64, dtype=np.uint16))  # kernels
    viewer = napari.Viewer(show=True)
    viewer.window._qt_window.resize(1400, 900)
    _, widget = viewer.window.add_plugin_dock_widget("napari-labyrinth", "Labyrinthine tiling")
    source = viewer.add_image(lazy_stack(), name="lazy", contrast_limits=(0, 4095))
    _events(1.0)
    figures: dict = {"variant": args.variant, "package": api.__file__}
    started = time.perf_counter()
    widget.run()
    _wait(lambda: len(viewer.layers) == 2 and viewer.layers[-1].visible)
    figures["layer appears"] = time.perf_counter() - started
    result = viewer.layers[-1]
    source.visible = False
    figures["while rendering"] = scroll(viewer)
    if args.screenshot:
        viewer.dims.set_current_step(0, PLANES // 2)
        _events(1.0)
        viewer.screenshot(args.screenshot, canvas_only=False)
    _wait(lambda: widget.worker is None)
    figures["all rendered"] = time.perf_counter() - started
    figures["rendered"] = scroll(viewer)
    figures["RSS before the input scroll"] = _memory()[1]
    result.visible, source.visible = False, True
    figures["input alone"] = scroll(viewer)
    figures["peak RSS"] = _memory()[1]
    figures["status"] = widget.status.value
    viewer.close()
    return figures


def _run_child(variant: str, src: str, screenshot: str | None) -> dict:
    env = dict(os.environ, PYTHONPATH=src, NAPARI_LABYRINTH_NO_WARMUP="1")
    command = [sys.executable, str(Path(__file__).resolve()), "--child", "--variant", variant]
    if screenshot:
        command += ["--screenshot", screenshot]
    done = subprocess.run(command, env=env, capture_output=True, text=True, check=False)
    lines = [line for line in done.stdout.splitlines() if line.startswith("{")]
    if done.returncode or not lines:
        raise RuntimeError(f"{variant} failed:\n{done.stderr[-3000:]}")
    return json.loads(lines[-1])


def _row(label: str, phase: dict) -> str:
    return (
        f"    {label:<16} wall {phase['wall']:6.1f} s   longest {phase['longest']:5.0f} ms "
        f"(step {phase.get('longest at step', '?'):>2})   "
        + "   ".join(f"> {limit} ms: {phase[f'over{limit}']:2d}" for limit in FREEZES_MS)
    )


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=2)
    parser.add_argument("--before", help="src directory of the code to compare with (main's)")
    parser.add_argument("--screenshot", help="PNG of the viewer, partly rendered (after only)")
    parser.add_argument("--child", action="store_true", help=argparse.SUPPRESS)
    parser.add_argument("--variant", default="after", help=argparse.SUPPRESS)
    args = parser.parse_args(argv)
    if args.child:
        scratch = tempfile.mkdtemp(prefix="napari-labyrinth-bench-")
        os.environ.setdefault("XDG_CONFIG_HOME", os.path.join(scratch, "config"))
        os.environ.setdefault("XDG_CACHE_HOME", os.path.join(scratch, "cache"))
        print(json.dumps(child(args)))
        return 0

    after_src = str(HERE.parent / "src")
    variants = [("after", after_src)] + ([("before", args.before)] if args.before else [])
    variants.append(("numpy", after_src))
    print(f"load average before: {os.getloadavg()[0]:.2f}  cores: {os.cpu_count()}")
    print(
        f"{PLANES} × {SIZE}² uint16 dask layer, mode single, all planes; the result scrolled "
        f"0 → {PLANES - 1} every {STEP_MS} ms (input hidden); heartbeat {HEARTBEAT_MS} ms"
    )
    for repeat in range(args.repeats):
        for variant, src in variants:
            shot = args.screenshot if variant == "after" and repeat == 0 else None
            figures = _run_child(variant, src, shot)
            print(f"\n{variant} (run {repeat + 1}, load {os.getloadavg()[0]:.2f}):")
            if variant == "numpy":
                print("    napari alone, the same planes in memory (numpy), no result layer:")
                print(_row("in memory", figures["in memory"]))
                print(f"    peak RSS {figures['peak RSS']:.2f} GB")
                continue
            print(
                f"    result layer appears after {figures['layer appears']:.1f} s; "
                f"every plane rendered after {figures['all rendered']:.1f} s"
            )
            for phase in ("while rendering", "rendered", "input alone"):
                print(_row(phase, figures[phase]))
            print(f"    peak RSS {figures['peak RSS']:.2f} GB; status: {figures['status']}")
    print(f"\nload average after: {os.getloadavg()[0]:.2f}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
