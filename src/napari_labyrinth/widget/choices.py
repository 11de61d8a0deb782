"""What the widget hands over when Run is pressed: the input layer and the user's choices.

:class:`LayerSnapshot` holds the input layer as plain values and
:class:`Choices` what the user chose; both are taken on the main thread and
read by :func:`~napari_labyrinth.widget.plan.make_plan`. The helpers here
give the values the form's fields take from a preset (:func:`preset_field_values`),
the fields that override it (:func:`overrides`) and the plane on screen
(:func:`visible_plane`).
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np

from ..core.presets import DEFAULT_PRESET, PRESETS

__all__ = [
    "ALL_PLANES",
    "CURRENT_PLANE",
    "Choices",
    "LayerSnapshot",
    "overrides",
    "preset_field_values",
    "preview_choices",
    "visible_plane",
]

#: Which planes of an nD layer to render.
ALL_PLANES, CURRENT_PLANE = "all planes", "current plane"


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
        Index, in the leading axes of the data (of a multiscale layer: of its full
        level), of the plane the viewer shows.
    data_level : int
        The level of a multiscale layer the viewer shows (0, the full level, otherwise).
    shown_region : ((int, int), (int, int)) or None
        The rows and the columns (start, stop) of that level on screen, as napari
        loads them (its corner pixels); None when not known (the whole level).
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
    data_level: int = 0
    shown_region: tuple[tuple[int, int], tuple[int, int]] | None = None

    @classmethod
    def of(cls, data: Any, name: str = "image", rgb: bool = False, **fields: Any) -> LayerSnapshot:
        """A snapshot of an array shown as napari shows it by default (identity transforms).

        ``fields`` override any attribute, e.g. ``scale=(2.0, 2.0)``; with
        ``multiscale=True``, ``data`` is a sequence of levels, the full one first.

        Examples
        --------
        >>> LayerSnapshot.of(np.zeros((3, 8, 8))).axis_labels
        ('-3', '-2', '-1')
        """
        full = data[0] if fields.get("multiscale") else data
        ndim = fields.pop("ndim") if "ndim" in fields else np.ndim(full) - bool(rgb)
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
    preview : bool
        A preview: a multiscale layer's level on screen is rendered, not its full
        level (:func:`preview_choices`).
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
    preview: bool = False


def preview_choices(choices: Choices) -> Choices:
    """The choices of a preview: one rendering of the plane on screen (of a multiscale
    layer, at the level on screen), no metrics."""
    return dataclasses.replace(
        choices, mode="single", planes=CURRENT_PLANE, metrics=False, preview=True
    )


def visible_plane(coordinates: Sequence[float], shape: Sequence[int]) -> tuple[int, ...]:
    """Index of the plane at data ``coordinates`` of the leading axes, clipped to ``shape``."""
    return tuple(int(np.clip(np.round(c), 0, size - 1)) for c, size in zip(coordinates, shape))


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
