"""Live preview: the plane on screen re-rendered into one layer as the parameters change.

While the preview is on, every change of a parameter, of the input, of the
plane on screen or of the zoom and the view (a multiscale input's level on screen, and the
part of it on screen) restarts a short timer (debounce); when it fires, the plane
on screen is rendered in a worker. A newer request cancels the render in
flight, and a render that is not the newest is never shown: each one carries
a generation number, and only the newest generation updates the layer. The
layer is updated in place; turning the preview off removes it. A new preview
layer is inserted hidden, with the window's repaints held for that turn of the
event loop, and shown in the next (as the widget shows a new result:
``worker.show_result``), so that napari's insertion and Qt's repaint of the
window after it do not stall one turn together. Full garbage collections stay
held until a turn after the draw of what a render shows.
"""

from __future__ import annotations

import time
from collections.abc import Callable

from napari.layers import Image
from napari.viewer import Viewer
from qtpy.QtCore import QObject, QTimer

from ..widget.choices import Choices, LayerSnapshot, preview_choices
from ..widget.plan import RenderPlan, make_plan
from ..widget.run import Failure, Outcome, result_layer
from .collector import hold_full_collections, hold_while_running
from .worker import (
    NEXT_TURN_MS,
    agrees,
    hold_repaints,
    main_window,
    render_worker,
    resume_repaints,
    stop,
)

#: Milliseconds without a change before the preview renders.
DEBOUNCE_MS = 60

#: The layer attributes a newer preview may change besides its data.
_UPDATED = ("translate", "scale", "contrast_limits", "metadata", "name")


