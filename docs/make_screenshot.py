"""Make the screenshots of the widget: after a stack run, after Auto V, after a sweep.

Opens napari (a real window: on a machine without a display run it under
Xvfb, e.g. ``xvfb-run -a python docs/make_screenshot.py``) at 1400×900, loads
a sample of the plugin and, in a fresh viewer for each picture:

- ``stack``: renders every pass in stack mode with the metrics, zooms in on
  the pattern -> ``docs/screenshot.png`` (the README's picture);
- ``auto``: presses Auto beside V -> ``docs/screenshot-auto.png``;
- ``sweep``: renders a sweep of V -> ``docs/screenshot-sweep.png``;
- ``preparing``: with an empty numba cache, presses Run as the widget opens,
  while its warm-up compiles the kernels -> ``docs/screenshot-preparing.png``.

For each it prints the layout checks a reader would otherwise judge by eye
(the metrics table needs no horizontal scrollbar, the plots' texts are clear
of their data and inside the dock, the plot is scrolled into view), and with
``--crops DIR`` writes the dock of each picture magnified 2× for a close look.

Usage::

    python docs/make_screenshot.py [--shots stack auto sweep] [--sample cell] [--crops DIR]
"""

from __future__ import annotations

import argparse
import os
import sys
import tempfile
import time
from pathlib import Path

WINDOW_SIZE = (1400, 900)
HERE = Path(__file__).resolve().parent
SHOTS = {
    "stack": "screenshot.png",
    "auto": "screenshot-auto.png",
    "sweep": "screenshot-sweep.png",
    "preparing": "screenshot-preparing.png",
}
#: Longest wait for a run or a search, in seconds.
TIMEOUT = 600


