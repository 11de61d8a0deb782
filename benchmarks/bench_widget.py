"""The widget in a real viewer: preview latency, stack time, cancel time, event-loop gaps.

Run under Xvfb: ``xvfb-run -a python benchmarks/bench_widget.py`` (``make bench-widget``);
``--parts preview,single,stack,planes`` chooses the parts. Prints figures; asserts
nothing; the machine's load is printed before and after. Parts:

- ``preview``: from a change of V to the updated preview layer, 1024² and 2048², and the
  longest event-loop gaps turning the preview on (it adds its layer) and as V changes;
- ``single``: Run -> result layer of one 2048² uint16 plane, default preset, warm, split
  into the worker's rendering and the main thread's steps of showing the result (each
  in a turn of the event loop of its own), when the run updates the last result in
  place ("replace last", the default) and when it adds a new layer; for a new layer,
  ways of showing it interleaved run by run (``NEW_LAYER_VARIANTS``: as shipped, as
  before in one turn, the selection deferred); and, for comparison, napari alone
  adding a layer of the same size (no plugin);
- ``stack``: 4 passes with metrics, 2048²; the time to cancel;
- ``planes``: a 20-plane 2048² movie, 4 passes (the first run adds the layer),
  interleaved with and without the widget's hold on Python's full garbage collections.

Each run is watched by a 20 ms QTimer: the longest gap between its ticks while the
worker renders, and from the last step to 0.5 s after the end (the layer added or
updated, then drawn), with the longest single draw of the canvas by vispy in that time
and Python's full garbage collections. Under a run's row, each stall over 100 ms is
listed with what the main thread was seen running in it (sampled every 10 ms).
Under Xvfb every repaint of the window goes through software OpenGL.
"""

from __future__ import annotations

import argparse
import contextlib
import gc
import os
import sys
import tempfile
import threading
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _qt_loop import process_events, wait_until


def _events(seconds: float = 0.0) -> None:
    process_events(seconds, nap=0.001)


def _wait(condition, timeout: float = 300.0) -> None:
    wait_until(condition, timeout)


def _clear(viewer) -> None:
    """Remove every layer, one at a time with the events in between (removing several at
    once while a repaint is pending crashes vispy under Xvfb's software OpenGL)."""
    for layer in list(viewer.layers):
        viewer.layers.remove(layer)
        _events(0.05)


class DrawMeter:
    """The longest single draw of the canvas by vispy (``paintGL``: the scene, and the upload
    of changed textures, in software under Xvfb), while on."""

    def __init__(self) -> None:
        from vispy.app.backends import _qt

        self._backend = _qt.CanvasBackendDesktop
        self._paint = self._backend.paintGL
        self.longest = 0.0

    def __enter__(self):
        meter, paint = self, self._paint

        def timed_paint(backend):
            started = time.perf_counter()
            try:
                return paint(backend)
            finally:
                meter.longest = max(meter.longest, time.perf_counter() - started)

        self.longest = 0.0
        self._backend.paintGL = timed_paint
        return self

    def __exit__(self, *_exc) -> None:
        self._backend.paintGL = self._paint


class GapMeter:
    """The longest interval between ticks of a 20 ms QTimer: how long the event loop stalled.

    With ``explain``, a thread looks every 10 ms and, while the loop has not ticked for
    over 60 ms, notes what the main thread is running (its innermost frames):
    :attr:`stalls` then holds, for each gap over 100 ms, its start, length and the frames
    seen (none seen: the main thread waited for the GIL, or for the CPU).
    """

    #: A gap longer than this is a stall.
    STALL = 0.1

    def __init__(self, explain: bool = False) -> None:
        from qtpy.QtCore import QTimer

        self.timer = QTimer()
        self.timer.setInterval(20)
        self.timer.timeout.connect(self._tick)
        self.last = 0.0
        self.longest = 0.0
        self.explain = explain
        self.stalls: list[tuple[float, float, list[str]]] = []
        self._samples: list[tuple[float, str]] = []
        self._on = False

    def _tick(self) -> None:
        now = time.perf_counter()
        if self.last:
            self.longest = max(self.longest, now - self.last)
            if now - self.last > self.STALL:
                seen = [f for t, f in self._samples if self.last <= t <= now]
                self.stalls.append((self.last, now - self.last, list(dict.fromkeys(seen))))
        self.last = now

    def _sample(self) -> None:
        import traceback

        main = threading.main_thread().ident
        while self._on:
            time.sleep(0.01)
            if self.last and time.perf_counter() - self.last > 0.06:
                frame = sys._current_frames().get(main)
                if frame is not None:
                    frames = traceback.extract_stack(frame)[-3:]
                    where = " <- ".join(
                        f"{f.filename.rsplit('site-packages/', 1)[-1].rsplit('/src/', 1)[-1]}"
                        f":{f.lineno} {f.name}"
                        for f in reversed(frames)
                    )
                    self._samples.append((time.perf_counter(), where))

    def __enter__(self):
        self.last, self.longest = 0.0, 0.0
        self.stalls, self._samples = [], []
        self.timer.start()
        if self.explain:
            self._on = True
            threading.Thread(target=self._sample, name="gap-sampler", daemon=True).start()
        return self

    def __exit__(self, *_exc) -> None:
        self.timer.stop()
        self._on = False