class Preview:
    """The preview of one widget.

    Parameters
    ----------
    viewer : napari.viewer.Viewer
    snapshot, choices : callable
        Return the input layer's snapshot and the user's choices now.
    report : callable
        Called with a line for the user (a failed preview says why).
    parent : QObject
        Owner of the debounce timer (the widget): the timer dies with it.

    Attributes
    ----------
    layer : napari.layers.Image or None
        The preview layer, while the preview is on and has rendered.
    latencies : list of float
        Seconds from each request that was shown to its layer update.
    """

    def __init__(
        self,
        viewer: Viewer,
        snapshot: Callable[[], LayerSnapshot | None],
        choices: Callable[[], Choices],
        report: Callable[[str], None],
        parent: QObject,
    ) -> None:
        self.viewer = viewer
        self._snapshot, self._choices, self._report = snapshot, choices, report
        self.enabled = False
        self.layer: Image | None = None
        self.latencies: list[float] = []
        self.generation = 0
        self.shown_generation = 0
        self._requested_at = 0.0
        self._key = None
        self._worker = None
        self._plan: RenderPlan | None = None
        self._parent = parent
        self._revealing = False  # a new preview layer inserted, shown in the next turn
        self._timer = QTimer(parent)
        self._timer.setSingleShot(True)
        self._timer.setInterval(DEBOUNCE_MS)
        self._timer.timeout.connect(self._render)
        # a multiscale input's level, and the part of it on screen
        self._camera = viewer_camera(viewer)
        self._camera.events.zoom.connect(self.request)
        self._camera.events.center.connect(self.request)

    @property
    def busy(self) -> bool:
        """Whether a preview is waiting for its timer, rendering, or not yet shown."""
        return self._timer.isActive() or self._worker is not None or self._revealing

    def set_enabled(self, enabled: bool) -> None:
        """Turn the preview on (renders at once) or off (removes its layer)."""
        self.enabled = bool(enabled)
        if self.enabled:
            self._key = None
            self.request()
            return
        self._timer.stop()
        self._cancel()
        if self.layer is not None and self.layer in self.viewer.layers:
            self.viewer.layers.remove(self.layer)
        self.layer, self._revealing = None, False

    def request(self, *_args) -> None:
        """Something changed: render again once nothing has changed for ``DEBOUNCE_MS``."""
        if not self.enabled:
            return
        self._requested_at = time.perf_counter()
        self._timer.start()

    def _render(self) -> None:
        snapshot = self._snapshot()
        if snapshot is None:
            return
        if self.layer is not None and snapshot.data is self.layer.data:
            return  # the preview layer itself is selected as the input
        try:
            plan = make_plan(snapshot, preview_choices(self._choices()))
        except (TypeError, ValueError) as exc:
            self._report(f"Preview: {exc}")
            return
        key = (id(snapshot.data), snapshot.visible_index, snapshot.data_level)
        key += (repr(plan.arguments), repr(plan.source_region))
        if key == self._key and self.layer is not None:
            return  # nothing that the preview shows changed
        self._key = key
        self._cancel()
        self.generation += 1
        generation, requested_at = self.generation, self._requested_at
        worker = render_worker(plan, progress=False)
        worker.returned.connect(
            lambda outcome: self._show(generation, requested_at, plan, outcome)
        )
        worker.finished.connect(lambda: self._finished(worker))
        hold_while_running(worker)
        self._worker, self._plan = worker, plan
        worker.start()

    def _cancel(self) -> None:
        if self._worker is not None and self._plan is not None:
            stop(self._worker, self._plan)
        self._worker = self._plan = None

    def _finished(self, worker) -> None:
        if worker is self._worker:
            self._worker = self._plan = None

    def _show(self, generation: int, requested_at: float, plan: RenderPlan, outcome) -> None:
        if not self.enabled or generation != self.generation or outcome is None:
            return  # off, stale, or cancelled: a newer render is on its way
        if isinstance(outcome, Failure):
            self._report(f"Preview failed: {outcome.message}")
            return
        assert isinstance(outcome, Outcome)
        data, kwargs = result_layer(plan, outcome)
        kwargs["name"] = f"{plan.source} · preview"
        # the worker's hold ends after this turn: no full collection in the draws to come
        release = hold_full_collections()
        layer = self.layer
        if layer is None or layer not in self.viewer.layers or layer.data.shape != data.shape:
            if layer is not None and layer in self.viewer.layers:
                self.viewer.layers.remove(layer)
            self._insert(Image(data, visible=False, **kwargs), generation, requested_at, release)
            return
        layer.data = data
        for name in _UPDATED:
            if not agrees(getattr(layer, name), kwargs[name]):
                setattr(layer, name, kwargs[name])  # a transform costs napari an extent
        self._shown(generation, requested_at)
        QTimer.singleShot(NEXT_TURN_MS, release)  # after the draw of the update

    def _insert(self, layer: Image, generation: int, requested_at: float, release) -> None:
        """Insert the new preview layer hidden, the window not repainted in this turn;
        show it in the next (``release`` ends the hold on full collections after that)."""
        window = main_window(self._parent)
        held = hold_repaints(window)
        try:
            self.viewer.layers.append(layer)
        except BaseException:
            resume_repaints(window, held)
            release()
            raise
        self.layer, self._revealing = layer, True
        QTimer.singleShot(
            NEXT_TURN_MS,
            lambda: self._reveal(layer, window, held, generation, requested_at, release),
        )

    def _reveal(self, layer, window, held: bool, generation: int, requested_at: float, release):
        """The turn after the insertion: the window repaints and the layer is shown, unless
        the preview went off or moved to another layer meanwhile."""
        resume_repaints(window, held)
        QTimer.singleShot(NEXT_TURN_MS, release)  # after the first draw
        if layer is not self.layer:
            return
        self._revealing = False
        if layer in self.viewer.layers:
            layer.visible = True
            self._shown(generation, requested_at)

    def _shown(self, generation: int, requested_at: float) -> None:
        self.shown_generation = max(self.shown_generation, generation)
        self.latencies.append(time.perf_counter() - requested_at)

    def close(self) -> None:
        """Stop for good (the widget is closing)."""
        self.set_enabled(False)
        self._camera.events.zoom.disconnect(self.request)
        self._camera.events.center.disconnect(self.request)


def viewer_camera(viewer: Viewer):
    """The viewer's camera: ``viewer.scene.camera`` from napari 0.9 on (``viewer.camera``
    is deprecated there), ``viewer.camera`` before."""
    scene = getattr(viewer, "scene", None)
    camera = getattr(scene, "camera", None)
    return camera if camera is not None else viewer.camera
