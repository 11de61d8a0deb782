"""The widget in a real viewer: preview latency, stack time, cancel time, event-loop gaps.

Run under Xvfb: ``xvfb-run -a python benchmarks/bench_widget.py`` (``make bench-widget``).
Prints figures; asserts nothing. Every figure is the best (or, for gaps, the worst)
of a few runs after a warm-up; the machine's load is printed before and after.
"""

from __future__ import annotations

import argparse
import contextlib
import os
import sys
import tempfile
import time

import numpy as np


def _events(seconds: float = 0.0) -> None:
    from qtpy.QtWidgets import QApplication

    end = time.perf_counter() + seconds
    QApplication.processEvents()
    while time.perf_counter() < end:
        QApplication.processEvents()
        time.sleep(0.001)


def _wait(condition, timeout: float = 300.0) -> None:
    end = time.perf_counter() + timeout
    while not condition():
        if time.perf_counter() > end:
            raise TimeoutError("the widget did not finish in time")
        _events(0.001)


def _clear(viewer) -> None:
    """Remove every layer, one at a time with the events in between (removing several at
    once while a repaint is pending crashes vispy under Xvfb's software OpenGL)."""
    for layer in list(viewer.layers):
        viewer.layers.remove(layer)
        _events(0.05)


class GapMeter:
    """The longest interval between ticks of a 20 ms QTimer: how long the event loop stalled."""

    def __init__(self) -> None:
        from qtpy.QtCore import QTimer

        self.timer = QTimer()
        self.timer.setInterval(20)
        self.timer.timeout.connect(self._tick)
        self.last = 0.0
        self.longest = 0.0

    def _tick(self) -> None:
        now = time.perf_counter()
        if self.last:
            self.longest = max(self.longest, now - self.last)
        self.last = now

    def __enter__(self):
        self.last, self.longest = 0.0, 0.0
        self.timer.start()
        return self

    def __exit__(self, *_exc) -> None:
        self.timer.stop()


def image(size: int, planes: int = 0, dtype=np.uint16) -> np.ndarray:
    """A camera-like test image of ``size``², or a stack of ``planes`` shifted copies."""
    from skimage import data, transform

    base = transform.resize(data.camera(), (size, size), order=1, preserve_range=True)
    base = (base / 255.0 * 4000 + 200).astype(dtype)
    if not planes:
        return base
    return np.stack([np.roll(base, 7 * k, axis=1) for k in range(planes)])


def bench_preview(viewer, widget, size: int, repeats: int) -> float:
    """Seconds from a change of V to the updated preview layer, best of ``repeats``."""
    _clear(viewer)
    viewer.add_image(image(size), name=f"{size}")
    widget.preview_toggle.value = True
    _wait(lambda: widget.preview.layer is not None and not widget.preview.busy)
    field = widget.fields["variance_threshold"]
    times = []
    for k in range(repeats + 1):  # the first is a warm-up
        before = widget.preview.shown_generation
        started = time.perf_counter()
        field.value = 0.035 + 0.001 * (k % 5)
        _wait(lambda before=before: widget.preview.shown_generation > before)
        _events()  # the canvas repaints
        times.append(time.perf_counter() - started)
    widget.preview_toggle.value = False
    return min(times[1:])


def _timed_run(widget) -> tuple[float, float, float]:
    """Run the widget; (total seconds, longest event-loop gap while rendering, seconds
    spent adding the result layer on the main thread)."""
    worker = widget.run(start=False)
    total_steps = worker.pbar.total
    gap = GapMeter()
    rendered = []

    def on_step(step: int) -> None:
        if step >= total_steps:  # the last step: the result goes to the main thread next
            gap.timer.stop()
            rendered.append(time.perf_counter())

    worker.yielded.connect(on_step)
    started = time.perf_counter()
    with gap:
        worker.start()
        _wait(lambda: widget.worker is None)
    finished = time.perf_counter()
    return finished - started, gap.longest, finished - (rendered or [finished])[0]


