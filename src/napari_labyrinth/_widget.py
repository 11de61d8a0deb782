"""The napari widget: render an image layer with the labyrinthine tiling.

The only module of the package that imports napari or Qt. It holds no
algorithm: it reads the user's choices, turns them into one call of the
public API (:func:`~napari_labyrinth.labyrinth`,
:func:`~napari_labyrinth.labyrinth_stack` or
:func:`~napari_labyrinth.labyrinth_sweep`), runs that call in a napari thread
worker and adds the result as a new layer whose metadata records the call, so
that it can be reproduced exactly.

How a run stays responsive and cancellable: the worker is a generator (napari
draws a determinate progress bar from its yields). The API call itself runs
in a helper thread started by the generator; its ``progress`` callback, called
after every plane and pass, forwards the count to the generator, which yields
it, and raises when the user cancelled, so a run stops at the next plane or
pass and adds no layer.

Lazy (dask-backed) input layers: only the plane the viewer shows is loaded
and rendered by the worker; the other planes of the result stay lazy and are
rendered by napari when the slider reaches them.
"""

from __future__ import annotations

import dataclasses
import math
import queue
import re
import threading
import time
from collections.abc import Callable, Generator, Sequence
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
from qtpy.QtWidgets import (
    QAbstractItemView,
    QHeaderView,
    QLabel,
    QScrollArea,
    QTableWidget,
    QTableWidgetItem,
    QVBoxLayout,
    QWidget,
)
from superqt import QCollapsible

from . import __version__, api, metrics, parameters, presets

__all__ = [
    "METADATA_KEY",
    "MODES",
    "LabyrinthWidget",
    "parse_sweep_values",
    "render_selected_layer",
    "stack_selected_layer",
]

#: Name of the plugin and of its widget in the manifest (napari.yaml).
PLUGIN_NAME = "napari-labyrinth"
WIDGET_NAME = "Labyrinthine tiling"

#: Key of the result layers' ``metadata`` under which the widget records a run.
METADATA_KEY = "napari_labyrinth"

#: What a run produces: one rendering, the input and every pass (Fig. 4), or
#: one rendering per value of a parameter (Fig. 3).
MODES = ("single", "stack", "sweep")

#: Which planes of an nD layer to render.
ALL_PLANES, CURRENT_PLANE = "all planes", "current plane"

#: API function each mode calls.
_FUNCTIONS = {"single": "labyrinth", "stack": "labyrinth_stack", "sweep": "labyrinth_sweep"}

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

#: Parameters a sweep may vary: every parameter but ``tones``, and the seed.
SWEEP_PARAMETERS = tuple(name for name in parameters.PARAMETER_NAMES if name != "tones") + (
    "seed",
)
_FLOAT_PARAMETERS = ("mean_threshold", "variance_threshold")
_INT_PARAMETERS = ("tone_ranges", "max_tries", "passes", "seed")
_OPTION_PARAMETERS = {
    name: choices for name, (choices, _) in READING_FIELDS.items() if choices is not None
}
_SYMBOLS = {"mean_threshold": "t", "variance_threshold": "V"}

#: Rows of the per-pass table (one column per pass): (metric key, row header, the
#: function whose docstring's first line is the row's tooltip).
METRIC_ROWS = (
    ("edge_enhancement", "edge enhancement", metrics.edge_enhancement),
    ("labyrinth_cover", "labyrinth cover", metrics.labyrinth_cover),
    ("wall_width", "wall width", metrics.wall_width),
    ("orientation_coherence", "coherence", metrics.orientation_coherence),
    ("contour_alignment", "alignment", metrics.contour_alignment),
    ("texture_added", "texture added", metrics.texture_added),
    ("changed", "changed %", None),
)

_SEED_MAX = 2**63 - 1
_PASSES_MAX = 1000


# -- plain helpers (no Qt) ---------------------------------------------------------------------


