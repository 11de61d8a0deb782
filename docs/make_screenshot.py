"""Make ``docs/screenshot.png``: napari with the widget after a stack run.

Opens napari (a real window: on a machine without a display run it under
Xvfb, e.g. ``xvfb-run -a python docs/make_screenshot.py``), loads a sample
of the plugin, renders every pass with the widget in stack mode, zooms in on
the pattern and saves a screenshot of the whole window.

Usage::

    python docs/make_screenshot.py [--sample cell] [--output docs/screenshot.png]
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


def main(argv: list[str] | None = None) -> int:
    """Render the sample in stack mode and save the screenshot; return the exit code."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument(
        "--sample", default="cell", help="sample key of the plugin (default: cell)"
    )
    parser.add_argument("--output", type=Path, default=HERE / "screenshot.png")
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

    import napari
    from qtpy.QtWidgets import QApplication

    viewer = napari.Viewer(title="napari-labyrinth", show=True)
    viewer.window.resize(*WINDOW_SIZE)
    (source,) = viewer.open_sample("napari-labyrinth", args.sample)
    _, widget = viewer.window.add_plugin_dock_widget("napari-labyrinth", "Labyrinthine tiling")
    widget.image_layer.value = source
    widget.mode.value = "stack"
    app = QApplication.instance()

    worker = widget.run()
    if worker is None:
        print(f"the widget did not start: {widget.status.value}", file=sys.stderr)
        return 1
    deadline = time.monotonic() + 300
    while widget.worker is not None and time.monotonic() < deadline:
        app.processEvents()
        time.sleep(0.02)
    result = widget.last_result
    if result is None:
        print(f"no result: {widget.status.value}", file=sys.stderr)
        return 1

    viewer.layers.selection.active = result
    height, width = source.data.shape[:2]
    camera = viewer.scene.camera if hasattr(viewer, "scene") else viewer.camera
    camera.center = (height * args.centre[0], width * args.centre[1])
    camera.zoom = args.zoom
    for _ in range(20):  # let Qt lay out and vispy draw
        app.processEvents()
        time.sleep(0.05)
    args.output.parent.mkdir(parents=True, exist_ok=True)
    viewer.screenshot(str(args.output), canvas_only=False, flash=False)
    print(f"wrote {args.output} ({result.name})")
    viewer.close()
    return 0


if __name__ == "__main__":
    sys.exit(main())
