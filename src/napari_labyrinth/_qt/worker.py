"""A run in a napari thread worker: progress bar, cancel, and the layer it adds.

The worker drives :func:`napari_labyrinth.run.render`, a generator: napari
draws a determinate progress bar from its yields. A cancel (the widget's
button, or napari's activity panel) stops the run at the next pass, and the
run is closed at once, which stops the rendering threads behind it.
"""

from __future__ import annotations

from collections.abc import Generator
from typing import Any

import numpy as np
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
    viewer: Viewer,
    plan: RenderPlan,
    outcome: Outcome,
    previous: Image | None = None,
    *,
    show_new: bool = True,
) -> Image:
    """Show the result of a finished run; a stack or sweep shows its last plane.

    A ``previous`` result still in the viewer is replaced: updated in place
    (data, name, metadata, contrast, transforms) when it can hold the new
    data (same number of axes, both RGB or both not), else removed and the
    new layer put in its place in the layer list. In place is much cheaper
    for the event loop: napari builds no new visual and no new controls,
    and removing a layer makes napari run a full garbage collection.

    With ``show_new=False`` a new layer is left hidden: the caller shows it
    (``visible = True``) in a later turn of the event loop, so that napari's
    adding it and its first draw do not stall the event loop together.
    """
    data, kwargs = result_layer(plan, outcome)
    if _updatable(viewer, previous, data, kwargs):
        layer = previous
        layer.visible = False  # sliced once below, where the viewer will stand
        _update_in_place(layer, data, kwargs)
        viewer.layers.selection.active = layer
    else:
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
    if layer is previous or show_new:
        layer.visible = True
    return layer


#: Attributes of a result layer that an update in place sets (``data`` first); the rest of
#: ``result_layer``'s keyword arguments (``rgb``) must already agree.
IN_PLACE = (
    "scale",
    "translate",
    "rotate",
    "shear",
    "affine",
    "units",
    "axis_labels",
    "contrast_limits",
    "gamma",
    "opacity",
    "blending",
    "interpolation2d",
    "colormap",
    "metadata",
    "name",
)


def _updatable(viewer: Viewer, previous: Image | None, data, kwargs: dict) -> bool:
    return (
        isinstance(previous, Image)
        and previous in viewer.layers
        and not previous.multiscale
        and previous.ndim == data.ndim
        and previous.rgb == kwargs["rgb"]
    )


def _update_in_place(layer: Image, data, kwargs: dict) -> None:
    """Give ``layer`` the data and settings of a new result (``result_layer``'s output)."""
    unknown = set(kwargs) - set(IN_PLACE) - {"rgb"}
    if unknown:  # pragma: no cover - a new keyword of result_layer not handled here
        raise ValueError(f"cannot update a layer in place with {sorted(unknown)}")
    layer.data = data
    for name in IN_PLACE:
        if name in kwargs and not agrees(getattr(layer, name), kwargs[name]):
            setattr(layer, name, kwargs[name])  # a transform set costs napari a new extent


def agrees(current: Any, value: Any) -> bool:
    """Whether a layer attribute already holds ``value`` (False when unsure: then it is set)."""
    if hasattr(current, "affine_matrix"):
        current = current.affine_matrix
    if isinstance(value, (list, tuple, np.ndarray)) or isinstance(current, np.ndarray):
        try:
            a, b = np.asarray(current), np.asarray(value)
            if a.dtype.kind in "biuf" and b.dtype.kind in "biuf":
                return a.shape == b.shape and bool(np.array_equal(a, b))
        except (TypeError, ValueError):
            return False
        return [str(v) for v in current] == [str(v) for v in value]  # units, axis labels
    if isinstance(value, dict):
        return False  # metadata: cheap to set, costly to compare
    try:
        return bool(current == value)
    except Exception:  # noqa: BLE001 - an odd comparison: set the attribute
        return False
