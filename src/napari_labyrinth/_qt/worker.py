"""A run in a napari thread worker: progress bar, cancel, and the layer it adds.

The worker drives :func:`napari_labyrinth.widget.run.render`, a generator: napari
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
from qtpy.QtWidgets import QWidget

from ..widget.plan import RenderPlan
from ..widget.run import Outcome, render, result_layer

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
) -> Image | None:
    """Show the result of a finished run at once (all of :func:`show_result`'s steps).

    Returns the layer, or None when it was removed from the viewer meanwhile.
    """
    steps = show_result(viewer, plan, outcome, previous)
    while True:
        try:
            next(steps)
        except StopIteration as done:
            return done.value


def show_result(
    viewer: Viewer,
    plan: RenderPlan,
    outcome: Outcome,
    previous: Image | None = None,
    *,
    window: QWidget | None = None,
) -> Generator[str, None, Image | None]:
    """Show the result of a finished run, one step at each ``next()``; a stack or sweep
    shows its last plane.

    Each step yields what it did; the generator then returns the layer (None when
    the user removed it between two steps). The widget runs one step per turn of
    the event loop, so that no turn holds napari's work of adding a layer and of
    drawing it together:

    1. the layer is built, hidden (a few ms);
    2. it is inserted in the layer list: napari builds its vispy visual and its
       layer controls and selects it (shows its controls, restyles its buttons).
       ``window`` (the viewer's main window), if given, is not repainted in this
       turn (Qt's ``setUpdatesEnabled``): Qt would otherwise repaint it at once,
       before the event loop's next turn, and under software OpenGL the repaint
       of a whole window (its widgets, the canvas, their composition) takes as
       long again as napari's insertion;
    3. the window is repainted (the new controls, the layer list); the layer is
       made the active layer if it is not (a plugin cannot keep napari from
       selecting a layer as it inserts it but through a private switch) and the
       slider of a stack or sweep moves to its last plane;
    4. it is made visible: napari slices it once, where the viewer stands (a new
       layer is otherwise sliced at index 0 first: a lazy plane computed for
       nothing), and the canvas draws it, uploading its texture;
    5. a ``previous`` result that could not be updated in place is removed (napari
       runs a full garbage collection for every layer removed: a turn of its own).

    A ``previous`` result still in the viewer is replaced: updated in place (data,
    name, metadata, contrast, transforms; one step) when it can hold the new data
    (same number of axes, both RGB or both not, both multiscale or both not), else a new layer takes its place
    in the layer list. In place is much cheaper for the event loop: napari builds
    no new visual and no new controls, and removes no layer.

    Closing the generator before its end (a cancel, a closed dock, a removed
    input), or a step that fails, takes a layer it inserted back out of the
    viewer and leaves ``previous`` where it is (an update in place, a single
    step, is done once it has yielded).
    """
    data, kwargs = result_layer(plan, outcome)
    if _updatable(viewer, previous, data, kwargs):
        layer = previous
        layer.visible = False  # sliced once below, where the viewer will stand
        _update_in_place(layer, data, kwargs)
        viewer.layers.selection.active = layer
        _go_to_last_plane(viewer, plan, layer)
        layer.visible = True
        yield "updated in place"
        return layer
    layer = Image(data, visible=False, **kwargs)
    yield "built"
    replaced = previous if previous is not None and previous in viewer.layers else None
    # just above the layer it replaces, which then leaves its place to it
    position = viewer.layers.index(replaced) + 1 if replaced is not None else len(viewer.layers)
    held = hold_repaints(window)
    try:
        insert_layer(viewer, position, layer)
        yield "inserted"
        held = resume_repaints(window, held)
        if layer not in viewer.layers:
            return None
        viewer.layers.selection.active = layer
        _go_to_last_plane(viewer, plan, layer)
        yield "selected"
        if layer not in viewer.layers:
            return None
        layer.visible = True
        yield "shown"
    except BaseException:  # closed early (GeneratorExit), or a step failed
        if layer in viewer.layers:
            viewer.layers.remove(layer)
        raise
    finally:
        resume_repaints(window, held)
    if replaced is not None and replaced in viewer.layers:
        viewer.layers.remove(replaced)
        yield "previous removed"
    return layer if layer in viewer.layers else None


#: Delay of a step put in a later turn of the event loop: a timer, not a 0 ms call, which
#: Qt would run in the same turn, before due timers and pending repaints.
NEXT_TURN_MS = 1


def main_window(widget: QWidget | None) -> QWidget | None:
    """The top-level window that holds ``widget`` (a floating dock's main window too: its
    parent); None for a widget that no window holds, or for no widget."""
    if not isinstance(widget, QWidget):
        return None
    window = widget.parentWidget()
    while window is not None and window.parentWidget() is not None:
        window = window.parentWidget()
    return window


def hold_repaints(window: QWidget | None) -> bool:
    """Stop ``window``'s repaints until :func:`resume_repaints`; whether this held them
    (not if they were held already, or there is no window)."""
    if window is None or not window.updatesEnabled():
        return False
    window.setUpdatesEnabled(False)
    return True


def resume_repaints(window: QWidget | None, held: bool) -> bool:
    """Let ``window`` repaint again (all of it, in a later turn) if :func:`hold_repaints`
    held it; returns False (nothing held any more)."""
    if held:
        try:
            window.setUpdatesEnabled(True)
        except RuntimeError:  # the window's Qt object is gone (the viewer was closed)
            pass
    return False


def insert_layer(viewer: Viewer, position: int, layer: Image) -> None:
    """Insert ``layer`` in the layer list at ``position`` (napari selects it)."""
    viewer.layers.insert(position, layer)


def _go_to_last_plane(viewer: Viewer, plan: RenderPlan, layer: Image) -> None:
    """Move the slider of a stack's or sweep's leading axis to its last plane."""
    if plan.mode in ("stack", "sweep"):
        axis = viewer.dims.ndim - layer.ndim
        viewer.dims.set_current_step(axis, layer.data.shape[0] - 1)


#: Attributes of a result layer that an update in place sets (``data`` first); the rest of
#: ``result_layer``'s keyword arguments (``rgb``, ``multiscale``) must already agree.
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
    multiscale = bool(kwargs.get("multiscale", False))  # data: the list of its levels
    return (
        isinstance(previous, Image)
        and previous in viewer.layers
        and previous.multiscale == multiscale
        and previous.ndim == (data[0] if multiscale else data).ndim
        and previous.rgb == kwargs["rgb"]
    )


def _update_in_place(layer: Image, data, kwargs: dict) -> None:
    """Give ``layer`` the data and settings of a new result (``result_layer``'s output)."""
    unknown = set(kwargs) - set(IN_PLACE) - {"rgb", "multiscale"}
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