def bench_stack(viewer, widget, size: int, repeats: int) -> tuple[float, float, float, float]:
    """Best total of a 4-pass stack with metrics, time to cancel, longest gap, layer add."""
    _clear(viewer)
    viewer.add_image(image(size), name=f"{size}")
    widget.mode.value = "stack"
    widget.measure.value = True
    widget.fields["passes"].value = 4
    runs = [_timed_run(widget) for _ in range(repeats + 1)][1:]  # the first is a warm-up
    cancels = []
    for _ in range(repeats):
        worker = widget.run(start=False)
        steps = []
        worker.yielded.connect(steps.append)
        worker.start()
        _wait(lambda steps=steps: len(steps) >= 2)
        started = time.perf_counter()
        widget.cancel()
        _wait(lambda: widget.worker is None)
        cancels.append(time.perf_counter() - started)
    widget.mode.value = "single"
    return (
        min(r[0] for r in runs),
        min(cancels),
        max(r[1] for r in runs),
        max(r[2] for r in runs),
    )


def bench_planes(viewer, widget, size: int, planes: int) -> tuple[float, float, float]:
    """Time, longest event-loop gap while rendering, and layer add of a ``planes``-plane run."""
    _clear(viewer)
    viewer.add_image(image(size, planes), name="movie")
    widget.mode.value = "single"
    widget.fields["passes"].value = 4
    return _timed_run(widget)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--planes", type=int, default=20, help="planes of the movie (2048²)")
    parser.add_argument(
        "--parts", default="preview,stack,planes", help="comma-separated parts to run"
    )
    parser.add_argument("--sizes", default="1024,2048", help="preview sizes")
    args = parser.parse_args(argv)

    scratch = tempfile.mkdtemp(prefix="napari-labyrinth-bench-")
    os.environ.setdefault("XDG_CONFIG_HOME", os.path.join(scratch, "config"))
    os.environ.setdefault("XDG_CACHE_HOME", os.path.join(scratch, "cache"))
    print(f"load average before: {os.getloadavg()[0]:.2f}  cores: {os.cpu_count()}")
    parts = set(args.parts.split(","))
    if "preview" in parts:
        for size in map(int, args.sizes.split(",")):
            with _viewer() as (viewer, widget):
                _preview_part(viewer, widget, size, args)
    if "stack" in parts:
        with _viewer() as (viewer, widget):
            _stack_part(viewer, widget, args)
    if "planes" in parts:
        with _viewer() as (viewer, widget):
            _planes_part(viewer, widget, args)
    print(f"\nload average after: {os.getloadavg()[0]:.2f}")
    return 0


@contextlib.contextmanager
def _viewer():
    """A shown viewer with the widget docked. Each part gets its own: under Xvfb's software
    OpenGL, one GL context that uploads 1024² and then 2048² textures can crash the driver."""
    import napari

    viewer = napari.Viewer(show=True)
    viewer.window._qt_window.resize(1400, 900)
    _, widget = viewer.window.add_plugin_dock_widget("napari-labyrinth", "Labyrinthine tiling")
    _events(0.5)
    try:
        yield viewer, widget
    finally:
        viewer.close()
        _events(0.2)


def _preview_part(viewer, widget, size: int, args) -> None:
    seconds = bench_preview(viewer, widget, size, args.repeats)
    print(f"\npreview, {size}² uint16, default preset: change of V -> updated preview on screen")
    print(f"  {1000 * seconds:7.0f} ms (best of {args.repeats}, debounce included)")


def _stack_part(viewer, widget, args) -> None:
    print("\nstack mode, 4 passes, metrics of every pass (2048², uint16)")
    total, cancel, gap, adding = bench_stack(viewer, widget, 2048, args.repeats)
    print(f"  total:  {total:6.2f} s (best of {args.repeats}, after a warm-up run)")
    print(f"  cancel: {1000 * cancel:6.0f} ms (from Cancel to the end of the worker, best)")
    print(f"  longest event-loop gap while rendering and measuring: {1000 * gap:.0f} ms")
    print(f"  adding the result layer (napari, main thread): {1000 * adding:.0f} ms (worst)")


def _planes_part(viewer, widget, args) -> None:
    seconds, gap, adding = bench_planes(viewer, widget, 2048, args.planes)
    print(f"\nsingle mode, {args.planes} planes of 2048², 4 passes: {seconds:.1f} s")
    print(f"  longest event-loop gap while rendering: {1000 * gap:.0f} ms")
    print(f"  adding the result layer (napari, main thread): {1000 * adding:.0f} ms")


if __name__ == "__main__":
    sys.exit(main())
