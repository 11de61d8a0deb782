"""The dock widget: render an image layer with the labyrinthine tiling.

Layout and wiring only. The sections live in their own modules (the input in
:mod:`.inputs`, the parameter fields in :mod:`.form`, the metrics table in
:mod:`.metrics_table`, compare in :mod:`.compare`); what a run does is
decided by :func:`napari_labyrinth.widget.plan.make_plan` from a snapshot of the
input layer and of the user's choices, and :mod:`.worker` runs it in a napari
thread worker and adds the layer it hands back, whose metadata records the API
call so that it can be reproduced exactly.
"""

from __future__ import annotations

import contextlib
import time
from typing import Any

from magicgui.widgets import (
    CheckBox,
    ComboBox,
    Container,
    Label,
    LineEdit,
    PushButton,
    RadioButtons,
)
from napari.layers import Image
from napari.utils.notifications import show_error, show_info
from napari.viewer import Viewer
from qtpy.QtCore import Qt, QTimer
from qtpy.QtWidgets import QProgressBar, QScrollArea, QVBoxLayout, QWidget
from superqt import QCollapsible

from .._warmup import DEFAULT_DTYPE
from ..core._jit import compiling, watch_compiles
from ..core.presets import DEFAULT_PRESET
from ..widget.choices import Choices
from ..widget.plan import MODES, RenderPlan, make_plan
from ..widget.run import Failure, Outcome
from ..widget.text import SWEEP_PARAMETERS, default_sweep_text
from .auto_window import AutoWindow
from .collector import hold_full_collections
from .compare import CompareView
from .form import ParameterForm
from .inputs import InputSection
from .lifecycle import ClosesWithItsDock
from .metrics_plot import MetricsPlot
from .metrics_table import MetricsTable
from .plane_queue import PlaneQueue
from .preview import Preview
from .result_store import StoreKeeper, unwrapped
from .sweep_label import SweepLabel
from .warm_up import PREPARING, WarmUp
from .worker import NEXT_TURN_MS, main_window, render_worker, show_result, stop

__all__ = ["LabyrinthWidget"]

#: Least seconds between two updates of the progress bar.
PROGRESS_INTERVAL = 0.2
#: Milliseconds between two looks at whether numba compiles a kernel for the run.
COMPILE_WATCH_MS = 250
#: The clock of those updates.
_clock = time.monotonic