class CollectionMeter:
    """Python's full garbage collections (generation 2) while on: how many, the longest,
    and in which thread; each holds the GIL, so it stalls the event loop whatever thread
    runs it."""

    def __init__(self) -> None:
        self.collections: list[tuple[float, str]] = []
        self._started = 0.0

    def _callback(self, phase: str, info: dict) -> None:
        if info.get("generation") != 2:
            return
        if phase == "start":
            self._started = time.perf_counter()
        elif self._started:
            thread = threading.current_thread().name
            self.collections.append((time.perf_counter() - self._started, thread))
            self._started = 0.0

    def __enter__(self):
        self.collections = []
        gc.callbacks.append(self._callback)
        return self

    def __exit__(self, *_exc) -> None:
        gc.callbacks.remove(self._callback)

    def summary(self) -> str:
        """e.g. ``2, longest 184 ms (main)`` or ``0``."""
        if not self.collections:
            return "0"
        longest, thread = max(self.collections)
        where = "main" if thread == "MainThread" else "worker"
        return f"{len(self.collections)}, longest {1000 * longest:.0f} ms ({where})"


def image(size: int, planes: int = 0, dtype=np.uint16) -> np.ndarray:
    """A camera-like test image of ``size``², or a stack of ``planes`` shifted copies."""
    from skimage import data, transform

    base = transform.resize(data.camera(), (size, size), order=1, preserve_range=True)
    base = (base / 255.0 * 4000 + 200).astype(dtype)
    if not planes:
        return base
    return np.stack([np.roll(base, 7 * k, axis=1) for k in range(planes)])


def bench_preview(viewer, widget, size: int, repeats: int) -> tuple[float, float, float]:
    """Seconds from a change of V to the updated preview layer, best of ``repeats``; the
    longest event-loop gap from turning the preview on to 0.5 s after its layer is shown
    (the first render, and the new layer), and while V changes."""
    _clear(viewer)
    viewer.add_image(image(size), name=f"{size}")
    with GapMeter() as gap:
        widget.preview_toggle.value = True
        _wait(lambda: widget.preview.layer is not None and not widget.preview.busy)
        _events(0.5)
    gap_on = gap.longest
    field = widget.fields["variance_threshold"]
    times = []
    with GapMeter() as gap:
        for k in range(repeats + 1):  # the first is a warm-up
            before = widget.preview.shown_generation
            started = time.perf_counter()
            field.value = 0.035 + 0.001 * (k % 5)
            _wait(lambda before=before: widget.preview.shown_generation > before)
            _events()  # the canvas repaints
            times.append(time.perf_counter() - started)
    widget.preview_toggle.value = False
    return min(times[1:]), gap_on, gap.longest


