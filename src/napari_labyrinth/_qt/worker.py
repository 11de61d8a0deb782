"""A run in a napari thread worker: progress bar, cancel, and the layer it adds.

The worker drives :func:`napari_labyrinth.run.render`, a generator: napari
draws a determinate progress bar from its yields. A cancel (the widget's
button, or napari's activity panel) stops the run at the next pass, and the
run is closed at once, which stops the rendering threads behind it.
"""

from __future__ import annotations

from collections.abc import Generator
from typing import Any

from napari.layers import Image
from napari.qt.threading import create_worker
from napari.viewer import Viewer

from ..plan import RenderPlan
from ..run import Outcome, render, result_layer

#: Title of a run's progress bar in napari's activity panel.
PROGRESS_TITLE = "Labyrinthine tiling"


def _steps_of(run: Generator[int, None, Any]) -> Generator[int, None, Any]:
    """The steps of ``run``, as a generator function napari can drive."""
    return (yield from run)


def render_worker(plan: RenderPlan, progress: bool = True):
    """An unstarted napari worker that runs ``plan``; ``progress``: a bar in the activity panel."""
    run = render(plan)
    bar = {"_progress": {"total": plan.total_steps, "desc": PROGRESS_TITLE}} if progress else {}
    worker = create_worker(_steps_of, run, **bar)
    plan.abort_requested = lambda: worker.abort_requested
    # An aborted napari worker stops driving its generator without closing it:
    # closing the run here stops its rendering threads now, not when it is collected.
    worker.aborted.connect(run.close)
    return worker


def stop(worker, plan: RenderPlan) -> None:
    """Ask the run to stop at its next pass; it then returns nothing."""
    plan.cancel.set()
    worker.quit()


def add_result_layer(
    viewer: Viewer, plan: RenderPlan, outcome: Outcome, previous: Image | None = None
) -> Image:
    """Add the layer of a finished run; a stack or sweep shows its last plane.

    A ``previous`` result still in the viewer is replaced: the new layer takes
    its place in the layer list.
    """
    data, kwargs = result_layer(plan, outcome)
    # Added hidden, so that napari slices it once, where the viewer stands (a
    # new layer is otherwise sliced at index 0 first: a lazy plane computed
    # for nothing), after the slider of a stack or sweep moves to its end.
    layer = viewer.add_image(data, visible=False, **kwargs)
    if previous is not None and previous in viewer.layers:
        position = viewer.layers.index(previous)
        viewer.layers.remove(previous)
        viewer.layers.move(viewer.layers.index(layer), position)
    if plan.mode in ("stack", "sweep"):
        axis = viewer.dims.ndim - layer.ndim
        viewer.dims.set_current_step(axis, data.shape[0] - 1)
    layer.visible = True
    return layer
