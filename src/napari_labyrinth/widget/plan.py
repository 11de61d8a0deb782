"""What a widget run will do: no napari, no Qt.

The napari widget (:mod:`napari_labyrinth._qt`) takes two plain snapshots on
the main thread when Run is pressed: the input layer (:class:`LayerSnapshot`)
and the user's choices (:class:`Choices`). :func:`make_plan` turns them into
a :class:`RenderPlan`: one run of :func:`~napari_labyrinth.labyrinth_steps`
in a mode, which planes it renders, its tone limits and plane offset, the
progress total, and the result layer's name, transforms, contrast settings
and metadata record, from which the API call it names
(:func:`~napari_labyrinth.labyrinth`, :func:`~napari_labyrinth.labyrinth_stack`
or :func:`~napari_labyrinth.labyrinth_sweep`) reproduces the result exactly.
:mod:`napari_labyrinth.widget.run` carries a plan out.

The fields of the widget's form and the sweep's values are read with the
parameter table (:mod:`napari_labyrinth.core.parameters`).
"""

from __future__ import annotations

import dataclasses
import math
import threading
from collections.abc import Callable, Mapping, Sequence
from typing import Any

import numpy as np

from .. import metrics
from ..api import MODES
from ..core.colour import resolve_colour
from ..core.parameters import PARAMETERS, SWEEPABLE, format_value
from ..core.planes import first_plane_index, step_count
from ..core.presets import DEFAULT_PRESET, PRESETS, resolve_parameters, resolve_sweep
from ..core.tone_scale import validate_tone_limits
from ..lazy import is_in_memory
from ..provenance import FUNCTIONS, KEY, input_record, make_record, sweep_arguments

__all__ = [
    "ALL_PLANES",
    "CURRENT_PLANE",
    "METADATA_KEY",
    "MODES",
    "Choices",
    "LayerSnapshot",
    "RenderPlan",
    "default_sweep_text",
    "make_plan",
    "parse_sweep_values",
    "preview_choices",
    "result_description",
    "result_name",
    "sweep_label",
]

#: Key of the result layers' ``metadata`` under which a run is recorded
#: (the provenance record of :mod:`napari_labyrinth.provenance`).
METADATA_KEY = KEY

#: Which planes of an nD layer to render.
ALL_PLANES, CURRENT_PLANE = "all planes", "current plane"

#: Parameters a sweep may vary: every parameter that takes one word, and the seed.
SWEEP_PARAMETERS = tuple(SWEEPABLE)

#: Values a sweep proposes for the parameters whose proposal is not derived from
#: their kind (floats: around the current value; options: every choice).
_SWEEP_PROPOSALS = {
    "passes": "1, 2, 4, 8",
    "seed": "0, 1, 2",
    "tone_ranges": "2, 3, 5",
    "max_tries": "1, 10, 100",
}

#: Rows of the per-pass metrics (one column per pass): (metric key, row header,
#: the function whose docstring's first line describes the row).
METRIC_ROWS = (
    ("edge_enhancement", "edge enhancement", metrics.edge_enhancement),
    ("labyrinth_cover", "labyrinth cover", metrics.labyrinth_cover),
    ("wall_width", "wall width", metrics.wall_width),
    ("orientation_coherence", "coherence", metrics.orientation_coherence),
    ("contour_alignment", "alignment", metrics.contour_alignment),
    ("texture_added", "texture added", metrics.texture_added),
    ("changed", "changed %", None),
)


# -- what the widget hands over ----------------------------------------------------------------