def _timed_run(widget) -> dict[str, float]:
    """Run the widget and watch the event loop with a 20 ms timer. Seconds:

    - ``total``: from the start of the worker to the end of the run (result shown);
    - ``rendering``: from the start to the run's last step (the worker thread's part);
    - ``gap_rendering``: the longest event-loop gap until then;
    - ``adding``: the main thread's time in the steps of showing the result (adding or
      updating the layer, each step in a turn of the event loop of its own), summed;
    - ``longest_step``: the longest of those steps;
    - ``steps``: each step's name and milliseconds, e.g. ``built 3, inserted 52, ...``;
    - ``gap_showing``: the longest gap from the last step to 0.5 s after the end: the
      layer added or updated, then drawn (the texture upload, in software under Xvfb);
    - ``drawing``: the longest single draw of the canvas by vispy in that time;
    - ``collections``: Python's full garbage collections over the whole run and the
      0.5 s after (:class:`CollectionMeter`'s summary).
    """
    from napari_labyrinth._qt import widget as module

    worker = widget.run(start=False)
    total_steps = widget.progress_bar.maximum()
    gap = GapMeter(explain=True)
    marks: dict[str, float] = {}
    steps: list[tuple[str, float]] = []
    show_result = module.show_result

    draw = DrawMeter()
    collections = CollectionMeter()

    def on_step(step: int) -> None:
        if step >= total_steps:  # the last step: the result goes to the main thread next
            marks["rendered"] = time.perf_counter()
            marks["gap_rendering"] = gap.longest
            gap.longest = 0.0
            draw.__enter__()

    def timed_show(*arguments, **options):
        shown = show_result(*arguments, **options)
        try:
            while True:
                started = time.perf_counter()
                try:
                    name = next(shown)
                except StopIteration as done:
                    return done.value
                finally:
                    steps.append(("", time.perf_counter() - started))
                steps[-1] = (name, steps[-1][1])
                yield name
        finally:
            shown.close()

    worker.yielded.connect(on_step)
    module.show_result = timed_show
    started = time.perf_counter()
    try:
        with gap, collections:
            worker.start()
            _wait(lambda: widget.worker is None)
            finished = time.perf_counter()
            _events(0.5)
    finally:
        module.show_result = show_result
        draw.__exit__()
    rendered = marks.get("rendered", finished)
    return {
        "total": finished - started,
        "rendering": rendered - started,
        "gap_rendering": marks.get("gap_rendering", gap.longest),
        "adding": sum(seconds for _, seconds in steps),
        "longest_step": max((seconds for _, seconds in steps), default=0.0),
        "steps": ", ".join(f"{name or 'end'} {1000 * seconds:.0f}" for name, seconds in steps),
        "gap_showing": gap.longest,
        "drawing": draw.longest,
        "collections": collections.summary(),
        "stalls": [(at - started, length, seen) for at, length, seen in gap.stalls],
    }


def bench_stack(viewer, widget, size: int, repeats: int) -> tuple[list[dict], float]:
    """Runs of a 4-pass stack with metrics (after a warm-up), and the best time to cancel."""
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
    return runs, min(cancels)


def bench_planes(viewer, widget, size: int, planes: int, repeats: int) -> dict[str, list]:
    """Runs of a ``planes``-plane movie, 4 passes: the first adds the layer, the next
    replace it (the widget's "replace last", on by default). Interleaved, runs with the
    widget as it is ("held": no full garbage collection starts by itself during a run)
    and with that hold taken out ("not held")."""
    _clear(viewer)
    viewer.add_image(image(size, planes), name="movie")
    widget.mode.value = "single"
    widget.fields["passes"].value = 4
    runs: dict[str, list] = {"held": [], "not held": []}
    for _ in range(repeats):
        runs["held"].append(_timed_run(widget))
        with _collections_not_held():
            runs["not held"].append(_timed_run(widget))
    return runs


@contextlib.contextmanager
def _collections_not_held():
    """The widget's runs without their hold on full garbage collections."""
    from napari_labyrinth._qt import widget as module

    hold = module.hold_full_collections
    module.hold_full_collections = lambda: lambda: None
    try:
        yield
    finally:
        module.hold_full_collections = hold


def bench_single(viewer, widget, size: int, repeats: int) -> tuple[dict, list[dict]]:
    """The first run of one ``size``² uint16 plane in this viewer, default preset (it adds
    the result layer), and ``repeats`` runs after it, each updating the last result in
    place ("replace last")."""
    _clear(viewer)
    viewer.add_image(image(size), name=f"{size}")
    widget.mode.value = "single"
    widget.replace.value = True
    first, *runs = [_timed_run(widget) for _ in range(repeats + 1)]
    return first, runs


#: The ways of showing a new result layer that ``bench_new_layer`` compares.
NEW_LAYER_VARIANTS = {
    "in steps (as shipped)": "each step of show_result in a turn of its own, the window's "
    "repaint held from the insertion's turn to the next",
    "repainted with the insertion": "as shipped, but the window repainted in the insertion's "
    "turn (show_result without the window, as before)",
    "added in one turn": "the steps up to the selection in one turn (the earlier way): "
    "viewer.add_image(hidden) then, a turn later, visible",
    "selection deferred": "as shipped, but inserted unselected (napari's private switch "
    "LayerList._activate_on_insert) and selected a turn later",
}