def main(argv: list[str] | None = None) -> int:
    """Make the chosen screenshots; return the exit code (1 if a run failed)."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--shots", nargs="+", choices=list(SHOTS), default=list(SHOTS))
    parser.add_argument(
        "--sample", default="cell", help="sample key of the plugin (default: cell)"
    )
    parser.add_argument("--output-dir", type=Path, default=HERE)
    parser.add_argument("--crops", type=Path, help="also write the dock of each picture, 2×")
    parser.add_argument("--zoom", type=float, default=2.4, help="screen pixels per image pixel")
    parser.add_argument(
        "--centre",
        type=float,
        nargs=2,
        default=(0.56, 0.72),  # the cell of scikit-image's "cell"
        metavar=("ROW", "COLUMN"),
        help="centre of the view, as fractions of the image height and width",
    )
    args = parser.parse_args(argv)

    # napari writes settings: keep them out of the user's configuration
    scratch = tempfile.mkdtemp(prefix="napari-labyrinth-screenshot-")
    os.environ.setdefault("XDG_CONFIG_HOME", os.path.join(scratch, "config"))
    os.environ.setdefault("XDG_CACHE_HOME", os.path.join(scratch, "cache"))

    if "preparing" in args.shots:  # a cache of its own, empty: as after an install
        os.environ["NUMBA_CACHE_DIR"] = os.path.join(scratch, "numba")
    failed = 0
    for shot in args.shots:
        failed += not make_shot(shot, args, args.output_dir / SHOTS[shot])
    return 1 if failed else 0


def make_shot(shot: str, args, output: Path) -> bool:
    """Open a fresh viewer, do ``shot``, save the window to ``output``; True on success."""
    import napari
    from qtpy.QtWidgets import QApplication

    viewer = napari.Viewer(title="napari-labyrinth", show=True)
    viewer.window.resize(*WINDOW_SIZE)
    app = QApplication.instance()
    try:
        (source,) = viewer.open_sample("napari-labyrinth", args.sample)
        _, widget = viewer.window.add_plugin_dock_widget(
            "napari-labyrinth", "Labyrinthine tiling"
        )
        widget.image_layer.value = source
        if shot == "preparing":
            return _preparing_shot(viewer, widget, app, output)
        if shot == "auto":
            worker = widget.auto_window.find()
            busy = lambda: widget.auto_window.worker is not None  # noqa: E731
        else:
            widget.mode.value = shot
            worker = widget.run()
            busy = lambda: widget.worker is not None  # noqa: E731
        if worker is None:
            print(f"{shot}: did not start: {widget.status.value}", file=sys.stderr)
            return False
        deadline = time.monotonic() + TIMEOUT
        while busy() and time.monotonic() < deadline:
            app.processEvents()
            time.sleep(0.02)
        if shot != "auto" and widget.last_result is None:
            print(f"{shot}: no result: {widget.status.value}", file=sys.stderr)
            return False
        if shot == "stack":
            viewer.layers.selection.active = widget.last_result
            height, width = source.data.shape[:2]
            camera = viewer.scene.camera if hasattr(viewer, "scene") else viewer.camera
            camera.center = (height * args.centre[0], width * args.centre[1])
            camera.zoom = args.zoom
        for _ in range(20):  # let Qt lay out and vispy draw
            app.processEvents()
            time.sleep(0.05)
        output.parent.mkdir(parents=True, exist_ok=True)
        picture = viewer.screenshot(str(output), canvas_only=False, flash=False)
        print(f"{shot}: wrote {output}: {widget.status.value}")
        for line in layout_checks(widget):
            print(f"  {line}")
        if args.crops is not None:
            write_dock_crop(picture, widget, viewer, args.crops / f"{output.stem}-dock.png")
        return True
    finally:
        # one layer at a time: removing several at once can crash software OpenGL in vispy
        while len(viewer.layers):
            viewer.layers.remove(viewer.layers[-1])
            app.processEvents()
        viewer.close()
        app.processEvents()


def _preparing_shot(viewer, widget, app, output: Path) -> bool:
    """Run pressed as the widget opens: the picture of the wait for the warm-up."""
    from napari_labyrinth._qt.warm_up import PREPARING

    if widget.run() is None:
        print(f"preparing: did not start: {widget.status.value}", file=sys.stderr)
        return False
    deadline = time.monotonic() + 15
    while time.monotonic() < deadline and "compiling" not in widget.status.value:
        app.processEvents()
        time.sleep(0.02)
    if not widget.status.value.startswith(PREPARING):
        print(f"preparing: the run did not wait: {widget.status.value}", file=sys.stderr)
        return False
    for _ in range(10):
        app.processEvents()
        time.sleep(0.05)
    output.parent.mkdir(parents=True, exist_ok=True)
    viewer.screenshot(str(output), canvas_only=False, flash=False)
    print(f"preparing: wrote {output}: {widget.status.value}")
    widget.cancel()
    return True


def layout_checks(widget) -> list[str]:
    """What a reader checks by eye in the dock, measured: each line says "ok" or "BAD"."""
    lines = []
    viewport = widget.scroll_area.viewport()

    def verdict(good: bool) -> str:
        return "ok " if good else "BAD"

    table = widget.metrics_table
    if table.isVisible():
        fits = not table.needs_scrollbar()
        lines.append(
            f"{verdict(fits)} metrics table: {table.content_width()} px of content in "
            f"{table.width()} px, horizontal scrollbar {'not needed' if fits else 'needed'}"
        )
    plots = [("metrics plot", widget.metrics_plot)]
    plots.append(("Auto plot", widget.auto_window.plot))
    for name, plot in plots:
        if not plot.isVisible():
            continue
        rects = plot.plot_rects()
        clear = not any(rect.intersects(rects.data) for rect in rects.texts())
        inside = all(rect.left() >= 0 and rect.right() <= plot.width() for rect in rects.texts())
        top = plot.mapTo(viewport, plot.rect().topLeft()).y()
        shown = top >= 0 and top + plot.height() <= viewport.height()
        lines.append(f"{verdict(clear)} {name}: texts clear of the data rectangle")
        lines.append(f"{verdict(inside)} {name}: texts inside its {plot.width()} px width")
        lines.append(f"{verdict(shown)} {name}: wholly in view in the dock")
    return lines


def write_dock_crop(picture, widget, viewer, path: Path) -> None:
    """Write the dock's part of the window's ``picture``, magnified 2× (pixels repeated)."""
    import imageio.v3 as iio
    import numpy as np
    from qtpy.QtCore import QPoint

    window = viewer.window._qt_window
    corner = widget.mapTo(window, QPoint(0, 0))
    scale = picture.shape[1] / window.width()  # the device pixel ratio
    top, left = int(corner.y() * scale), int(corner.x() * scale)
    bottom, right = top + int(widget.height() * scale), left + int(widget.width() * scale)
    crop = np.asarray(picture)[top:bottom, left:right]
    path.parent.mkdir(parents=True, exist_ok=True)
    iio.imwrite(path, np.repeat(np.repeat(crop, 2, axis=0), 2, axis=1))
    print(f"  wrote {path}")


if __name__ == "__main__":
    sys.exit(main())
