"""The widget's text in and text out: typed values read, names, labels and table cells written.

In: the values of a sweep (:func:`parse_sweep_values`) and the tone limits
(:func:`tone_limits`) as typed. Out: what the widget proposes and shows, the
result layer's name (:func:`result_name`) and one-line description
(:func:`result_description`), the label of a sweep's plane
(:func:`sweep_label`), and the rows and cells of the per-pass metrics table
(:data:`METRIC_ROWS`). Values are read and written with the parameter table
(:mod:`napari_labyrinth.core.parameters`).
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from typing import Any

from .. import metrics
from ..core.parameters import PARAMETERS, SWEEPABLE, format_value
from ..core.tone_scale import validate_tone_limits

__all__ = [
    "METRIC_ROWS",
    "SWEEP_PARAMETERS",
    "default_sweep_text",
    "edited_text",
    "format_metric",
    "metric_cells",
    "metric_row_headers",
    "parse_sweep_values",
    "plane_label",
    "result_description",
    "result_name",
    "sweep_label",
    "tone_limit_text",
    "tone_limits",
]

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


# -- text in -----------------------------------------------------------------------------------


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
        If the text holds no value, an empty value (``"0.03,,0.05"``), a
        value of the wrong type or a range, or a decimal comma (``"0,04"``:
        see :meth:`Parameter.parse_values`).
    """
    if parameter not in SWEEPABLE:
        raise ValueError(
            f"cannot sweep {parameter!r}: choose one of {', '.join(SWEEP_PARAMETERS)}"
        )
    return SWEEPABLE[parameter].parse_values(text)


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


# -- text out: what the form proposes ----------------------------------------------------------


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


def tone_limit_text(contrast_limits: Sequence[float]) -> tuple[str, str]:
    """Contrast limits as the text of the tone limit fields."""
    low, high = (float(v) for v in contrast_limits)
    return f"{low:.6g}", f"{high:.6g}"


def edited_text(edited: Mapping[str, Any]) -> str:
    """What the preset row says about the fields edited after choosing the preset."""
    return f"edited: {', '.join(edited)}" if edited else "as the preset"


# -- text out: names and labels of results -----------------------------------------------------


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


def plane_label(axis_labels: Sequence[str], index: tuple[int, ...]) -> str:
    """Where a plane is, for a layer name: ``"t=2, z=5"`` (``"axis 0=2"`` for unnamed axes)."""
    labels = []
    for axis, position in enumerate(index):
        label = str(axis_labels[axis])
        if label.lstrip("-").isdigit():
            label = f"axis {axis}"
        labels.append(f"{label}={position}")
    return ", ".join(labels)


# -- text out: the per-pass metrics table ------------------------------------------------------


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