def bench_new_layer(viewer, widget, size: int, repeats: int) -> dict[str, list[dict]]:
    """Runs of one ``size``² uint16 plane that each add a new layer ("replace last" off),
    the ways of :data:`NEW_LAYER_VARIANTS` interleaved, after a warm-up round; each new
    layer is removed after its run (outside the run's watch)."""
    _clear(viewer)
    viewer.add_image(image(size), name=f"{size}")
    widget.mode.value = "single"
    widget.replace.value = False
    runs: dict[str, list[dict]] = {variant: [] for variant in NEW_LAYER_VARIANTS}
    for k in range(repeats + 1):
        for variant in NEW_LAYER_VARIANTS:
            with _new_layer_variant(variant):
                run = _timed_run(widget)
            if k:  # the first round is a warm-up
                runs[variant].append(run)
            for layer in [layer for layer in viewer.layers if layer.name != f"{size}"]:
                viewer.layers.remove(layer)  # napari collects garbage: outside the watch
                _events(0.1)
    widget.replace.value = True
    return runs


@contextlib.contextmanager
def _new_layer_variant(variant: str):
    """The widget with its new layers shown the way ``variant`` says."""
    from napari_labyrinth._qt import widget as widget_module
    from napari_labyrinth._qt import worker as worker_module

    show_result, insert = widget_module.show_result, worker_module.insert_layer

    def in_one_turn(*arguments, **_options):
        steps = show_result(*arguments)  # as before: no window held
        try:
            name = next(steps)
            while name in ("built", "inserted"):  # joined to the next step, as before
                name = next(steps)
            yield name
            return (yield from steps)
        finally:
            steps.close()

    def unselected(viewer, position, layer):
        layers = getattr(viewer, "__wrapped__", viewer).layers  # the widget has a proxy
        layers._activate_on_insert = False
        try:
            layers.insert(position, layer)
        finally:
            layers._activate_on_insert = True

    def window_repainted(*arguments, **options):
        return show_result(*arguments, **{**options, "window": None})

    if variant == "added in one turn":
        widget_module.show_result = in_one_turn
    elif variant == "repainted with the insertion":
        widget_module.show_result = window_repainted
    elif variant == "selection deferred":
        worker_module.insert_layer = unselected
    try:
        yield
    finally:
        widget_module.show_result, worker_module.insert_layer = show_result, insert


def bench_bare_add(viewer, size: int, repeats: int) -> list[dict]:
    """napari alone, no plugin: ``viewer.add_image`` of a ``size``² uint16 plane from an
    event-loop callback (as a finished run's result arrives), watched like a run: what
    any new layer of that size costs the event loop on this machine."""
    from qtpy.QtCore import QTimer

    _clear(viewer)
    viewer.add_image(image(size), name=f"{size}")
    runs = []
    for k in range(repeats + 1):
        data = image(size)
        marks: dict[str, float] = {}

        def add(data=data, k=k, marks=marks) -> None:
            started = time.perf_counter()
            viewer.add_image(data, name=f"bare {k}", contrast_limits=(0, 65535))
            marks["adding"] = time.perf_counter() - started

        gap, draw = GapMeter(), DrawMeter()
        with gap, draw:
            _events(0.1)
            gap.longest = 0.0
            QTimer.singleShot(0, add)
            _events(0.6)
        runs.append(
            {"adding": marks["adding"], "gap_showing": gap.longest, "drawing": draw.longest}
        )
    for layer in [layer for layer in viewer.layers if layer.name != f"{size}"]:
        viewer.layers.remove(layer)
        _events(0.05)
    return runs[1:]  # the first is a warm-up


def _print_runs(runs: list[dict]) -> None:
    """One line per run (milliseconds but the total), its steps, its stalls."""
    print(
        "  run   total   rendering   longest gap     showing the result    longest gap while"
        "   of which: longest      full garbage\n"
        "                 (worker)   while rendering   (main thread: all"
        "    adding + drawing   vispy draw (paintGL)   collections\n"
        "                                             steps / longest step)"
    )
    for k, r in enumerate(runs, 1):
        print(
            f"  {k:>3} {r['total']:6.2f} s {1000 * r['rendering']:7.0f} ms"
            f" {1000 * r['gap_rendering']:13.0f} ms {1000 * r['adding']:11.0f} /"
            f" {1000 * r['longest_step']:3.0f} ms"
            f" {1000 * r['gap_showing']:14.0f} ms {1000 * r['drawing']:17.0f} ms"
            f"   {r['collections']}"
        )
        print(f"        steps (ms, one turn of the event loop each): {r['steps']}")
        for at, length, seen in r.get("stalls", []):
            where = "; ".join(seen) if seen else "nothing seen (waiting for the GIL or the CPU)"
            print(
                f"        stall of {1000 * length:.0f} ms at {at:+.2f} s: main thread in {where}"
            )