def parse_sweep_values(parameter: str, text: str) -> list[Any]:
    """Values of a sweep typed as text, converted to the parameter's type.

    Parameters
    ----------
    parameter : str
        One of ``SWEEP_PARAMETERS``.
    text : str
        Values separated by commas, semicolons or spaces, e.g. ``"0.47, 0.50, 0.53"``.

    Returns
    -------
    list
        floats, ints, bools or option names.

    Raises
    ------
    ValueError
        If the text holds no value or a value of the wrong type.
    """
    if parameter not in SWEEP_PARAMETERS:
        raise ValueError(
            f"cannot sweep {parameter!r}: choose one of {', '.join(SWEEP_PARAMETERS)}"
        )
    items = [item for item in re.split(r"[,;\s]+", text.strip()) if item]
    if not items:
        raise ValueError(f"type at least one value of {parameter} to sweep, e.g. 0.47, 0.50, 0.53")
    values: list[Any] = []
    for item in items:
        try:
            if parameter in _FLOAT_PARAMETERS:
                values.append(float(item))
            elif parameter in _INT_PARAMETERS:
                values.append(int(item))
            elif parameter == "include_centre":
                lowered = item.lower()
                if lowered not in ("true", "false", "yes", "no", "1", "0"):
                    raise ValueError
                values.append(lowered in ("true", "yes", "1"))
            else:
                if item not in _OPTION_PARAMETERS[parameter]:
                    raise ValueError
                values.append(item)
        except ValueError:
            expected = {
                **dict.fromkeys(_FLOAT_PARAMETERS, "numbers"),
                **dict.fromkeys(_INT_PARAMETERS, "whole numbers"),
                "include_centre": "true or false",
            }.get(parameter) or " or ".join(_OPTION_PARAMETERS[parameter])
            raise ValueError(f"{parameter} values must be {expected}; got {item!r}") from None
    return values


def default_sweep_text(parameter: str, current: Any) -> str:
    """Values proposed for a sweep of ``parameter`` around its ``current`` value.

    ``variance_threshold`` at the paper's 0.50 gives ``"0.47, 0.5, 0.53"`` (Fig. 3).
    """
    if parameter in _FLOAT_PARAMETERS:
        step = 0.03 if current >= 0.2 else 0.02
        values = [max(0.0, current - step), current, current + step]
        return ", ".join(f"{v:.4g}" for v in values)
    if parameter == "passes":
        return "1, 2, 4, 8"
    if parameter == "seed":
        return "0, 1, 2"
    if parameter == "tone_ranges":
        return "2, 3, 5"
    if parameter == "max_tries":
        return "1, 10, 100"
    if parameter == "include_centre":
        return "false, true"
    return ", ".join(_OPTION_PARAMETERS[parameter])


def _tone_range_count(value: Any) -> int:
    """Number of tone ranges of a ``tone_ranges`` value (a count or the limits)."""
    return int(value) if isinstance(value, (int, np.integer)) else len(value) - 1


def _differs(value: Any, base: Any) -> bool:
    """Whether a field's value overrides the preset's (floats: beyond rounding)."""
    if isinstance(base, float) or isinstance(value, float):
        return not math.isclose(float(value), float(base), rel_tol=1e-9, abs_tol=1e-12)
    return value != base


def _format_value(value: Any) -> str:
    """A parameter value in a layer name."""
    if isinstance(value, bool):
        return str(value).lower()
    if isinstance(value, float):
        return f"{value:.4g}"
    return str(value)


def _format_metric(value: float) -> str:
    """A metric in a table cell: 3 significant digits, no exponent below 10**6."""
    if not math.isfinite(value):
        return "–"
    return f"{value:.0f}" if 100 <= abs(value) < 1e6 else f"{value:.3g}"


def _plural(count: int, word: str) -> str:
    return f"{count} {word}" + ("" if count == 1 else "es" if word.endswith("s") else "s")


def result_name(
    source: str,
    mode: str,
    passes: int,
    preset: str,
    overrides: dict[str, Any],
    seed: int,
    sweep: tuple[str, Sequence[Any]] | None = None,
    plane_label: str = "",
) -> str:
    """Name of a result layer: the input, the mode and the key parameters.

    Examples
    --------
    >>> result_name("cell", "single", 4, "labyrinth", {}, 0)
    'cell · labyrinth · 4 passes · preset labyrinth'
    """
    if mode == "sweep" and sweep is not None:
        parameter, values = sweep
        shown = ", ".join(_format_value(v) for v in values[:4]) + (" …" if len(values) > 4 else "")
        parts = [source, f"sweep {parameter} {shown}"]
        if parameter != "passes":
            parts.append(_plural(passes, "pass"))
    else:
        parts = [source, "labyrinth" if mode == "single" else "stack", _plural(passes, "pass")]
    parts.append(f"preset {preset}")
    edits = [
        f"{_SYMBOLS.get(name, name)}={_format_value(value)}"
        for name, value in overrides.items()
        if name != "passes"
    ]
    if edits:
        parts.append(", ".join(edits[:3]) + (" …" if len(edits) > 3 else ""))
    if seed and not (sweep and sweep[0] == "seed"):
        parts.append(f"seed {seed}")
    if plane_label:
        parts.append(plane_label)
    return " · ".join(parts)