class LabyrinthWidget(ClosesWithItsDock, QWidget):
    """Dock widget that renders an image layer with the labyrinthine tiling.

    Parameters
    ----------
    napari_viewer : napari.viewer.Viewer
        The viewer whose image layers the widget renders.

    Attributes
    ----------
    image_layer : magicgui.widgets.ComboBox
        The input: one of the viewer's image layers.
    planes : magicgui.widgets.RadioButtons
        ``"all planes"`` or ``"current plane"`` of an nD layer.
    follow_contrast : magicgui.widgets.CheckBox
        Whether the tone limits follow the input's contrast limits.
    tone_low, tone_high : magicgui.widgets.LineEdit
        Values mapped to tones 0 and 255.
    preset : magicgui.widgets.ComboBox
        Named parameter set that fills every parameter field.
    fields : dict of str to magicgui widget
        One field per parameter of the algorithm (``PARAMETER_NAMES`` but ``tones``).
    seed : magicgui.widgets.SpinBox
    mode : magicgui.widgets.RadioButtons
        One of ``MODES``.
    sweep_parameter : magicgui.widgets.ComboBox
    sweep_values : magicgui.widgets.LineEdit
        Values proposed around the swept parameter's field (``default_sweep_text``), which
        follow the field until the user edits them.
    run_button, cancel_button, compare_button : magicgui.widgets.PushButton
    status : magicgui.widgets.Label
    metrics_table : QTableWidget
        Per-pass metrics of the last stack run (cleared when the mode, the
        input or its plane on screen changes).
    metrics_plot : QWidget
        The same run's edge enhancement and labyrinth cover against the pass.
    measure, replace, preview_toggle : magicgui.widgets.CheckBox
        Measure the passes of a stack; replace the previous result of the
        same input and mode; live preview of the plane on screen.
    progress_bar : QProgressBar
        The running run's steps.
    scroll_area : QScrollArea
        Holds the sections; scrolls to the metrics when a stack run shows them.
    preview : Preview
    worker : napari worker or None
        The running worker, if any.
    last_result : napari.layers.Image or None
        The layer the last run added.
    """

    #: Whether a run's progress also shows in napari's activity panel. Off: while any
    #: progress is active napari animates an indicator in its status bar that repaints the
    #: whole window about 30 times a second; under software OpenGL (Xvfb, remote
    #: desktops) that takes a core from the run (a 2048² plane took twice as long).
    activity_panel: bool = False

    def __init__(self, napari_viewer: Viewer) -> None:
        super().__init__()
        self.viewer = napari_viewer
        self.worker = None
        self.last_result: Image | None = None
        self._plan: RenderPlan | None = None
        self._outcome_received = False
        self._outcome: Outcome | Failure | None = None
        self._showing = None  # the steps of showing a result (show_result), while they last
        self._waiting = None  # a worker started once the warm-up has ended
        self._rendering = ""  # the status of the run: what it renders
        self._compare = CompareView(napari_viewer)

        self.inputs = InputSection(napari_viewer)
        self.image_layer = self.inputs.image_layer
        self.planes = self.inputs.planes
        self.follow_contrast = self.inputs.follow_contrast
        self.tone_low, self.tone_high = self.inputs.tone_low, self.inputs.tone_high
        self.form = ParameterForm()
        self.preset, self.edited = self.form.preset, self.form.edited
        self.fields, self.seed = self.form.fields, self.form.seed
        self.preset.changed.connect(self._apply_preset)
        self.auto_window = AutoWindow(self.form, self.inputs.snapshot, self.choices, self._say)
        self._build_mode_section()
        self.metrics_table = MetricsTable()
        self.metrics_title = self.metrics_table.title
        self.metrics_plot = MetricsPlot()
        self._build_layout()

        layer_events = self.viewer.layers.events
        for name in ("inserted", "removed", "reordered", "renamed"):
            emitter = getattr(layer_events, name, None)
            if emitter is not None:
                emitter.connect(self.reset_choices)

        self.preset.value = DEFAULT_PRESET
        self._apply_preset(self.preset.value)
        active = self.viewer.layers.selection.active
        if isinstance(active, Image):
            self.image_layer.value = active
        self.inputs.follow_layer()
        self._on_mode_changed()

        self._results: dict[tuple[str, str], Image] = {}
        self._input: Image | None = None
        self._cancel_reason = ""
        self._shown_plane: tuple[int, ...] | None = None
        self._closed = False
        self._release_collections = _nothing
        self._progress_shown = 0.0
        self.sweep_label = SweepLabel(self.viewer)
        self.preview = Preview(self.viewer, self.inputs.snapshot, self.choices, self._say, self)
        self.preview_toggle.changed.connect(self._on_preview_toggled)
        for widget in (*self.fields.values(), self.seed, self.preset, self.image_layer):
            widget.changed.connect(self.preview.request)
        for widget in (self.follow_contrast, self.tone_low, self.tone_high, self.inputs.colour):
            widget.changed.connect(self.preview.request)
        self.image_layer.changed.connect(self._forget_metrics)
        self.viewer.dims.events.current_step.connect(self._on_step)
        layer_events.removed.connect(self._on_layer_removed)
        # numba's first compiles out of this process; what a run compiles itself is said
        watch_compiles()
        self._compile_watch = QTimer(self)
        self._compile_watch.setInterval(COMPILE_WATCH_MS)
        self._compile_watch.timeout.connect(self._say_compiling)
        self.warm_up = WarmUp(self._on_warm_up_line, self._on_warm_up_end, self)
        self.warm_up.start(self._warm_up_dtype())

    # -- construction ------------------------------------------------------------------------

    def _build_mode_section(self) -> None:
        self.mode = RadioButtons(
            label="mode",
            choices=MODES,
            value="single",
            orientation="horizontal",
            tooltip="single: one result layer; stack: the input and every pass along a new "
            "axis (Fig. 4); sweep: one rendering per value of a parameter (Fig. 3).",
        )
        self.sweep_parameter = ComboBox(
            label="sweep",
            choices=list(SWEEP_PARAMETERS),
            value="variance_threshold",
            tooltip="Parameter varied by a sweep (Fig. 3 varies V of Eq. 4).",
        )
        self.sweep_values = LineEdit(
            label="values",
            tooltip="Values of the swept parameter; proposed around its field's value, "
            "which they follow until you edit them.",
        )
        self._proposing = False  # the values are being set to the proposal, not edited
        self._sweep_edited = False  # the user has typed values of their own
        self.run_button = PushButton(text="Run", tooltip="Render in the background.")
        self.cancel_button = PushButton(
            text="Cancel", tooltip="Stop at the next plane or pass; no layer is added."
        )
        self.compare_button = PushButton(
            text="Compare", tooltip="Show the input and the last result side by side (grid)."
        )
        self.cancel_button.enabled = False
        self.measure = CheckBox(
            text="metrics",
            value=True,
            tooltip="Stack mode: measure each pass on the plane on screen as it renders "
            "(table and plot below); untick for the fastest stack.",
        )
        self.replace = CheckBox(
            text="replace last",
            value=True,
            tooltip="A run of the same input and mode replaces the layer of the last one "
            "instead of adding another.",
        )
        self.preview_toggle = CheckBox(
            text="preview",
            value=False,
            tooltip="Render the plane on screen into one preview layer at every change of a "
            "parameter, of the input or of the plane shown; Run still renders the result.",
        )
        options = Container(
            widgets=[self.preview_toggle, self.measure, self.replace],
            layout="horizontal",
            labels=False,
        )
        options.margins = (0, 0, 0, 0)
        buttons = Container(
            widgets=[self.run_button, self.cancel_button, self.compare_button],
            layout="horizontal",
            labels=False,
        )
        buttons.margins = (0, 0, 0, 0)
        self.status = Label(value="")
        self.status.native.setWordWrap(True)
        self.status.native.setAlignment(Qt.AlignmentFlag.AlignLeft | Qt.AlignmentFlag.AlignVCenter)
        self.progress_bar = QProgressBar()
        self.progress_bar.setVisible(False)
        self.progress_bar.setFormat("%v of %m steps")
        self.mode_box = Container(
            widgets=[self.mode, self.sweep_parameter, self.sweep_values, options, buttons]
        )
        self.mode.changed.connect(self._on_mode_changed)
        self.sweep_parameter.changed.connect(self._on_sweep_parameter)
        self.sweep_values.changed.connect(self._on_sweep_values_edited)
        for widget in (*self.fields.values(), self.seed):  # Auto V, typed, a preset
            widget.changed.connect(self._propose_sweep_values)
        self.run_button.changed.connect(self.run)
        self.cancel_button.changed.connect(self.cancel)
        self.compare_button.changed.connect(self.toggle_compare)

    def _build_layout(self) -> None:
        self.reading_section = QCollapsible("Reading options (advanced)")
        self.reading_section.setToolTip(
            "The points the paper leaves open; the preset chooses a reading of each."
        )
        self.reading_section.layout().setContentsMargins(0, 2, 0, 2)
        self.reading_section.layout().setSpacing(0)
        self.reading_section.addWidget(self.form.reading_box.native)
        self.reading_section.collapse(animate=False)

        boxes = (self.inputs.box, self.form.parameter_box, self.form.reading_box, self.mode_box)
        for box in boxes:
            box.margins = (4, 2, 4, 2)
        content = QWidget()
        layout = QVBoxLayout(content)
        layout.setContentsMargins(4, 4, 4, 4)
        layout.addWidget(self.inputs.box.native)
        layout.addWidget(self.form.parameter_box.native)
        layout.addWidget(self.auto_window.plot)
        layout.addWidget(self.reading_section)
        layout.addWidget(self.mode_box.native)
        layout.addWidget(self.progress_bar)
        layout.addWidget(self.status.native)
        layout.addWidget(self.metrics_title)
        layout.addWidget(self.metrics_table)
        layout.addWidget(self.metrics_plot)
        layout.addStretch(1)
        self.scroll_area = scroll = QScrollArea()
        scroll.setWidgetResizable(True)
        scroll.setWidget(content)
        scroll.setHorizontalScrollBarPolicy(Qt.ScrollBarPolicy.ScrollBarAlwaysOff)
        outer = QVBoxLayout(self)
        outer.setContentsMargins(0, 0, 0, 0)
        outer.addWidget(scroll)
        content.setMinimumWidth(365)
        self.setMinimumWidth(385)

    def showEvent(self, event) -> None:  # noqa: N802 - Qt's name
        super().showEvent(event)
        for box in (self.inputs.box, self.form.parameter_box, self.form.reading_box):
            _fit_label_widths(box)

    # -- choices -----------------------------------------------------------------------------

    def reset_choices(self, *_args) -> None:
        """Refresh the list of image layers (napari calls it when layers change)."""
        self.inputs.reset_choices()

    def tone_limits(self) -> tuple[float, float]:
        """The values mapped to tones 0 and 255: the layer's contrast limits or the typed ones."""
        return self.inputs.tone_limits()

    def _apply_preset(self, name: str) -> None:
        """Fill every parameter field from preset ``name``."""
        self.form.apply_preset(name)
        self._propose_sweep_values()

    def overrides(self) -> dict[str, Any]:
        """The fields whose value differs from the chosen preset's (parameter name -> value)."""
        return self.form.overrides()

    def _on_mode_changed(self, *_args) -> None:
        sweeping = self.mode.value == "sweep"
        self.sweep_parameter.visible = sweeping
        self.sweep_values.visible = sweeping
        self.measure.visible = self.mode.value == "stack"
        self._forget_metrics()

    def _forget_metrics(self, *_args) -> None:
        """Clear the metrics of the last stack: another mode, input or plane is on screen."""
        self.metrics_table.clear_passes()
        self.metrics_plot.clear()
        self._shown_plane = None

    def _on_step(self, *_args) -> None:
        self.preview.request()
        if self._shown_plane is not None:
            snapshot = self.inputs.snapshot()
            if snapshot is None or snapshot.visible_index != self._shown_plane:
                self._forget_metrics()

    def _on_preview_toggled(self, enabled: bool) -> None:
        self._watch_window()
        self.preview.set_enabled(enabled)

    def _say(self, text: str) -> None:
        self.status.value = text

    def _on_sweep_parameter(self, *_args) -> None:
        """Another parameter is swept: the values typed for the last one are not its own."""
        self._sweep_edited = False
        self._propose_sweep_values()

    def _propose_sweep_values(self, *_args) -> None:
        """Propose the sweep's values around the swept field's value, unless the user has
        typed values of their own."""
        if self._sweep_edited:
            return
        parameter = self.sweep_parameter.value
        text = default_sweep_text(parameter, self.form.value(parameter))
        if self.sweep_values.value != text:
            self._proposing = True
            try:
                self.sweep_values.value = text
            finally:
                self._proposing = False

    def _on_sweep_values_edited(self, *_args) -> None:
        if not self._proposing:
            self._sweep_edited = True

    def choices(self) -> Choices:
        """The user's choices, as plain values."""
        return Choices(
            mode=self.mode.value,
            preset=self.preset.value,
            overrides=self.overrides(),
            seed=int(self.seed.value),
            tone_limits=self.inputs.typed_tone_limits(),
            planes=self.planes.value,
            sweep_parameter=self.sweep_parameter.value,
            sweep_text=self.sweep_values.value,
            metrics=bool(self.measure.value),
            colour=self.inputs.colour.value,
        )

    def plan(self) -> RenderPlan:
        """Capture the current choices as a :class:`~napari_labyrinth.widget.plan.RenderPlan`.

        Raises
        ------
        ValueError, TypeError
            With a message for the user when a choice is invalid.
        """
        return make_plan(self.inputs.snapshot(), self.choices())

    # -- running -----------------------------------------------------------------------------

    def run(self, *_args, start: bool = True):
        """Start a run with the current choices in a napari thread worker.

        Parameters
        ----------
        start : bool, optional
            Start the worker. With False the worker is returned unstarted, so
            that a caller (a test, a script) can connect to its signals first
            and then call ``worker.start()``.

        Returns
        -------
        worker or None
            The worker, or None when the choices are invalid (the user gets a
            notification) or a run is already going on.
        """
        if self.worker is not None:
            show_info("A labyrinthine tiling is already running: cancel it or wait.")
            return None
        try:
            plan = self.plan()
        except (TypeError, ValueError) as exc:
            show_error(f"Labyrinthine tiling: {exc}")
            self.status.value = f"Not started: {exc}"
            return None
        self._watch_window()
        worker = render_worker(plan, progress=self.activity_panel)
        worker.returned.connect(self._on_returned)
        worker.finished.connect(self._on_finished)
        worker.yielded.connect(self._on_progress)
        self.worker = worker
        self._plan = plan
        self._release_collections = hold_full_collections()  # released as the run settles
        self._input = self.image_layer.value
        self._outcome_received = False
        self._outcome = None
        self.run_button.enabled = False
        self.cancel_button.enabled = True
        self.progress_bar.setRange(0, plan.total_steps)
        self.progress_bar.setValue(0)
        self._progress_shown = _clock()
        self.progress_bar.setVisible(True)
        self._rendering = f"Rendering {plan.description} …"
        self.status.value = self._rendering
        self._compile_watch.start()
        if start and not self.warm_up.done_with(_warm_up_steps(plan)):  # its kernels: wait
            self._waiting = worker
            self.progress_bar.setRange(0, 0)  # busy: the warm-up says no fraction done
            self.status.value = f"{PREPARING} ({self.warm_up.step or 'starting'}) …"
        elif start:
            worker.start()
        return worker

    def cancel(self, *_args) -> None:
        """Stop the running worker at its next plane or pass; no layer is added."""
        self._cancel_because("")

    def _cancel_because(self, reason: str) -> None:
        if self.worker is None or self._plan is None:
            return
        if self._waiting is not None:  # not started: nothing will finish
            self._waiting = None
            self._cancel_reason = reason
            self._settle()
            return
        stop(self.worker, self._plan)
        self._cancel_reason = reason
        self.status.value = "Cancelling …"

    def _on_returned(self, outcome: Outcome | Failure | None) -> None:
        plan = self._plan
        if outcome is None or plan is None or plan.cancel.is_set() or self._closed:
            return
        self._outcome = outcome  # shown once the worker has finished (_end_run)

    def _end_run(self) -> None:
        """Start showing the run's result, one step per turn of the event loop, or settle.

        Adding a layer and drawing it are each tens of milliseconds of napari's and
        Qt's work on the main thread (the layer's visual and controls, its selection;
        its texture and the repaint of the window, in software under Xvfb or a remote
        desktop): :func:`.worker.show_result` splits them into steps, and each step
        gets a turn of its own, so that none stalls the event loop for long. The
        run is still on (``worker`` set) until the widget settles: a cancel, a closed
        dock or a removed input in between adds nothing (a layer already inserted is
        taken out again).
        """
        plan, outcome, self._outcome = self._plan, self._outcome, None
        if outcome is None or not self._wanted():
            self._settle()
            return
        self._outcome_received = True
        if isinstance(outcome, Failure):
            show_error(f"Labyrinthine tiling failed: {outcome.message}")
            self.status.value = f"Failed: {outcome.message}"
            self._settle()
            return
        key = (plan.source, plan.mode)
        previous = self._results.get(key) if self.replace.value else None
        self._showing = show_result(self.viewer, plan, outcome, previous, window=main_window(self))
        self._show_step(plan, outcome)

    def _wanted(self) -> bool:
        """Whether the run's result is still to be shown (no cancel, the dock open)."""
        return self._plan is not None and not self._plan.cancel.is_set() and not self._closed

    def _show_step(self, plan: RenderPlan, outcome: Outcome) -> None:
        """One step of showing the result; the next in a later turn, the end in its own."""
        steps = self._showing
        if steps is None:
            return
        if not self._wanted():
            self._showing = None
            _abandon(steps)
            self._outcome_received = False  # said as cancelled
            self._settle()
            return
        try:
            next(steps)
        except StopIteration as done:
            self._showing = None
            self._shown(plan, outcome, done.value)
            return
        except Exception as exc:  # noqa: BLE001 - shown to the user, not as a traceback
            self._showing = None
            _abandon(steps)
            show_error(f"Labyrinthine tiling: could not add the result layer: {exc}")
            self.status.value = f"Failed: {exc}"
            self._settle()
            return
        QTimer.singleShot(NEXT_TURN_MS, lambda: self._show_step(plan, outcome))

    def _shown(self, plan: RenderPlan, outcome: Outcome, layer: Image | None) -> None:
        """The result is on screen: the widget says so, and settles."""
        if layer is not None:
            self.last_result = self._results[(plan.source, plan.mode)] = layer
            self.sweep_label.refresh()
            if plan.mode == "stack" and outcome.metric_rows:
                self.metrics_table.show_passes(outcome.metric_rows)
                self.metrics_plot.show_passes(outcome.metric_rows)
                self._shown_plane = tuple(plan.visible_index)
                QTimer.singleShot(0, self._reveal_metrics)
            self.status.value = f"Added {plan.description} ({outcome.seconds:.1f} s)"
            if outcome.store is not None:  # a pyramid rendered band by band, on disk
                StoreKeeper(self.viewer, layer, outcome.store.remove, main_window(self))
            if outcome.background is not None:  # a lazy input: the other planes still to render
                self._render_in_background(plan, layer, outcome.background)
                return
        else:
            self.status.value = "The result layer was removed before it was shown."
        self._settle()

    def _render_in_background(self, plan: RenderPlan, layer: Image, background) -> None:
        """The run goes on (progress, Cancel) while the other planes of a lazy result render."""
        self.worker = queue = PlaneQueue(self.viewer, layer, background, main_window(self))
        queue.progressed.connect(self._on_progress)
        queue.ended.connect(self._settle)
        queue.start(self.progress_bar, self._say, plan.description)

    def _reveal_metrics(self, attempts: int = 10, last: tuple = ()) -> None:
        """Scroll the dock to the metrics just shown: the plot in full, and the table's
        title if both do not fit. Qt lays them out over a few turns of the event loop
        (their heights follow their width): look again until their geometry settles."""
        if self._closed or not self.metrics_plot.isVisible():
            return
        self.metrics_table.fit()
        self.metrics_plot.fit_height()
        self.scroll_area.ensureWidgetVisible(self.metrics_plot, 0, 0)
        self.scroll_area.ensureWidgetVisible(self.metrics_title, 0, 0)
        plot, content = self.metrics_plot, self.scroll_area.widget()
        geometry = (content.height(), plot.y(), plot.height(), self.metrics_table.height())
        if geometry != last and attempts > 1:
            QTimer.singleShot(0, lambda: self._reveal_metrics(attempts - 1, geometry))

    def _on_progress(self, step: int) -> None:
        if self._closed:  # after close the Qt side of the widget may be gone
            return
        # each change repaints the window (tens of ms under software OpenGL): a few a
        # second, and not the last step (the bar is hidden as the result is shown)
        now = _clock()
        if step < self.progress_bar.maximum() and now - self._progress_shown >= PROGRESS_INTERVAL:
            self.progress_bar.setValue(step)
            self._progress_shown = now

    def _on_finished(self) -> None:
        QTimer.singleShot(NEXT_TURN_MS, self._end_run)  # a turn of its own: see _end_run

    def _settle(self) -> None:
        """The run is over: buttons, progress bar and status show it."""
        cancelled = self._plan is not None and not self._outcome_received
        release, self._release_collections = self._release_collections, _nothing
        self.worker = None
        self._plan = None  # holds the input data: let it go
        self._input = None
        if self._closed:  # the close stopped the watch: its Qt side may be gone
            release()
            return
        self._compile_watch.stop()
        # after the result's first draw, which is pending: a collection that fell due
        # during the run must not land in it
        QTimer.singleShot(NEXT_TURN_MS, release)
        self.run_button.enabled = True
        self.cancel_button.enabled = False
        self.progress_bar.setVisible(False)
        if cancelled:
            self.status.value = f"Cancelled: {self._cancel_reason or 'no layer added'}"
        self._cancel_reason = ""

    # -- kernels -----------------------------------------------------------------------------

    def _warm_up_dtype(self) -> str:
        """The dtype of the selected image layer's data, which the warm-up prepares."""
        layer = self.image_layer.value
        data = getattr(layer, "data", None)
        if getattr(layer, "multiscale", False):
            data = data[0]
        dtype = getattr(data, "dtype", None)
        if dtype is None or dtype.kind not in "uif" or getattr(layer, "rgb", False):
            return DEFAULT_DTYPE
        return str(dtype)

    def _on_warm_up_line(self, line: str) -> None:
        if self._waiting is None or self._closed:
            return
        if self.warm_up.done_with(_warm_up_steps(self._plan)):  # the rest is not this run's
            self._on_warm_up_end()
            return
        if line.startswith("kernel "):
            detail = f"{self.warm_up.step}: compiling {line.split(' ', 1)[1]}"
        else:
            detail = line
        self.status.value = f"{PREPARING} ({detail}) …"

    def _on_warm_up_end(self) -> None:
        worker, self._waiting = self._waiting, None
        if worker is not None and not self._closed:
            self.progress_bar.setRange(0, self._plan.total_steps)
            self.status.value = self._rendering
            worker.start()

    def _say_compiling(self) -> None:
        """While the run waits on numba compiling a kernel in this process, say so."""
        if self._waiting is not None or self._closed or self.worker is None:
            return
        kernel = compiling()
        if kernel is not None:
            text = f"{PREPARING} (compiling {kernel}) …"
        elif self.status.value.startswith(PREPARING):
            text = self._rendering
        else:
            return
        if self.status.value != text:
            self.status.value = text

    # -- lifecycle ---------------------------------------------------------------------------

    def _on_layer_removed(self, event) -> None:
        """Removing the input of a run cancels it: its result would have nowhere to go."""
        if self.worker is not None and unwrapped(event.value) is unwrapped(self._input):
            self._cancel_because("the input layer was removed")

    def close_down(self) -> None:
        """The dock or the viewer is closing: cancel the run and the preview, add nothing."""
        if self._closed:
            return
        self._closed = True
        self._cancel_because("the widget was closed")
        # the run will not settle here if the viewer goes (Qt drops the turns queued for a
        # deleted widget): its hold on full collections ends now
        release, self._release_collections = self._release_collections, _nothing
        release()
        self.warm_up.stop()
        self._compile_watch.stop()
        self.preview.close()
        self.auto_window.close()
        self.sweep_label.disconnect()
        self.viewer.dims.events.current_step.disconnect(self._on_step)

    # -- compare -----------------------------------------------------------------------------

    def toggle_compare(self, *_args) -> None:
        """Show the input and the result side by side (napari grid mode), or go back."""
        self._compare.toggle(self.last_result)
        self.compare_button.text = "Back to overlay" if self._compare.active else "Compare"

    @property
    def comparing(self) -> bool:
        """Whether the compare (grid) view is on."""
        return self._compare.active




def _nothing() -> None:
    pass


def _warm_up_steps(plan: RenderPlan) -> int:
    """The steps of the warm-up (``_warmup.warm_up_steps``) a run of ``plan`` needs: the
    render, and the metrics for a stack that measures its passes."""
    return 2 if plan.metrics else 1


def _abandon(steps) -> None:
    """Close the steps of showing a result, which takes back a layer they inserted; a
    viewer that is closing may have lost its Qt side: nothing more to take back then."""
    with contextlib.suppress(RuntimeError):
        steps.close()


def _fit_label_widths(box: Container) -> None:
    """Give the row labels of ``box`` the width their text needs as napari draws them.

    magicgui sizes them with the application's font and no padding; napari's
    stylesheet draws them larger and padded, which cut the end of the longest
    (``variance threshold V``).
    """
    rows = [row for row in (widget._labeled_widget() for widget in box) if row is not None]
    labels = [row._label_widget.native for row in rows]
    if not labels:
        return
    for label in labels:
        label.ensurePolished()
    widest = max(label.sizeHint().width() for label in labels)
    for row in rows:
        row.label_width = widest