def _print_summary(label: str, runs: list[dict]) -> None:
    """The best and the median of a variant's longest gaps while showing, and its best run."""
    gaps = sorted(1000 * r["gap_showing"] for r in runs)
    best = min(runs, key=lambda r: r["total"])
    over = sum(gap > 1000 * GapMeter.STALL for gap in gaps)
    print(
        f"  {label}: longest gap while showing: best {gaps[0]:.0f} ms, median"
        f" {gaps[len(gaps) // 2]:.0f} ms, worst {gaps[-1]:.0f} ms; {over} of {len(gaps)}"
        f" runs over {1000 * GapMeter.STALL:.0f} ms. Best run {1000 * best['total']:.0f} ms ="
        f" rendering {1000 * best['rendering']:.0f} + showing (main thread)"
        f" {1000 * best['adding']:.0f} + the rest"
        f" {1000 * (best['total'] - best['rendering'] - best['adding']):.0f}"
    )


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--planes", type=int, default=20, help="planes of the movie (2048²)")
    parser.add_argument(
        "--parts", default="preview,single,stack,planes", help="comma-separated parts to run"
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
    if "single" in parts:
        with _viewer() as (viewer, widget):
            _single_part(viewer, widget, args)
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
    seconds, gap_on, gap_changes = bench_preview(viewer, widget, size, args.repeats)
    print(f"\npreview, {size}² uint16, default preset: change of V -> updated preview on screen")
    print(f"  {1000 * seconds:7.0f} ms (best of {args.repeats}, debounce included)")
    print(
        f"  longest event-loop gap: {1000 * gap_on:.0f} ms turning it on (its first render"
        f" and new layer), {1000 * gap_changes:.0f} ms while V changes"
    )


def _stack_part(viewer, widget, args) -> None:
    print("\nstack mode, 4 passes, metrics of every pass (2048², uint16), replace last on")
    runs, cancel = bench_stack(viewer, widget, 2048, args.repeats)
    _print_runs(runs)
    print(f"  best total: {min(r['total'] for r in runs):.2f} s")
    print(f"  cancel: {1000 * cancel:6.0f} ms (from Cancel to the end of the worker, best)")


def _planes_part(viewer, widget, args) -> None:
    print(f"\nsingle mode, {args.planes} planes of 2048², 4 passes (run 1 adds the layer,")
    print("the next runs update it in place: replace last on)")
    for variant, runs in bench_planes(viewer, widget, 2048, args.planes, args.repeats).items():
        print(f"full garbage collections {variant} during a run:")
        _print_runs(runs)


def _single_part(viewer, widget, args) -> None:
    print("\nRun -> layer, one 2048² uint16 plane, default preset, warm; each run updates")
    print("the last result in place (replace last on)")
    first, runs = bench_single(viewer, widget, 2048, args.repeats)
    _print_runs(runs)
    _print_summary("in place", runs)
    print("\nthe first run in this viewer (before those), which added the result layer:")
    _print_runs([first])
    print("\nRun -> layer, the same, each run adding a new layer (replace last off, or a first")
    print("run); ways of showing it, interleaved run by run:")
    for variant, what in NEW_LAYER_VARIANTS.items():
        print(f"  - {variant}: {what}")
    variants = bench_new_layer(viewer, widget, 2048, args.repeats)
    for variant, runs in variants.items():
        print(f"\n{variant}:")
        _print_runs(runs)
    print()
    for variant, runs in variants.items():
        _print_summary(variant, runs)
    print(
        "\nnapari alone, no plugin: viewer.add_image of a 2048² uint16 plane from an"
        " event-loop callback\n  run   add_image (main thread)   longest gap while"
        " adding + drawing   of which: longest vispy draw (paintGL)"
    )
    for k, r in enumerate(bench_bare_add(viewer, 2048, args.repeats), 1):
        print(
            f"  {k:>3} {1000 * r['adding']:19.0f} ms {1000 * r['gap_showing']:30.0f} ms"
            f" {1000 * r['drawing']:33.0f} ms"
        )
    print(f"  (load average now: {os.getloadavg()[0]:.2f})")


if __name__ == "__main__":
    sys.exit(main())