def _diagnostics_record(diagnostics: np.ndarray | None) -> dict[str, Any] | None:
    """JSON-friendly form of the API's structured diagnostics array."""
    if diagnostics is None:
        return None
    return {
        "shape": list(diagnostics.shape),
        "counts": {name: diagnostics[name].tolist() for name in diagnostics.dtype.names},
    }


def _is_lazy(data: Any) -> bool:
    """True for array-likes other than numpy arrays (dask, zarr, ...): load planes on demand."""
    return not isinstance(data, np.ndarray)


def _as_dask(data: Any, n_leading: int):
    """``data`` as a dask array with one chunk per plane."""
    import dask.array as da

    if isinstance(data, da.Array):
        return data
    chunks = (1,) * n_leading + tuple(data.shape[n_leading:])
    return da.from_array(data, chunks=chunks)


def _splice_plane(lazy, rendered_plane: np.ndarray, index: tuple[int, ...], axis: int):
    """``lazy`` with the plane at ``index`` (on the axes from ``axis``) replaced by an array.

    The visible plane, rendered by the worker, goes into the lazy result so
    that napari shows it at once without rendering it again.
    """
    import dask.array as da

    if not index:
        block = np.asarray(rendered_plane).reshape(lazy.shape)
        return da.from_array(block, chunks=block.shape)
    position = index[0]

    def take(part: slice):
        return lazy[(slice(None),) * axis + (part,)]

    parts = []
    if position > 0:
        parts.append(take(slice(0, position)))
    parts.append(
        _splice_plane(take(slice(position, position + 1)), rendered_plane, index[1:], axis + 1)
    )
    if position + 1 < lazy.shape[axis]:
        parts.append(take(slice(position + 1, None)))
    return da.concatenate(parts, axis=axis) if len(parts) > 1 else parts[0]


def _plane_offset(shape: tuple[int, ...], index: tuple[int, ...], rgb: bool) -> int:
    """Flat index, among the API's planes of the whole data, of the first plane at ``index``.

    The API takes every leading axis as planes, colour channels (last axis of
    napari's RGB data) last among them.
    """
    channels = shape[-1] if rgb else 1
    return int(np.ravel_multi_index(index, shape[: len(index)])) * channels


def _grey(plane: np.ndarray, rgb: bool) -> np.ndarray:
    """A 2-D float plane for the metrics: colour planes averaged over R, G and B."""
    plane = np.asarray(plane, dtype=np.float64)
    return plane[..., :3].mean(axis=-1) if rgb else plane


# -- what a run does ---------------------------------------------------------------------------


class _Cancelled(Exception):
    """Raised in the progress callback when the user cancelled."""


@dataclasses.dataclass
class _Failure:
    """A run that failed: the message for the user."""

    message: str


@dataclasses.dataclass
class _Outcome:
    """What a finished run hands back to the main thread."""

    data: Any
    diagnostics: Any
    metric_rows: list[dict[str, float]]
    seconds: float


