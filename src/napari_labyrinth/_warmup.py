"""Compile numba's kernels in a process of their own, out of the viewer's.

numba compiles a kernel the first time it is called with new argument types
(once after an install: the compiled code then stays in numba's disk cache)
and holds the interpreter while it does, which would freeze the viewer for
seconds. The widget therefore has this module compile them:

``python -m napari_labyrinth._warmup --dtype uint16`` as it opens: what a
first run on an image of that dtype with the default preset needs (the
render and the metrics of a stack). A run the user starts meanwhile waits
for the process (the widget says so) rather than compiling the same kernels
beside it; what a run needs beyond them (another preset, another dtype)
compiles in the run. The process prints a line per step (``step K of N:
what``) and per kernel it compiles (``kernel NAME``), which the widget shows,
and ends with the viewer. Run it by hand after an install to the same effect.

Where the install's shipped kernels load (``core._shipped``), nothing is left to
compile and the widget starts no such process.

``python -m napari_labyrinth._warmup --all`` makes every first call a user can
make (:mod:`._every_call`): the build of the platform wheel runs it to compile
every kernel into the wheel, and it fills numba's cache where no wheel carries
them.
"""

from __future__ import annotations

import argparse
import os
import sys
from collections.abc import Callable

import numpy as np

from .core._shipped import shipped

#: Set to any value to keep the widget from compiling out of its process (tests do):
#: runs then compile in the viewer's process, as a script's calls do.
DISABLE_VARIABLE = "NAPARI_LABYRINTH_NO_WARMUP"

#: The dtype prepared when the widget opens on no image layer.
DEFAULT_DTYPE = "uint16"

#: Side of the image the warm-up renders: large enough for the tiles of a first run.
WARM_UP_SIDE = 1024


def disabled() -> bool:
    """Whether kernels compile in the process that needs them (``DISABLE_VARIABLE`` set)."""
    return bool(os.environ.get(DISABLE_VARIABLE))


def needed() -> bool:
    """Whether first calls compile kernels here: the install's shipped kernels do not load
    (``core._shipped``), so a warm-up process has something to do."""
    return shipped().refused is not None


def command(*arguments: str) -> list[str]:
    """The command line of a warm-up with ``arguments`` (``--dtype D``)."""
    return [sys.executable, "-m", "napari_labyrinth._warmup", *arguments]


def warm_up_steps(dtype) -> list[tuple[str, Callable[[], object]]]:
    """The steps that compile what a first run on an image of ``dtype`` needs: a render
    with the default preset, then the metrics of a stack, as the widget calls them."""
    from . import labyrinth, metrics  # the widget imports this module; only the warm-up runs them

    dtype = np.dtype(dtype)
    columns = np.indices((WARM_UP_SIDE, WARM_UP_SIDE))[1]
    stripes = np.where(np.cos(np.pi * columns / 2) > 0, 0.9, 0.1)
    if dtype.kind in "iu":
        info = np.iinfo(dtype)
        limits = (float(info.min), float(info.max))
        image = (limits[0] + stripes * (limits[1] - limits[0])).astype(dtype)
    else:
        limits = (0.0, 1.0)
        image = stripes.astype(dtype)
    rendered = {}

    def render():
        rendered["image"] = labyrinth(image, passes=1, tone_limits=limits)

    def measure():
        comparison = metrics.Comparison(image, tone_limits=limits)
        for _ in comparison.describe_steps(rendered["image"]):
            pass

    return [(f"the render of {dtype} images", render), ("the metrics of a stack", measure)]


def run_steps(steps: list[tuple[str, Callable[[], object]]]) -> None:
    """Run ``steps``, printing each and every kernel numba compiles on the way."""
    from numba.core import event

    class Announcer(event.Listener):
        def on_start(self, ev):
            function = ev.data["dispatcher"].py_func
            if function.__module__.startswith("napari_labyrinth") and function.__name__[0] != "_":
                print(f"kernel {function.__name__}", flush=True)

        def on_end(self, ev):
            pass

    with event.install_listener("numba:compile", Announcer()):
        for number, (label, step) in enumerate(steps, start=1):
            print(f"step {number} of {len(steps)}: {label}", flush=True)
            step()


def main(argv: list[str] | None = None) -> int:
    """``python -m napari_labyrinth._warmup [--dtype D | --all]``."""
    parser = argparse.ArgumentParser(prog="python -m napari_labyrinth._warmup")
    parser.add_argument("--dtype", default=DEFAULT_DTYPE, help="dtype of the images to prepare")
    parser.add_argument(
        "--all", action="store_true", help="every first call a user can make (the wheel's build)"
    )
    arguments = parser.parse_args(argv)
    if arguments.all:
        from ._every_call import every_call_steps  # the whole package: only for --all

        run_steps(every_call_steps())
    else:
        run_steps(warm_up_steps(arguments.dtype))
    print("done", flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
