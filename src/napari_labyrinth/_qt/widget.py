"""The napari widget: render an image layer with the labyrinthine tiling.

The only module of the package that imports napari or Qt. It holds no
algorithm and no plan: it reads the user's choices and a snapshot of the
input layer, hands them to :func:`napari_labyrinth.plan.make_plan`, runs
:func:`napari_labyrinth.plan.render` in a napari thread worker (napari draws
a determinate progress bar from its yields) and adds the result as a new
layer whose metadata records the API call, so that it can be reproduced
exactly.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from magicgui.widgets import (
    CheckBox,
    ComboBox,
    Container,
    FloatSpinBox,
    Label,
    LineEdit,
    PushButton,
    RadioButtons,
    SpinBox,
)
from napari.layers import Image
from napari.qt.threading import create_worker
from napari.utils.notifications import show_error, show_info
from napari.viewer import Viewer
from qtpy.QtCore import Qt
from qtpy.QtWidgets import QScrollArea, QVBoxLayout, QWidget
from superqt import QCollapsible

from .. import parameters, presets
from ..plan import (
    ALL_PLANES,
    CURRENT_PLANE,
    FLOAT_PARAMETERS,
    MODES,
    SWEEP_PARAMETERS,
    Choices,
    Failure,
    LayerSnapshot,
    Outcome,
    RenderPlan,
    default_sweep_text,
    edited_text,
    make_plan,
    overrides,
    preset_field_values,
    render,
    result_layer,
    tone_limit_text,
    tone_limits,
    visible_plane,
)
from .compare import CompareView
from .metrics_table import MetricsTable

__all__ = ["LabyrinthWidget"]

#: Parameters edited in the main section, in order: (label, tooltip citing the paper).
MAIN_FIELDS = {
    "mean_threshold": (
        "mean threshold t",
        (
            "t of Eq. 2: a pixel of tone g keeps it when |g - M| / M <= t, M being the mean "
            "of its 8 nearest and next-nearest neighbours (Eq. 1). Paper: 0.12."
        ),
    ),
    "variance_threshold": (
        "variance threshold V",
        (
            "V of Eq. 4: where R2 = sqrt(V/N)/M > V the substitution g -> g* is not applied "
            "(or g is pushed away from M, see 'variance action'). Paper: 0.50. The labyrinth "
            "appears only in a narrow range of V (Fig. 3)."
        ),
    ),
    "tone_ranges": (
        "tone ranges",
        (
            "Number of about-equal tone ranges from a low tone (10) to 255; Eq. 3 draws "
            "g* = T_inf + R (T_sup - T_inf) in the range holding g. Paper: 3. A preset's own "
            "range limits and tones are kept until this count is changed."
        ),
    ),
    "max_tries": (
        "max tries",
        (
            "Draws of Eq. 3 per pixel before giving up ('till condition (2) is satisfied or "
            "the number of iterations exceeds a fixed value'; the paper gives no number)."
        ),
    ),
    "passes": (
        "passes",
        (
            "Passes over the image: Fig. 4 applies the algorithm several times to enhance "
            "edges. Stack mode keeps the image after every pass."
        ),
    ),
}

#: Reading options (the points the paper leaves open), in the collapsible section.
READING_FIELDS = {
    "variance_ratio": (
        parameters.VARIANCE_RATIOS,
        "R2 of Eq. 4: sqrt(V/N)/M as printed, or sqrt(V)/M (the coefficient of variation).",
    ),
    "variance_action": (
        parameters.VARIANCE_ACTIONS,
        (
            "Where Eq. 4 holds: 'leave' g as printed ('the substitution is not applied'), or "
            "push it further from M with a draw on its side of M (the push readings of 'a "
            "condition able to strongly enhance the local variance'; see docs/algorithm.md)."
        ),
    ),
    "condition_order": (
        parameters.CONDITION_ORDERS,
        "Which condition decides first: Eq. 2 (as printed) or Eq. 4.",
    ),
    "border": (
        parameters.BORDERS,
        (
            "Neighbours of border pixels: only those inside the image (N of Eq. 1 is their "
            "number), or completed like the scipy.ndimage modes of the same name."
        ),
    ),
    "on_exhausted": (
        parameters.ON_EXHAUSTED,
        (
            "What a pixel becomes when none of the 'max tries' draws of Eq. 3 satisfies Eq. 2: "
            "it keeps its tone, or takes the last draw."
        ),
    ),
    "include_centre": (
        None,
        "Whether the pixel joins its own M and V (Eq. 1 sums over the neighbours only).",
    ),
    "scan": (
        parameters.SCANS,
        (
            "Scan order from the top-left corner: every row left to right (raster), or odd rows "
            "right to left (serpentine)."
        ),
    ),
}

_SEED_MAX = 2**63 - 1
_PASSES_MAX = 1000


# -- the widget --------------------------------------------------------------------------------


class LabyrinthWidget(QWidget):
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
    run_button, cancel_button, compare_button : magicgui.widgets.PushButton
    status : magicgui.widgets.Label
    metrics_table : QTableWidget
        Per-pass metrics of the last stack run.
    worker : napari worker or None
        The running worker, if any.
    last_result : napari.layers.Image or None
        The layer the last run added.
    """

    def __init__(self, napari_viewer: Viewer) -> None:
        super().__init__()
        self.viewer = napari_viewer
        self.worker = None
        self.last_result: Image | None = None
        self._plan: RenderPlan | None = None
        self._outcome_received = False
        self._watched_layer: Image | None = None
        self._compare = CompareView(napari_viewer)
        self._filling = False

        self._build_input_section()
        self._build_parameter_section()
        self._build_mode_section()
        self._build_layout()

        layer_events = self.viewer.layers.events
        for name in ("inserted", "removed", "reordered", "renamed"):
            emitter = getattr(layer_events, name, None)
            if emitter is not None:
                emitter.connect(self.reset_choices)

        self.preset.value = presets.DEFAULT_PRESET
        self._apply_preset(self.preset.value)
        active = self.viewer.layers.selection.active
        if isinstance(active, Image):
            self.image_layer.value = active
        self._on_input_changed()
        self._on_mode_changed()

    # -- construction ------------------------------------------------------------------------

    def _build_input_section(self) -> None:
        self.image_layer = ComboBox(
            label="image",
            choices=self._image_layer_choices,
            tooltip="Image layer to render (grey, RGB, or an nD time/z stack).",
        )
        self.planes = RadioButtons(
            label="planes",
            choices=(ALL_PLANES, CURRENT_PLANE),
            value=ALL_PLANES,
            orientation="horizontal",
            tooltip="Render every plane of an nD layer, or only the plane on screen "
            "(a quick look; the result sits at that plane).",
        )
        self.follow_contrast = CheckBox(
            text="tone limits follow the contrast limits",
            value=True,
            tooltip="Map the layer's contrast limits to tones 0 and 255, so that what you "
            "see is what gets rendered.",
        )
        self.tone_low = LineEdit(label="tone limits", tooltip="Value mapped to tone 0.")
        self.tone_high = LineEdit(tooltip="Value mapped to tone 255.")
        tone_row = Container(
            widgets=[self.tone_low, self.tone_high],
            layout="horizontal",
            labels=False,
            label="tone limits",
        )
        tone_row.margins = (0, 0, 0, 0)
        self.input_box = Container(
            widgets=[self.image_layer, self.planes, tone_row, self.follow_contrast]
        )
        self.image_layer.changed.connect(self._on_input_changed)
        self.follow_contrast.changed.connect(self._on_follow_contrast)

    def _build_parameter_section(self) -> None:
        self.preset = ComboBox(
            label="preset",
            choices=list(presets.PRESETS),
            tooltip="A named parameter set: choosing one fills every field; a field edited "
            "afterwards overrides the preset.",
        )
        self.edited = Label(value="")
        self.edited.native.setStyleSheet("color: gray")
        self.fields: dict[str, Any] = {}
        for name, (label, tooltip) in MAIN_FIELDS.items():
            if name in FLOAT_PARAMETERS:
                widget = FloatSpinBox(label=label, min=0.0, max=100.0, step=0.01, tooltip=tooltip)
                widget.native.setDecimals(4)
            elif name == "tone_ranges":
                widget = SpinBox(label=label, min=1, max=255, tooltip=tooltip)
            elif name == "max_tries":
                widget = SpinBox(
                    label=label, min=0, max=parameters.MAX_TRIES_LIMIT, tooltip=tooltip
                )
            else:
                widget = SpinBox(label=label, min=0, max=_PASSES_MAX, tooltip=tooltip)
            self.fields[name] = widget
        self.seed = SpinBox(
            label="seed",
            min=0,
            max=_SEED_MAX,
            tooltip="Seed of the random draws of Eq. 3: the result is a pure function of the "
            "image, the parameters and the seed.",
        )
        reading = []
        for name, (choices, tooltip) in READING_FIELDS.items():
            label = name.replace("_", " ")
            if choices is None:
                widget = CheckBox(text=label, tooltip=tooltip)
            else:
                widget = ComboBox(label=label, choices=list(choices), tooltip=tooltip)
            self.fields[name] = widget
            reading.append(widget)
        preset_row = Container(
            widgets=[self.preset, self.edited], layout="horizontal", labels=False, label="preset"
        )
        preset_row.margins = (0, 0, 0, 0)
        self.parameter_box = Container(
            widgets=[preset_row] + [self.fields[name] for name in MAIN_FIELDS] + [self.seed]
        )
        self.reading_box = Container(widgets=reading)
        self.preset.changed.connect(self._apply_preset)
        for widget in self.fields.values():
            widget.changed.connect(self._on_field_edited)

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
            label="values", tooltip="Values of the swept parameter, e.g. 0.47, 0.50, 0.53."
        )
        self.run_button = PushButton(text="Run", tooltip="Render in the background.")
        self.cancel_button = PushButton(
            text="Cancel", tooltip="Stop at the next plane or pass; no layer is added."
        )
        self.compare_button = PushButton(
            text="Compare", tooltip="Show the input and the last result side by side (grid)."
        )
        self.cancel_button.enabled = False
        buttons = Container(
            widgets=[self.run_button, self.cancel_button, self.compare_button],
            layout="horizontal",
            labels=False,
        )
        buttons.margins = (0, 0, 0, 0)
        self.status = Label(value="")
        self.status.native.setWordWrap(True)
        self.status.native.setAlignment(Qt.AlignmentFlag.AlignLeft | Qt.AlignmentFlag.AlignVCenter)
        self.mode_box = Container(
            widgets=[self.mode, self.sweep_parameter, self.sweep_values, buttons]
        )
        self.mode.changed.connect(self._on_mode_changed)
        self.sweep_parameter.changed.connect(self._on_sweep_parameter)
        self.run_button.changed.connect(self.run)
        self.cancel_button.changed.connect(self.cancel)
        self.compare_button.changed.connect(self.toggle_compare)

    def _build_layout(self) -> None:
        self.reading_section = QCollapsible("Reading options (advanced)")
        self.reading_section.setToolTip(
            "The points the paper leaves open; the preset chooses a reading of each."
        )
        self.reading_section.layout().setContentsMargins(0, 2, 0, 2)
        self.reading_section.addWidget(self.reading_box.native)
        self.reading_section.collapse(animate=False)

        self.metrics_table = MetricsTable()
        self.metrics_title = self.metrics_table.title

        for box in (self.input_box, self.parameter_box, self.reading_box, self.mode_box):
            box.margins = (4, 2, 4, 2)
        content = QWidget()
        layout = QVBoxLayout(content)
        layout.setContentsMargins(4, 4, 4, 4)
        for part in (self.input_box, self.parameter_box):
            layout.addWidget(part.native)
        layout.addWidget(self.reading_section)
        layout.addWidget(self.mode_box.native)
        layout.addWidget(self.status.native)
        layout.addWidget(self.metrics_title)
        layout.addWidget(self.metrics_table)
        layout.addStretch(1)
        scroll = QScrollArea()
        scroll.setWidgetResizable(True)
        scroll.setWidget(content)
        scroll.setHorizontalScrollBarPolicy(Qt.ScrollBarPolicy.ScrollBarAlwaysOff)
        outer = QVBoxLayout(self)
        outer.setContentsMargins(0, 0, 0, 0)
        outer.addWidget(scroll)
        content.setMinimumWidth(330)
        self.setMinimumWidth(350)

    # -- input -------------------------------------------------------------------------------

    def _image_layer_choices(self, _widget=None) -> list[tuple[str, Image]]:
        return [(layer.name, layer) for layer in self.viewer.layers if isinstance(layer, Image)]

    def reset_choices(self, *_args) -> None:
        """Refresh the list of image layers (napari calls it when layers change)."""
        self.image_layer.reset_choices()
        if self._watched_layer != self.image_layer.value:
            self._on_input_changed()

    def _on_input_changed(self, *_args) -> None:
        layer = self.image_layer.value
        if self._watched_layer is not None:
            self._watched_layer.events.contrast_limits.disconnect(self._on_contrast_limits)
        self._watched_layer = layer
        if layer is not None:
            layer.events.contrast_limits.connect(self._on_contrast_limits)
        self.planes.enabled = layer is not None and layer.ndim > 2
        self._on_contrast_limits()

    def _on_contrast_limits(self, *_args) -> None:
        layer = self.image_layer.value
        if layer is None or not self.follow_contrast.value:
            return
        self.tone_low.value, self.tone_high.value = tone_limit_text(layer.contrast_limits)

    def _on_follow_contrast(self, follow: bool) -> None:
        self.tone_low.enabled = self.tone_high.enabled = not follow
        self._on_contrast_limits()

    def tone_limits(self) -> tuple[float, float]:
        """The values mapped to tones 0 and 255: the layer's contrast limits or the typed ones.

        Raises
        ------
        ValueError
            If the typed limits are not numbers with low < high.
        """
        layer = self.image_layer.value
        following = self.follow_contrast.value and layer is not None
        typed = (self.tone_low.value, self.tone_high.value)
        return tone_limits(layer.contrast_limits if following else None, typed)

    # -- parameters --------------------------------------------------------------------------

    def _apply_preset(self, name: str) -> None:
        """Fill every parameter field from preset ``name``."""
        values = preset_field_values(name, list(self.fields))
        self._filling = True
        try:
            for field, widget in self.fields.items():
                widget.value = values[field]
        finally:
            self._filling = False
        self._on_field_edited()
        self._on_sweep_parameter(self.sweep_parameter.value)

    def _on_field_edited(self, *_args) -> None:
        if self._filling:
            return
        self.edited.value = edited_text(self.overrides())

    def overrides(self) -> dict[str, Any]:
        """The fields whose value differs from the chosen preset's.

        Returns
        -------
        dict
            Parameter name -> value, for :func:`napari_labyrinth.resolve_parameters`.
        """
        values = {name: widget.value for name, widget in self.fields.items()}
        return overrides(self.preset.value, values)

    def _on_mode_changed(self, *_args) -> None:
        sweeping = self.mode.value == "sweep"
        self.sweep_parameter.visible = sweeping
        self.sweep_values.visible = sweeping

    def _on_sweep_parameter(self, parameter: str) -> None:
        if parameter == "seed":
            current = self.seed.value
        else:
            current = self.fields[parameter].value
        self.sweep_values.value = default_sweep_text(parameter, current)

    # -- running -----------------------------------------------------------------------------

    def plan(self) -> RenderPlan:
        """Capture the current choices as a :class:`RenderPlan` (main thread).

        Raises
        ------
        ValueError, TypeError
            With a message for the user when a choice is invalid.
        """
        return make_plan(self._snapshot(), self.choices())

    def choices(self) -> Choices:
        """The user's choices, as plain values."""
        return Choices(
            mode=self.mode.value,
            preset=self.preset.value,
            overrides=self.overrides(),
            seed=int(self.seed.value),
            tone_limits=(
                None if self.follow_contrast.value else (self.tone_low.value, self.tone_high.value)
            ),
            planes=self.planes.value,
            sweep_parameter=self.sweep_parameter.value,
            sweep_text=self.sweep_values.value,
        )

    def _snapshot(self) -> LayerSnapshot | None:
        """The input layer as plain values (None without one)."""
        layer = self.image_layer.value
        if layer is None:
            return None
        n_leading = layer.ndim - 2
        if layer.multiscale or n_leading <= 0:
            visible_index: tuple[int, ...] = ()
        else:
            coordinates = layer.world_to_data(self.viewer.dims.point)[:n_leading]
            visible_index = visible_plane(coordinates, layer.data.shape[:n_leading])
        return LayerSnapshot(
            name=layer.name,
            data=layer.data,
            ndim=layer.ndim,
            rgb=bool(layer.rgb),
            multiscale=bool(layer.multiscale),
            scale=np.asarray(layer.scale, dtype=float),
            translate=np.asarray(layer.translate, dtype=float),
            rotate=np.asarray(layer.rotate, dtype=float),
            shear=np.asarray(layer.shear, dtype=float),
            affine=np.asarray(layer.affine.affine_matrix, dtype=float),
            units=tuple(str(unit) for unit in layer.units),
            axis_labels=tuple(str(label) for label in layer.axis_labels),
            contrast_limits=tuple(layer.contrast_limits),
            gamma=layer.gamma,
            opacity=layer.opacity,
            blending=layer.blending,
            interpolation2d=layer.interpolation2d,
            colormap=layer.colormap,
            visible_index=visible_index,
        )

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
        worker = create_worker(
            render,
            plan,
            _progress={"total": plan.total_steps, "desc": "Labyrinthine tiling"},
        )
        plan.abort_requested = lambda: worker.abort_requested
        worker.returned.connect(self._on_returned)
        worker.finished.connect(self._on_finished)
        self.worker = worker
        self._plan = plan
        self._outcome_received = False
        self.run_button.enabled = False
        self.cancel_button.enabled = True
        self.status.value = f"Rendering {plan.name} …"
        if start:
            worker.start()
        return worker

    def cancel(self, *_args) -> None:
        """Stop the running worker at its next plane or pass; no layer is added."""
        if self.worker is None or self._plan is None:
            return
        self._plan.cancel.set()
        self.worker.quit()
        self.status.value = "Cancelling …"

    def _on_returned(self, outcome: Outcome | Failure | None) -> None:
        plan = self._plan
        if outcome is None or plan is None or plan.cancel.is_set():
            return
        self._outcome_received = True
        if isinstance(outcome, Failure):
            show_error(f"Labyrinthine tiling failed: {outcome.message}")
            self.status.value = f"Failed: {outcome.message}"
            return
        try:
            self._add_result(plan, outcome)
        except Exception as exc:  # noqa: BLE001 - shown to the user, not as a traceback
            show_error(f"Labyrinthine tiling: could not add the result layer: {exc}")
            self.status.value = f"Failed: {exc}"

    def _add_result(self, plan: RenderPlan, outcome: Outcome) -> None:
        data, kwargs = result_layer(plan, outcome)
        # Added hidden, so that napari slices it once, where the viewer stands (a
        # new layer is otherwise sliced at index 0 first: a lazy plane computed
        # for nothing), after the slider of a stack or sweep moves to its end.
        layer = self.viewer.add_image(data, visible=False, **kwargs)
        self.last_result = layer
        if plan.mode in ("stack", "sweep"):
            axis = self.viewer.dims.ndim - layer.ndim
            self.viewer.dims.set_current_step(axis, data.shape[0] - 1)
        layer.visible = True
        if plan.mode == "stack":
            self.metrics_table.show_passes(outcome.metric_rows)
        self.status.value = f"Added {layer.name} ({outcome.seconds:.1f} s)"

    def _on_finished(self) -> None:
        cancelled = self._plan is not None and not self._outcome_received
        self.worker = None
        self._plan = None  # holds the input data: let it go
        self.run_button.enabled = True
        self.cancel_button.enabled = False
        if cancelled:
            self.status.value = "Cancelled: no layer added"

    # -- compare -----------------------------------------------------------------------------

    def toggle_compare(self, *_args) -> None:
        """Show the input and the result side by side (napari grid mode), or go back."""
        self._compare.toggle(self.last_result)
        self.compare_button.text = "Back to overlay" if self._compare.active else "Compare"

    @property
    def comparing(self) -> bool:
        """Whether the compare (grid) view is on."""
        return self._compare.active
