"""Compile the numba kernels into their disk cache, in a process of its own.

numba compiles a kernel on its first call and holds the GIL while it does:
in the napari widget that would freeze the viewer for the ~20 s the metrics
need the first time after an install. The widget therefore starts this
module once per session as a separate, low-priority process
(``python -m napari_labyrinth._warmup``); it renders and measures a tiny
image, numba writes its cache, and the widget's own first calls load the
compiled code in a fraction of a second. Run it by hand after an install to
the same effect.
"""

from __future__ import annotations

import os
import subprocess
import sys

import numpy as np

#: Set to any value to keep the widget from starting the warm-up process (tests do).
DISABLE_VARIABLE = "NAPARI_LABYRINTH_NO_WARMUP"

_started = False


#: The dtypes whose tone loops the warm-up compiles: those of most microscopy layers.
WARMED_DTYPES = (np.uint8, np.uint16, np.float32)


def warm_up() -> None:
    """Render and measure a small striped image in each of ``WARMED_DTYPES`` and in colour:
    every kernel the widget uses gets compiled (the plane is large enough to be tiled)."""
    from . import labyrinth, metrics

    stripes = np.where(np.cos(np.pi * np.indices((256, 256))[1] / 2) > 0, 230, 30).T
    for dtype in WARMED_DTYPES:
        rendered = labyrinth(stripes.astype(dtype), passes=1, workers=2)
        labyrinth(stripes.astype(dtype), passes=1, workers=1)  # integers: the banded pass
    labyrinth(np.stack([stripes] * 3, axis=-1).astype(np.uint8), channel_axis=-1, passes=1)
    metrics.describe(stripes.astype(np.float32), rendered.astype(np.float32))


def start_in_background() -> None:
    """Start the warm-up process once per session (a no-op when disabled or started)."""
    global _started
    if _started or os.environ.get(DISABLE_VARIABLE):
        return
    _started = True
    try:
        subprocess.Popen(
            [sys.executable, "-m", "napari_labyrinth._warmup"],
            stdin=subprocess.DEVNULL,
            stdout=subprocess.DEVNULL,
            stderr=subprocess.DEVNULL,
            start_new_session=True,
        )
    except OSError:  # no interpreter to start: the first calls compile in process
        pass


if __name__ == "__main__":
    if hasattr(os, "nice"):
        os.nice(10)
    warm_up()