@dataclasses.dataclass
class RenderPlan:
    """Everything a run needs, captured on the main thread when Run is pressed.

    The worker reads only this (arrays and plain values), never the viewer.

    Attributes
    ----------
    mode : {"single", "stack", "sweep"}
    function : str
        Name of the API function called.
    arguments : dict
        Its keyword arguments (every parameter, seed, tone limits, ...).
    data : array_like
        What the worker renders: the whole layer data, or one plane of it
        (then ``arguments`` holds its ``plane_offset``).
    source_index : tuple of int or None
        Index of that plane in the layer data, None for the whole data.
    visible_index : tuple of int
        Index of the plane the viewer shows (for the metrics table).
    lazy_source : array_like or None
        Lazy layer data of which the rest of the result stays lazy.
    rgb : bool
        Whether the data holds colour channels on its last axis.
    total_steps : int
        Number of yields of the worker (the progress bar's total).
    layer_kwargs : dict
        Keyword arguments of the result layer (name, transforms, contrast, metadata).
    """

    mode: str
    function: str
    arguments: dict[str, Any]
    data: Any
    source_index: tuple[int, ...] | None
    visible_index: tuple[int, ...]
    lazy_source: Any
    rgb: bool
    total_steps: int
    layer_kwargs: dict[str, Any]
    cancel: threading.Event = dataclasses.field(default_factory=threading.Event)
    abort_requested: Callable[[], bool] = lambda: False

    def should_stop(self) -> bool:
        """Whether the user (or napari's activity panel) asked the run to stop."""
        return self.cancel.is_set() or self.abort_requested()


def _call_with_progress(
    function: Callable[..., Any],
    data: Any,
    arguments: dict[str, Any],
    should_stop: Callable[[], bool],
) -> Generator[int, None, Any]:
    """Run an API call in a helper thread; yield after each plane and pass.

    Returns the call's result (as the generator's value). The call stops at
    its next plane or pass once ``should_stop()`` is true (raising
    :class:`_Cancelled`).
    """
    events: queue.SimpleQueue = queue.SimpleQueue()

    def report(done: int, _total: int) -> None:
        if should_stop():
            raise _Cancelled
        events.put(("progress", done))

    def target() -> None:
        try:
            events.put(("done", function(data, progress=report, **arguments)))
        except BaseException as exc:  # noqa: BLE001 - handed to the generator, raised there
            events.put(("error", exc))

    if should_stop():
        raise _Cancelled
    thread = threading.Thread(target=target, name="napari-labyrinth render", daemon=True)
    thread.start()
    while True:
        kind, value = events.get()
        if kind == "progress":
            yield value
            continue
        thread.join()
        if kind == "error":
            raise value
        return value


def _lazy_result(plan: RenderPlan):
    """The whole result as a lazy dask array (the API renders dask input lazily)."""
    import dask.array as da

    source = _as_dask(plan.lazy_source, len(plan.visible_index))
    arguments = {k: v for k, v in plan.arguments.items() if k != "plane_offset"}
    result = getattr(api, plan.function)(source, **arguments)
    if not isinstance(result, da.Array):
        raise TypeError("this version of napari_labyrinth.api does not render dask arrays lazily")
    return result


def _render(plan: RenderPlan) -> Generator[int, None, _Outcome | _Failure | None]:
    """The worker: render, yield after each plane and pass, compute the metrics.

    Returns an :class:`_Outcome`, a :class:`_Failure` with a message for the
    user, or None when cancelled.
    """
    started = time.perf_counter()
    try:
        data = np.asarray(plan.data)  # for lazy input: loads one plane only
        function = getattr(api, plan.function)
        result, diagnostics = yield from _call_with_progress(
            function, data, dict(plan.arguments, return_diagnostics=True), plan.should_stop
        )
        metric_rows = []
        if plan.mode == "stack":
            metric_rows = yield from _stack_metrics(plan, data, result)
        if plan.lazy_source is not None:
            offset = 0 if plan.mode == "single" else 1
            result = _splice_plane(_lazy_result(plan), result, plan.visible_index, offset)
        if plan.should_stop():
            return None
        yield plan.total_steps
        return _Outcome(result, diagnostics, metric_rows, time.perf_counter() - started)
    except _Cancelled:
        return None
    except (TypeError, ValueError) as exc:  # the API names the parameter at fault
        return _Failure(str(exc))
    except MemoryError:
        return _Failure("not enough memory: render the current plane only, or a smaller image")
    except Exception as exc:  # noqa: BLE001 - anything else still reaches the user as a message
        return _Failure(f"{type(exc).__name__}: {exc}")