@dataclasses.dataclass(frozen=True, eq=False)
class LayerSnapshot:
    """The input image layer as plain values, taken on the main thread.

    Attributes
    ----------
    name : str
    data : array_like
        The layer data (not copied; numpy, dask, zarr, ...).
    ndim : int
        Dimensions of the layer, colour channels of RGB data not counted.
    rgb, multiscale : bool
    scale, translate : ndarray
        One value per dimension.
    rotate : ndarray
        ``(ndim, ndim)`` rotation matrix.
    shear : ndarray
        Upper-triangular shear coefficients (``ndim * (ndim - 1) / 2``
        values) or an ``(ndim, ndim)`` shear matrix.
    affine : ndarray
        ``(ndim + 1, ndim + 1)`` homogeneous matrix of the layer's extra
        (physical to world) affine transform.
    units, axis_labels : tuple of str
    contrast_limits : tuple of float
    gamma, opacity, blending, interpolation2d, colormap
        Display settings, handed to the result layer as they are.
    visible_index : tuple of int
        Index, in the leading axes of the data, of the plane the viewer shows.
    """

    name: str
    data: Any
    ndim: int
    rgb: bool
    multiscale: bool
    scale: np.ndarray
    translate: np.ndarray
    rotate: np.ndarray
    shear: np.ndarray
    affine: np.ndarray
    units: tuple[str, ...]
    axis_labels: tuple[str, ...]
    contrast_limits: tuple[float, float]
    gamma: float
    opacity: float
    blending: str
    interpolation2d: Any
    colormap: Any
    visible_index: tuple[int, ...]

    @classmethod
    def of(cls, data: Any, name: str = "image", rgb: bool = False, **fields: Any) -> LayerSnapshot:
        """A snapshot of an array shown as napari shows it by default (identity transforms).

        ``fields`` override any attribute, e.g. ``scale=(2.0, 2.0)``.

        Examples
        --------
        >>> LayerSnapshot.of(np.zeros((3, 8, 8))).axis_labels
        ('-3', '-2', '-1')
        """
        ndim = fields.pop("ndim") if "ndim" in fields else np.ndim(data) - bool(rgb)
        values = {
            "name": name,
            "data": data,
            "ndim": ndim,
            "rgb": bool(rgb),
            "multiscale": False,
            "scale": np.ones(ndim),
            "translate": np.zeros(ndim),
            "rotate": np.eye(ndim),
            "shear": np.zeros(ndim * (ndim - 1) // 2),
            "affine": np.eye(ndim + 1),
            "units": ("pixel",) * ndim,
            "axis_labels": tuple(str(axis - ndim) for axis in range(ndim)),
            "contrast_limits": (0.0, 255.0),
            "gamma": 1.0,
            "opacity": 1.0,
            "blending": "translucent",
            "interpolation2d": "nearest",
            "colormap": "gray",
            "visible_index": (0,) * max(ndim - 2, 0),
        }
        values.update(fields)
        for key in ("scale", "translate", "rotate", "shear", "affine"):
            values[key] = np.asarray(values[key], dtype=float)
        return cls(**values)


@dataclasses.dataclass(frozen=True)
class Choices:
    """The user's choices for a run.

    Attributes
    ----------
    mode : {"single", "stack", "sweep"}
    preset : str
        Name of the preset (``napari_labyrinth.PRESETS``).
    overrides : dict
        Parameters whose value differs from the preset's.
    seed : int
    tone_limits : pair or None
        Values mapped to tones 0 and 255 as typed (text or numbers), or None
        to follow the layer's contrast limits.
    planes : {"all planes", "current plane"}
    sweep_parameter : str
        One of ``SWEEP_PARAMETERS`` (sweep mode).
    sweep_text : str
        Its values as typed, e.g. ``"0.47, 0.50, 0.53"`` (sweep mode).
    metrics : bool
        Measure every pass of a stack on the plane on screen (stack mode).
    colour : {"luminance", "channels"}
        How an RGB(A) layer is rendered: its luminance, the colour kept, or
        each channel on its own (ignored for other layers).
    """

    mode: str = "single"
    preset: str = DEFAULT_PRESET
    overrides: Mapping[str, Any] = dataclasses.field(default_factory=dict)
    seed: int = 0
    tone_limits: tuple[Any, Any] | None = None
    planes: str = ALL_PLANES
    sweep_parameter: str = "variance_threshold"
    sweep_text: str = ""
    metrics: bool = True
    colour: str = "luminance"


# -- text in, text out -------------------------------------------------------------------------


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
        If the text holds no value, a value of the wrong type, or a decimal
        comma (``"0,04"``: see :meth:`Parameter.parse_values`).
    """
    if parameter not in SWEEPABLE:
        raise ValueError(
            f"cannot sweep {parameter!r}: choose one of {', '.join(SWEEP_PARAMETERS)}"
        )
    return SWEEPABLE[parameter].parse_values(text)


def default_sweep_text(parameter: str, current: Any) -> str:
    """Values proposed for a sweep of ``parameter`` around its ``current`` value.

    ``variance_threshold`` at the paper's 0.50 gives ``"0.47, 0.5, 0.53"`` (Fig. 3).
    """
    kind = SWEEPABLE[parameter].kind
    if kind == "float":
        step = 0.03 if current >= 0.2 else 0.02
        values = [max(0.0, current - step), current, current + step]
        return ", ".join(f"{v:.4g}" for v in values)
    if kind == "choice":
        return ", ".join(SWEEPABLE[parameter].choices)
    if kind == "bool":
        return "false, true"
    return _SWEEP_PROPOSALS[parameter]


def tone_limits(
    contrast_limits: Sequence[float] | None, typed: tuple[Any, Any] | None = None
) -> tuple[float, float]:
    """The values mapped to tones 0 and 255: the contrast limits, or else the typed pair.

    Raises
    ------
    ValueError
        If the typed limits are not numbers, or the limits are not finite with low < high.
    """
    if contrast_limits is not None:
        low, high = (float(v) for v in contrast_limits)
    else:
        if typed is not None and (not isinstance(typed, Sequence) or len(typed) != 2):
            raise ValueError(f"tone limits must be a pair of numbers (low, high), got {typed!r}")
        typed_low, typed_high = typed if typed is not None else (None, None)
        try:
            low, high = float(typed_low), float(typed_high)
        except (TypeError, ValueError):
            raise ValueError(
                f"tone limits must be numbers, got {typed_low!r} and {typed_high!r}"
            ) from None
    try:
        return validate_tone_limits((low, high))
    except ValueError:
        raise ValueError(
            f"tone limits must be finite with low < high, got ({low}, {high})"
        ) from None


def tone_limit_text(contrast_limits: Sequence[float]) -> tuple[str, str]:
    """Contrast limits as the text of the tone limit fields."""
    low, high = (float(v) for v in contrast_limits)
    return f"{low:.6g}", f"{high:.6g}"


def _plural(count: int, word: str) -> str:
    return f"{count} {word}" + ("" if count == 1 else "es" if word.endswith("s") else "s")


def result_description(
    source: str,
    mode: str,
    passes: int,
    preset: str,
    overrides: Mapping[str, Any],
    seed: int,
    sweep: tuple[str, Sequence[Any]] | None = None,
    plane_label: str = "",
) -> str:
    """What a result holds, in one line: the input, the mode and the key parameters.

    The result layer's metadata and the widget's status line carry it; the
    layer's name is the short :func:`result_name`.

    Examples
    --------
    >>> result_description("cell", "single", 4, "labyrinth", {}, 0)
    'cell · labyrinth · 4 passes · preset labyrinth'
    """
    if mode == "sweep" and sweep is not None:
        parameter, values = sweep
        shown = ", ".join(format_value(v) for v in values[:4]) + (" …" if len(values) > 4 else "")
        parts = [source, f"sweep {parameter} {shown}"]
        if parameter != "passes":
            parts.append(_plural(passes, "pass"))
    else:
        parts = [source, "labyrinth" if mode == "single" else "stack", _plural(passes, "pass")]
    parts.append(f"preset {preset}")
    edits = [
        f"{PARAMETERS[name].symbol or name}={format_value(value)}"
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


def result_name(source: str, mode: str, sweep_parameter: str = "", plane_label: str = "") -> str:
    """Short name of a result layer, readable in the layer list.

    Examples
    --------
    >>> result_name("cell", "sweep", "variance_threshold")
    'cell · sweep V'
    >>> result_name("movie", "single", plane_label="t=2")
    'movie · labyrinth · t=2'
    """
    what = {"single": "labyrinth", "stack": "stack", "preview": "preview"}.get(mode)
    if mode == "sweep":
        symbol = PARAMETERS[sweep_parameter].symbol if sweep_parameter in PARAMETERS else None
        what = f"sweep {symbol or sweep_parameter}"
    return " · ".join(part for part in (source, what, plane_label) if part)


def sweep_label(record: Mapping[str, Any], step: int) -> str:
    """What the plane ``step`` of a sweep result shows: ``"V = 0.04"`` (for a text overlay)."""
    sweep = record.get("sweep") or {}
    values = sweep.get("values") or []
    if not values:
        return ""
    parameter = sweep["parameter"]
    value = values[min(max(int(step), 0), len(values) - 1)]
    symbol = PARAMETERS[parameter].symbol if parameter in PARAMETERS else None
    return f"{symbol or parameter} = {format_value(value)}"


def preview_choices(choices: Choices) -> Choices:
    """The choices of a preview: one rendering of the plane on screen, no metrics."""
    return dataclasses.replace(choices, mode="single", planes=CURRENT_PLANE, metrics=False)


def plane_label(axis_labels: Sequence[str], index: tuple[int, ...]) -> str:
    """Where a plane is, for a layer name: ``"t=2, z=5"`` (``"axis 0=2"`` for unnamed axes)."""
    labels = []
    for axis, position in enumerate(index):
        label = str(axis_labels[axis])
        if label.lstrip("-").isdigit():
            label = f"axis {axis}"
        labels.append(f"{label}={position}")
    return ", ".join(labels)


def format_metric(value: float) -> str:
    """A metric in a table cell: 3 significant digits (trailing zeros kept, so that a
    column reads alike), no exponent below 10**6."""
    if not math.isfinite(value):
        return "–"
    if value == 0:
        return "0"
    text = f"{value:#.3g}"
    if abs(float(text)) >= 100:  # 99.96 rounds up to 100: no digits after the point
        return f"{value:.0f}" if abs(value) < 1e6 else text
    return text


def metric_row_headers() -> list[tuple[str, str]]:
    """(header, tooltip) of each row of the per-pass metrics table."""
    rows = []
    for key, header, function in METRIC_ROWS:
        doc = (
            (function.__doc__ or "").strip().splitlines()[0]
            if function
            else "Pixels this pass changed, in percent."
        )
        rows.append((header, f"{key}: {doc}"))
    return rows


def metric_cells(passes: Sequence[Mapping[str, float]]) -> tuple[list[str], list[list[str]]]:
    """Column headers (the pass numbers) and cell texts (one row per metric) of the table."""
    headers = [str(values["pass"]) for values in passes]
    cells = [[format_metric(values[key]) for values in passes] for key, _, _ in METRIC_ROWS]
    return headers, cells


# -- presets and the fields that override them -------------------------------------------------


def _tone_range_count(value: Any) -> int:
    """Number of tone ranges of a ``tone_ranges`` value (a count or the limits)."""
    return int(value) if isinstance(value, (int, np.integer)) else len(value) - 1


def _differs(value: Any, base: Any) -> bool:
    """Whether a field's value overrides the preset's (floats: beyond rounding)."""
    if isinstance(base, float) or isinstance(value, float):
        return not math.isclose(float(value), float(base), rel_tol=1e-9, abs_tol=1e-12)
    return value != base


def preset_field_values(preset: str, names: Sequence[str]) -> dict[str, Any]:
    """The values the fields ``names`` take from ``preset`` (tone ranges as a count)."""
    values = PRESETS[preset]
    return {
        name: _tone_range_count(values[name]) if name == "tone_ranges" else values[name]
        for name in names
    }


def overrides(preset: str, values: Mapping[str, Any]) -> dict[str, Any]:
    """The field ``values`` that differ from ``preset``'s, in the order of ``values``.

    Returns
    -------
    dict
        Parameter name -> value, for :func:`napari_labyrinth.resolve_parameters`.
    """
    base = preset_field_values(preset, list(values))
    return {name: value for name, value in values.items() if _differs(value, base[name])}


def edited_text(edited: Mapping[str, Any]) -> str:
    """What the preset row says about the fields edited after choosing the preset."""
    return f"edited: {', '.join(edited)}" if edited else "as the preset"


# -- planes ------------------------------------------------------------------------------------


def visible_plane(coordinates: Sequence[float], shape: Sequence[int]) -> tuple[int, ...]:
    """Index of the plane at data ``coordinates`` of the leading axes, clipped to ``shape``."""
    return tuple(int(np.clip(np.round(c), 0, size - 1)) for c, size in zip(coordinates, shape))


def run_steps(
    shape: tuple[int, ...],
    rgb: bool,
    passes_per_run: Sequence[int],
    stack_passes: int = 0,
    colour: str | None = None,
) -> int:
    """Number of yields of a run of data of ``shape`` (the progress bar's total).

    One per plane and pass of every run (colour: per channel, alpha not
    rendered), one per pass whose metrics a stack computes, and one for
    assembling the result.
    """
    return step_count(shape, -1 if rgb else None, passes_per_run, colour) + stack_passes + 1


# -- the plan ----------------------------------------------------------------------------------


@dataclasses.dataclass
class RenderPlan:
    """Everything a run needs, captured on the main thread when Run is pressed.

    The run reads only this (arrays and plain values), never the viewer.

    Attributes
    ----------
    mode : {"single", "stack", "sweep"}
    function : str
        Name of the API function called.
    arguments : dict
        Its keyword arguments (every parameter, seed, tone limits, ...).
    data : array_like
        What the run renders: the whole layer data, or one plane of it
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
        Number of yields of the run (the progress bar's total).
    metrics : bool
        Whether a stack run measures every pass on the plane on screen.
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
    metrics: bool = False
    cancel: threading.Event = dataclasses.field(default_factory=threading.Event)
    abort_requested: Callable[[], bool] = lambda: False

    @property
    def name(self) -> str:
        """Name of the result layer."""
        return self.layer_kwargs["name"]

    @property
    def description(self) -> str:
        """What the result holds, in one line (its metadata record's ``description``)."""
        return self.layer_kwargs["metadata"][METADATA_KEY]["description"]

    @property
    def source(self) -> str:
        """Name of the input layer."""
        return self.layer_kwargs["metadata"][METADATA_KEY]["source_layer"]

    def should_stop(self) -> bool:
        """Whether the user (or napari's activity panel) asked the run to stop."""
        return self.cancel.is_set() or self.abort_requested()


def make_plan(snapshot: LayerSnapshot | None, choices: Choices) -> RenderPlan:
    """What a run with ``choices`` on the layer ``snapshot`` will do.

    Raises
    ------
    ValueError, TypeError
        With a message for the user when a choice is invalid (no layer, a
        multiscale layer, bad tone limits, sweep values or parameters).
    """
    _check_input(snapshot, choices.mode)
    mode, preset, edits = choices.mode, choices.preset, dict(choices.overrides)
    resolved = resolve_parameters(preset, **edits)
    seed = SWEEPABLE["seed"].validate(choices.seed)  # 2.7 was truncated to 2
    typed = choices.tone_limits
    limits = tone_limits(snapshot.contrast_limits if typed is None else None, typed)
    arguments: dict[str, Any] = {"preset": preset, "seed": seed, **resolved.as_dict()}
    arguments["tone_limits"] = limits
    arguments["channel_axis"] = -1 if snapshot.rgb else None
    if snapshot.rgb:
        arguments["colour"] = resolve_colour(choices.colour, snapshot.data.shape, -1)
    sweep = None
    if mode == "sweep":
        sweep = _sweep(preset, edits, choices.sweep_parameter, choices.sweep_text)
        _sweep_arguments(arguments, *sweep)

    # "current plane", and lazy data: the run renders the plane on screen only;
    # the rest of a lazy result stays lazy (napari renders a plane when it shows it)
    source, n_leading = snapshot.data, snapshot.ndim - 2
    visible_index = tuple(snapshot.visible_index)
    partial = choices.planes == CURRENT_PLANE and n_leading > 0
    lazy = not is_in_memory(source) and n_leading > 0 and not partial
    source_index = visible_index if partial or lazy else None
    if source_index is not None:
        arguments["plane_offset"] = first_plane_index(
            source.shape, source_index, -1 if snapshot.rgb else None
        )
    passes_per_run = [resolved.passes]
    if sweep:  # one run per value
        passes_per_run = sweep[1] if sweep[0] == "passes" else passes_per_run * len(sweep[1])
    stack_passes = resolved.passes if mode == "stack" and choices.metrics else 0
    rendered_shape = source.shape[0 if source_index is None else len(source_index) :]
    colour = arguments.get("colour")
    total = run_steps(rendered_shape, snapshot.rgb, passes_per_run, stack_passes, colour)

    label = plane_label(snapshot.axis_labels, visible_index) if partial else ""
    name = result_name(snapshot.name, mode, sweep[0] if sweep else "", label)
    description = result_description(
        snapshot.name, mode, resolved.passes, preset, edits, seed, sweep, label
    )
    record = make_record(
        mode=mode,
        preset=preset,
        overrides=edits,
        parameters=resolved.as_dict(),
        seed=seed,
        tone_limits=limits,
        arguments=arguments,
        sweep=sweep,
        source=input_record(snapshot.name, source.shape, source.dtype),
    )
    record.update(
        description=description,
        source_layer=snapshot.name,
        source_shape=list(source.shape),
        source_dtype=str(source.dtype),
        source_index=list(source_index) if partial else None,
        lazy=lazy,
    )
    if not partial:  # the record renders the whole data
        record["arguments"].pop("plane_offset", None)
    extra_axis = {"stack": "pass", "sweep": sweep[0] if sweep else None}.get(mode)
    layer_kwargs = result_layer_kwargs(
        snapshot, name, extra_axis, visible_index if partial else None
    )
    layer_kwargs["metadata"] = {METADATA_KEY: record}
    return RenderPlan(
        mode=mode,
        function=FUNCTIONS[mode],
        arguments=arguments,
        data=source if source_index is None else source[source_index],
        source_index=source_index,
        visible_index=visible_index,
        lazy_source=source if lazy else None,
        rgb=bool(snapshot.rgb),
        total_steps=total,
        metrics=mode == "stack" and choices.metrics,
        layer_kwargs=layer_kwargs,
    )


def _check_input(snapshot: LayerSnapshot | None, mode: str) -> None:
    """Raise for what no run can render: no layer, a multiscale layer, an unknown mode."""
    if snapshot is None:
        raise ValueError("choose an image layer to render (add one, or open a sample)")
    if snapshot.multiscale:
        raise ValueError(
            f"{snapshot.name!r} is a multiscale layer: add one of its resolution levels as "
            "an image layer and render that"
        )
    if mode not in MODES:
        raise ValueError(f"mode must be one of {', '.join(MODES)}, got {mode!r}")


def _sweep(
    preset: str, edits: Mapping[str, Any], parameter: str, text: str
) -> tuple[str, list[Any]]:
    """The swept parameter and its values, each checked now rather than in the run."""
    values = parse_sweep_values(parameter, text)
    others = {name: value for name, value in edits.items() if name != parameter}
    resolve_sweep(preset, others, None, parameter, values)  # the swept field's value is replaced
    return parameter, list(values)


def _sweep_arguments(arguments: dict[str, Any], parameter: str, values: list[Any]) -> None:
    """Turn the arguments of one rendering into those of ``labyrinth_sweep``."""
    sweep_arguments(arguments, parameter, values)


def _shear_matrix(shear: np.ndarray, ndim: int) -> np.ndarray:
    """An ``(ndim, ndim)`` shear matrix from napari's upper-triangular values or a matrix."""
    shear = np.asarray(shear, dtype=float)
    if shear.ndim == 2:
        return shear
    matrix = np.eye(ndim)
    matrix[np.triu_indices(ndim, k=1)] = shear
    return matrix


def data_to_physical(snapshot: LayerSnapshot) -> np.ndarray:
    """Linear part of the layer's data-to-physical transform: rotate @ shear @ scale (napari's)."""
    n = snapshot.ndim
    return (
        np.asarray(snapshot.rotate, dtype=float)
        @ _shear_matrix(snapshot.shear, n)
        @ np.diag(np.asarray(snapshot.scale, dtype=float))
    )


def result_layer_kwargs(
    snapshot: LayerSnapshot,
    name: str,
    extra_axis: str | None,
    plane_index: tuple[int, ...] | None,
) -> dict[str, Any]:
    """Name, transforms, units and contrast settings of a result layer.

    ``extra_axis`` names a new leading axis (stack, sweep), which gets
    scale 1. A single plane rendered alone (``plane_index``) sits where it is
    in the input: its translate moves by the data-to-physical image of its
    index (the extra affine transform then maps it where the input's plane is).
    """
    scale = np.asarray(snapshot.scale, dtype=float)
    translate = np.asarray(snapshot.translate, dtype=float)
    if plane_index is not None:
        offset = np.zeros(snapshot.ndim)
        offset[: len(plane_index)] = plane_index
        translate = translate + data_to_physical(snapshot) @ offset
    units = tuple(snapshot.units)
    axis_labels = tuple(snapshot.axis_labels)
    rotate = np.asarray(snapshot.rotate)
    shear = np.asarray(snapshot.shear)
    affine = np.asarray(snapshot.affine, dtype=float)
    if extra_axis is not None:
        n = snapshot.ndim
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
        expanded = np.eye(n + 2)
        expanded[1:, 1:] = affine
        affine = expanded
    kwargs: dict[str, Any] = {
        "name": name,
        "scale": scale,
        "translate": translate,
        "rotate": rotate,
        "shear": shear,
        "affine": affine,
        "units": units,
        "axis_labels": axis_labels,
        "rgb": bool(snapshot.rgb),
        "contrast_limits": list(snapshot.contrast_limits),
        "gamma": snapshot.gamma,
        "opacity": snapshot.opacity,
        "blending": snapshot.blending,
        "interpolation2d": snapshot.interpolation2d,
    }
    if not snapshot.rgb:
        kwargs["colormap"] = snapshot.colormap
    return kwargs
