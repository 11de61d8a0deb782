"""A run in a napari thread worker: progress bar, cancel, and the layer it adds.

The worker runs :func:`napari_labyrinth.plan.render`, a generator: napari
draws a determinate progress bar from its yields, and a cancel (the widget's
button or napari's activity panel) stops it at the next plane or pass.
"""

from __future__ import annotations

from napari.layers import Image
from napari.qt.threading import create_worker
from napari.viewer import Viewer

from ..plan import Outcome, RenderPlan, render, result_layer

#: Title of a run's progress bar in napari's activity panel.
PROGRESS_TITLE = "Labyrinthine tiling"


def render_worker(plan: RenderPlan):
    """An unstarted napari worker that runs ``plan``, with a progress bar of its steps."""
    worker = create_worker(
        render,
        plan,
        _progress={"total": plan.total_steps, "desc": PROGRESS_TITLE},
    )
    plan.abort_requested = lambda: worker.abort_requested
    return worker


def stop(worker, plan: RenderPlan) -> None:
    """Ask the run to stop at its next plane or pass; it then returns nothing."""
    plan.cancel.set()
    worker.quit()


def add_result_layer(viewer: Viewer, plan: RenderPlan, outcome: Outcome) -> Image:
    """Add the layer of a finished run; a stack or sweep shows its last plane."""
    data, kwargs = result_layer(plan, outcome)
    # Added hidden, so that napari slices it once, where the viewer stands (a
    # new layer is otherwise sliced at index 0 first: a lazy plane computed
    # for nothing), after the slider of a stack or sweep moves to its end.
    layer = viewer.add_image(data, visible=False, **kwargs)
    if plan.mode in ("stack", "sweep"):
        axis = viewer.dims.ndim - layer.ndim
        viewer.dims.set_current_step(axis, data.shape[0] - 1)
    layer.visible = True
    return layer