def _stack_metrics(
    plan: RenderPlan, data: np.ndarray, stack: np.ndarray
) -> Generator[int, None, list[dict[str, float]]]:
    """Pattern and edge metrics of every pass on the visible plane."""
    index = () if plan.source_index is not None else plan.visible_index
    original = _grey(data[index], plan.rgb)
    rows = []
    previous = np.asarray(stack[(0,) + index])
    for pass_number in range(1, stack.shape[0]):
        if plan.should_stop():
            raise _Cancelled
        rendered = np.asarray(stack[(pass_number,) + index])
        try:
            described = metrics.describe(original, _grey(rendered, plan.rgb))
        except ValueError:  # e.g. a plane too small for the metrics' windows
            described = {key: math.nan for key, _, function in METRIC_ROWS if function}
        row = {"pass": pass_number, **described}
        changed = rendered != previous
        if plan.rgb:
            changed = changed.any(axis=-1)
        row["changed"] = 100.0 * float(changed.mean())
        rows.append(row)
        previous = rendered
        yield pass_number
    return rows


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
        self._compare_state: dict[str, Any] | None = None
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
            if name in _FLOAT_PARAMETERS:
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

        self.metrics_title = QLabel("Metrics after pass 1, 2, … (plane on screen)")
        self.metrics_table = QTableWidget(len(METRIC_ROWS), 0)
        self.metrics_table.setVerticalHeaderLabels([header for _, header, _ in METRIC_ROWS])
        for row, (key, _, function) in enumerate(METRIC_ROWS):
            doc = (
                (function.__doc__ or "").strip().splitlines()[0]
                if function
                else ("Pixels this pass changed, in percent.")
            )
            self.metrics_table.verticalHeaderItem(row).setToolTip(f"{key}: {doc}")
        self.metrics_table.setEditTriggers(QAbstractItemView.EditTrigger.NoEditTriggers)
        self.metrics_table.horizontalHeader().setSectionResizeMode(
            QHeaderView.ResizeMode.ResizeToContents
        )
        self.metrics_table.verticalHeader().setSectionResizeMode(
            QHeaderView.ResizeMode.ResizeToContents
        )
        self.metrics_title.setVisible(False)
        self.metrics_table.setVisible(False)

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
        low, high = (float(v) for v in layer.contrast_limits)
        self.tone_low.value = f"{low:.6g}"
        self.tone_high.value = f"{high:.6g}"

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
        if self.follow_contrast.value and layer is not None:
            low, high = (float(v) for v in layer.contrast_limits)
        else:
            try:
                low, high = float(self.tone_low.value), float(self.tone_high.value)
            except ValueError:
                raise ValueError(
                    f"tone limits must be numbers, got {self.tone_low.value!r} and "
                    f"{self.tone_high.value!r}"
                ) from None
        if not (math.isfinite(low) and math.isfinite(high) and low < high):
            raise ValueError(f"tone limits must be finite with low < high, got ({low}, {high})")
        return low, high

    # -- parameters --------------------------------------------------------------------------

    def _apply_preset(self, name: str) -> None:
        """Fill every parameter field from preset ``name``."""
        values = presets.PRESETS[name]
        self._filling = True
        try:
            for field, widget in self.fields.items():
                value = values[field]
                widget.value = _tone_range_count(value) if field == "tone_ranges" else value
        finally:
            self._filling = False
        self._on_field_edited()
        self._on_sweep_parameter(self.sweep_parameter.value)

    def _on_field_edited(self, *_args) -> None:
        if self._filling:
            return
        edited = list(self.overrides())
        self.edited.value = f"edited: {', '.join(edited)}" if edited else "as the preset"

    def overrides(self) -> dict[str, Any]:
        """The fields whose value differs from the chosen preset's.

        Returns
        -------
        dict
            Parameter name -> value, for :func:`napari_labyrinth.resolve_parameters`.
        """
        base = presets.PRESETS[self.preset.value]
        changed = {}
        for name, widget in self.fields.items():
            value, preset_value = widget.value, base[name]
            if name == "tone_ranges":
                preset_value = _tone_range_count(preset_value)
            if _differs(value, preset_value):
                changed[name] = value
        return changed

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
        layer = self.image_layer.value
        if layer is None:
            raise ValueError("choose an image layer to render (add one, or open a sample)")
        if layer.multiscale:
            raise ValueError(
                f"{layer.name!r} is a multiscale layer: add one of its resolution levels as "
                "an image layer and render that"
            )
        mode = self.mode.value
        preset = self.preset.value
        overrides = self.overrides()
        resolved = api.resolve_parameters(preset, **overrides)
        seed = int(self.seed.value)
        tone_limits = self.tone_limits()
        rgb = bool(layer.rgb)
        source = layer.data
        n_leading = layer.ndim - 2
        visible_index = self._visible_index(layer)

        arguments: dict[str, Any] = {"preset": preset, "seed": seed}
        arguments.update(resolved.as_dict())
        arguments["tone_limits"] = tone_limits
        arguments["channel_axis"] = -1 if rgb else None
        sweep = None
        passes_per_run = [resolved.passes]
        if mode == "sweep":
            parameter = self.sweep_parameter.value
            values = parse_sweep_values(parameter, self.sweep_values.value)
            for value in values:  # validate every value now, not in the worker
                if parameter != "seed":
                    api.resolve_parameters(preset, **dict(overrides, **{parameter: value}))
            arguments.pop(parameter, None)
            if parameter == "tone_ranges":
                arguments.pop("tones", None)
            if parameter == "seed":
                arguments.pop("seed")
            arguments["parameter"] = parameter
            arguments["values"] = list(values)
            sweep = (parameter, list(values))
            if parameter == "passes":
                passes_per_run = list(values)

        # "current plane", and lazy data: the worker renders the plane on screen only;
        # the rest of a lazy result stays lazy (napari renders a plane when it shows it)
        partial = self.planes.value == CURRENT_PLANE and n_leading > 0
        lazy = _is_lazy(source) and n_leading > 0 and not partial
        if partial or lazy:
            source_index = visible_index
            data = source[source_index]
            arguments["plane_offset"] = _plane_offset(source.shape, source_index, rgb)
        else:
            source_index = None
            data = source

        planes_rendered = 1 if source_index is not None else math.prod(source.shape[:n_leading])
        if rgb:
            channels = source.shape[-1]
            planes_rendered *= 3 if channels == 4 else channels
        total = planes_rendered * sum(passes_per_run)
        if mode == "stack":
            total += resolved.passes
        total += 1  # the final step: assembling the result

        plane_label = self._plane_label(layer, visible_index) if partial else ""
        name = result_name(
            layer.name, mode, resolved.passes, preset, overrides, seed, sweep, plane_label
        )
        function = _FUNCTIONS[mode]
        record = {
            "version": __version__,
            "mode": mode,
            "function": function,
            "arguments": {
                k: (list(v) if isinstance(v, tuple) else v) for k, v in arguments.items()
            },
            "source_layer": layer.name,
            "source_shape": list(source.shape),
            "source_dtype": str(source.dtype),
            "source_index": list(source_index) if partial else None,
            "preset": preset,
            "overrides": dict(overrides),
            "parameters": resolved.as_dict(),
            "seed": seed,
            "tone_limits": list(tone_limits),
            "sweep": {"parameter": sweep[0], "values": sweep[1]} if sweep else None,
            "lazy": lazy,
        }
        if not partial:
            record["arguments"].pop("plane_offset", None)
        extra_axis = {"stack": "pass", "sweep": sweep[0] if sweep else None}.get(mode)
        layer_kwargs = self._result_layer_kwargs(
            layer, name, extra_axis, visible_index if partial else None
        )
        layer_kwargs["metadata"] = {METADATA_KEY: record}
        return RenderPlan(
            mode=mode,
            function=function,
            arguments=arguments,
            data=data,
            source_index=source_index,
            visible_index=visible_index,
            lazy_source=source if lazy else None,
            rgb=rgb,
            total_steps=total,
            layer_kwargs=layer_kwargs,
        )

    def _visible_index(self, layer: Image) -> tuple[int, ...]:
        """Index, in the layer data, of the plane the viewer shows."""
        n_leading = layer.ndim - 2
        if n_leading <= 0:
            return ()
        coordinates = layer.world_to_data(self.viewer.dims.point)[:n_leading]
        shape = layer.data.shape[:n_leading]
        return tuple(int(np.clip(np.round(c), 0, size - 1)) for c, size in zip(coordinates, shape))

    @staticmethod
    def _plane_label(layer: Image, index: tuple[int, ...]) -> str:
        labels = []
        for axis, position in enumerate(index):
            label = str(layer.axis_labels[axis])
            if label.lstrip("-").isdigit():
                label = f"axis {axis}"
            labels.append(f"{label}={position}")
        return ", ".join(labels)

    @staticmethod
    def _result_layer_kwargs(
        layer: Image,
        name: str,
        extra_axis: str | None,
        plane_index: tuple[int, ...] | None,
    ) -> dict[str, Any]:
        """Name, transforms, units and contrast settings of a result layer.

        ``extra_axis`` names a new leading axis (stack, sweep), which gets
        scale 1. A single plane rendered alone sits where it is in the input.
        """
        scale = np.asarray(layer.scale, dtype=float)
        translate = np.asarray(layer.translate, dtype=float)
        if plane_index is not None:
            # the plane is data[index]: keep it in place in world coordinates
            origin = np.zeros(layer.ndim)
            offset = np.zeros(layer.ndim)
            offset[: len(plane_index)] = plane_index
            to_physical = layer.affine.inverse
            translate = (
                translate
                + np.asarray(to_physical(layer.data_to_world(offset)))
                - (np.asarray(to_physical(layer.data_to_world(origin))))
            )
        units = tuple(str(unit) for unit in layer.units)
        axis_labels = tuple(layer.axis_labels)
        rotate = np.asarray(layer.rotate)
        shear = np.asarray(layer.shear)
        affine = layer.affine
        if extra_axis is not None:
            n = layer.ndim
            scale = np.concatenate([[1.0], scale])
            translate = np.concatenate([[0.0], translate])
            units = ("pixel",) + units
            axis_labels = (extra_axis,) + axis_labels
            embedded = np.eye(n + 1)
            embedded[1:, 1:] = rotate
            rotate = embedded
            shear = (
                np.concatenate([np.zeros(n), shear.ravel()])
                if shear.ndim == 1
                else (np.pad(shear, ((1, 0), (1, 0))))
            )
            if shear.ndim == 2:
                shear[0, 0] = 1.0
            affine = affine.expand_dims([0])
        kwargs: dict[str, Any] = {
            "name": name,
            "scale": scale,
            "translate": translate,
            "rotate": rotate,
            "shear": shear,
            "affine": affine,
            "units": units,
            "axis_labels": axis_labels,
            "rgb": bool(layer.rgb),
            "contrast_limits": list(layer.contrast_limits),
            "gamma": layer.gamma,
            "opacity": layer.opacity,
            "blending": layer.blending,
            "interpolation2d": layer.interpolation2d,
        }
        if not layer.rgb:
            kwargs["colormap"] = layer.colormap
        return kwargs

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
            _render,
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
        self.status.value = f"Rendering {plan.layer_kwargs['name']} …"
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

    def _on_returned(self, outcome: _Outcome | _Failure | None) -> None:
        plan = self._plan
        if outcome is None or plan is None or plan.cancel.is_set():
            return
        self._outcome_received = True
        if isinstance(outcome, _Failure):
            show_error(f"Labyrinthine tiling failed: {outcome.message}")
            self.status.value = f"Failed: {outcome.message}"
            return
        try:
            self._add_result(plan, outcome)
        except Exception as exc:  # noqa: BLE001 - shown to the user, not as a traceback
            show_error(f"Labyrinthine tiling: could not add the result layer: {exc}")
            self.status.value = f"Failed: {exc}"

    def _add_result(self, plan: RenderPlan, outcome: _Outcome) -> None:
        kwargs = dict(plan.layer_kwargs)
        record = kwargs["metadata"][METADATA_KEY]
        if plan.mode == "sweep":
            record["diagnostics"] = [_diagnostics_record(d) for d in outcome.diagnostics]
        else:
            record["diagnostics"] = _diagnostics_record(outcome.diagnostics)
        if plan.source_index is None:
            record["diagnostics_scope"] = "all planes"
        elif plan.lazy_source is not None:
            record["diagnostics_scope"] = "the plane on screen (the others render lazily)"
            record["diagnostics_plane"] = list(plan.visible_index)
        else:
            record["diagnostics_scope"] = "the rendered plane"
        record["metrics"] = outcome.metric_rows
        data = outcome.data
        if record["source_index"] is not None:
            # one plane rendered alone: size-1 leading axes keep it at its place
            n_extra = 0 if plan.mode == "single" else 1
            index = record["source_index"]
            shape = data.shape[:n_extra] + (1,) * len(index) + data.shape[n_extra:]
            data = data.reshape(shape)
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
            self._show_metrics(outcome.metric_rows)
        self.status.value = f"Added {layer.name} ({outcome.seconds:.1f} s)"

    def _on_finished(self) -> None:
        cancelled = self._plan is not None and not self._outcome_received
        self.worker = None
        self._plan = None  # holds the input data: let it go
        self.run_button.enabled = True
        self.cancel_button.enabled = False
        if cancelled:
            self.status.value = "Cancelled: no layer added"

    def _show_metrics(self, passes: list[dict[str, float]]) -> None:
        """Fill the table: one row per metric, one column per pass."""
        table = self.metrics_table
        table.setColumnCount(len(passes))
        table.setHorizontalHeaderLabels([str(values["pass"]) for values in passes])
        for column, values in enumerate(passes):
            for row, (key, _, _) in enumerate(METRIC_ROWS):
                value = values[key]
                item = QTableWidgetItem(_format_metric(value))
                item.setTextAlignment(Qt.AlignmentFlag.AlignRight | Qt.AlignmentFlag.AlignVCenter)
                table.setItem(row, column, item)
        self.metrics_title.setVisible(True)
        table.setVisible(True)
        table.resizeColumnsToContents()
        height = table.horizontalHeader().sizeHint().height() + 2 * table.frameWidth()
        height += sum(table.rowHeight(row) for row in range(table.rowCount()))
        if table.horizontalScrollBar().isVisible() or table.columnCount() > 6:
            height += table.horizontalScrollBar().sizeHint().height()
        table.setFixedHeight(height)

    # -- compare -----------------------------------------------------------------------------

    def toggle_compare(self, *_args) -> None:
        """Show the input and the result side by side (napari grid mode), or go back."""
        grid = getattr(self.viewer, "canvas", self.viewer).grid
        if self._compare_state is not None:
            state, self._compare_state = self._compare_state, None
            grid.enabled = state["enabled"]
            grid.shape = state["shape"]
            grid.stride = state["stride"]
            for layer, visible in state["visible"].items():
                if layer in self.viewer.layers:
                    layer.visible = visible
            self.compare_button.text = "Compare"
            return
        result = self.viewer.layers.selection.active
        if not (isinstance(result, Image) and METADATA_KEY in result.metadata):
            result = self.last_result
        if result is None or result not in self.viewer.layers:
            show_info("Run the tiling first (or select a result layer) to compare it.")
            return
        source_name = result.metadata[METADATA_KEY]["source_layer"]
        source = next((lay for lay in self.viewer.layers if lay.name == source_name), None)
        if source is None:
            show_info(f"The input layer {source_name!r} is no longer in the viewer.")
            return
        self._compare_state = {
            "enabled": grid.enabled,
            "shape": tuple(grid.shape),
            "stride": grid.stride,
            "visible": {layer: layer.visible for layer in self.viewer.layers},
        }
        for layer in self.viewer.layers:
            # napari hands plugins proxies of its layers: compare with ==, not `is`
            layer.visible = layer == source or layer == result
        layers = list(self.viewer.layers)
        grid.stride = 1 if layers.index(source) < layers.index(result) else -1
        grid.shape = (1, 2)
        grid.enabled = True
        self.compare_button.text = "Back to overlay"

    @property
    def comparing(self) -> bool:
        """Whether the compare (grid) view is on."""
        return self._compare_state is not None


# -- menu commands (Layers > Filter) -----------------------------------------------------------


def _run_on_selected_layer(viewer: Viewer, mode: str) -> None:
    layer = viewer.layers.selection.active
    if not isinstance(layer, Image):
        show_error("Labyrinthine tiling: select an image layer first.")
        return
    _, widget = viewer.window.add_plugin_dock_widget(PLUGIN_NAME, WIDGET_NAME)
    widget.reset_choices()
    widget.image_layer.value = layer
    widget.mode.value = mode
    widget.run()


def render_selected_layer(viewer: Viewer) -> None:
    """Render the selected image layer with the widget's current settings.

    Opens the widget (if needed) so that the progress, Cancel and the
    parameters stay at hand.
    """
    _run_on_selected_layer(viewer, "single")


def stack_selected_layer(viewer: Viewer) -> None:
    """Render every pass of the selected image layer into one stack (Fig. 4)."""
    _run_on_selected_layer(viewer, "stack")
