"""Mapping between an image's values and the paper's 0-255 tone scale."""

from __future__ import annotations

import dataclasses
import math
import numbers
from collections.abc import Mapping
from typing import Any

import numpy as np

from ._kernel_arguments import IntegerScale
from .parameters import as_float, scalar
from .percentiles import counting_pays, integer_percentiles

#: Percentiles of the finite values that set the default tone limits of
#: every dtype but uint8 (robust to a few hot or dead pixels).
DEFAULT_PERCENTILES = (0.5, 99.5)

#: The dtypes an image may have: integers up to 32 bits and floats.
SUPPORTED_DTYPES = tuple(
    np.dtype(t)
    for t in (
        np.uint8,
        np.uint16,
        np.uint32,
        np.int8,
        np.int16,
        np.int32,
        np.float16,
        np.float32,
        np.float64,
    )
)


def validate_dtype(dtype: np.dtype) -> np.dtype:
    """``dtype`` if an image may have it; a TypeError saying what to do otherwise."""
    dtype = np.dtype(dtype)
    if dtype not in SUPPORTED_DTYPES:
        if dtype.kind in "iu":
            hint = "; 64-bit integers usually hold labels: cast an intensity image to float32"
        else:
            hint = ""
        raise TypeError(
            f"image dtype {dtype} is not supported: use an integer type up to "
            f"32 bits or a float type{hint}"
        )
    return dtype


@dataclasses.dataclass(frozen=True)
class ToneScale:
    """Linear map of ``[low, high]`` onto the 0-255 tone scale (clipped)."""

    low: float
    high: float

    @property
    def _gain(self) -> float:
        return 255.0 / (self.high - self.low)

    @property
    def gain(self) -> float:
        """Tones per unit of value: ``255 / (high - low)``."""
        return self._gain

    @property
    def _fits_float32(self) -> bool:
        """Whether float32 intermediates hold the map (limits and gain well inside its
        range); otherwise a finite value could become an infinite or NaN tone."""
        return max(abs(self.low), abs(self.high)) < 1e37 and 1e-30 < self._gain < 1e30

    def to_tones(self, values: np.ndarray) -> np.ndarray:
        """float32 tones of ``values``; non-finite values become NaN."""
        if _is_paper_scale(self, values.dtype):
            return values.astype(np.float32)  # the paper's own scale
        if (values.dtype.itemsize <= 2 or values.dtype == np.float32) and self._fits_float32:
            # values are exact in float32: map there, with half the memory traffic
            tones = np.subtract(values, np.float32(self.low), dtype=np.float32)
            with np.errstate(over="ignore"):  # values far outside the limits: clipped below
                tones *= np.float32(self._gain)
        else:
            tones = np.subtract(values, self.low, dtype=np.float64) * self._gain
            tones = tones.astype(np.float32)
        np.clip(tones, 0.0, 255.0, out=tones)
        if values.dtype.kind == "f":
            finite = np.isfinite(values)
            if not finite.all():
                tones[~finite] = np.nan
        return tones

    def from_tones(self, tones: np.ndarray, dtype: np.dtype) -> np.ndarray:
        """Values of ``dtype`` for ``tones``: rounded and clipped for integers."""
        values = tones.astype(np.float64) / self._gain + self.low
        return representable(values, np.dtype(dtype))


def validate_tone_limits(tone_limits: Any) -> tuple[float, float]:
    """``tone_limits`` as ``(low, high)`` floats, finite with low < high.

    Raises
    ------
    TypeError, ValueError
        Naming ``tone_limits``.
    """
    if (
        isinstance(tone_limits, (str, bytes, set, frozenset, Mapping))  # unordered: refused
        or not _has_length(tone_limits)
        or len(tone_limits) != 2
    ):
        raise TypeError(f"tone_limits must be None or (low, high), got {tone_limits!r}")
    values = [scalar(value) for value in tone_limits]  # a 0-d array is its number
    for value in values:
        if not isinstance(value, numbers.Real) or isinstance(value, (bool, np.bool_)):
            raise TypeError(f"tone_limits must hold real numbers, got {tone_limits!r}")
    low, high = (as_float(value) for value in values)
    if not (math.isfinite(low) and math.isfinite(high)) or not low < high:
        raise ValueError(f"tone_limits must be finite with low < high, got {tone_limits!r}")
    return low, high


def resolve_tone_scale(values: np.ndarray, tone_limits: tuple[float, float] | None) -> ToneScale:
    """The tone scale of an image from the ``tone_limits`` argument.

    ``None`` gives (0, 255) for uint8 data and the ``DEFAULT_PERCENTILES`` of
    the finite values otherwise. A constant image gets a unit-wide scale.
    """
    if tone_limits is not None:
        return ToneScale(*_finite_span(*validate_tone_limits(tone_limits), given=True))
    if values.dtype == np.uint8:
        return ToneScale(0.0, 255.0)
    finite = values if values.dtype.kind in "iu" else values[np.isfinite(values)]
    if finite.size == 0:
        return ToneScale(0.0, 1.0)
    low, high = default_percentiles(finite)
    return ToneScale(*_finite_span(*separated_limits(low, high), given=False))


def separated_limits(low: float, high: float) -> tuple[float, float]:
    """Tone limits of an image made a usable scale.

    A constant image (``high <= low``): ``high = low + 1``, or one float64
    step above ``low`` where 1 is below that step (``|low| >= 2**53``, where
    ``low + 1`` rounds to ``low``); below ``low`` for the largest float64.
    Limits closer than ``MIN_TONE_SPAN`` (subnormal values, whose gain
    ``255 / (high - low)`` would overflow): ``high = low + MIN_TONE_SPAN``.
    """
    if high > low:
        return low, max(high, low + MIN_TONE_SPAN)
    step = max(1.0, math.ulp(low))
    if math.isfinite(low + step):
        return low, low + step
    return low - step, low


#: The narrowest tone scale: below it the gain ``255 / (high - low)`` could overflow.
MIN_TONE_SPAN = 1e-300


def _finite_span(low: float, high: float, *, given: bool) -> tuple[float, float]:
    """``(low, high)``, refused when ``high - low`` overflows float64 (the gain would be 0).

    Given limits closer than ``MIN_TONE_SPAN`` (the gain would overflow) are
    refused; the image's own are widened by ``separated_limits``.
    """
    if given and high - low < MIN_TONE_SPAN:
        raise ValueError(
            f"tone_limits ({low!r}, {high!r}) are too close for a tone scale: "
            f"pass tone_limits that differ by at least {MIN_TONE_SPAN:g}"
        )
    if not math.isfinite(high - low):
        what = "tone_limits" if given else "the default tone limits (percentiles) of image"
        raise ValueError(
            f"{what} ({low!r}, {high!r}) span more than the largest float64: "
            "pass tone_limits that differ by less than 1.7e308"
        )
    return low, high


def _has_length(value: Any) -> bool:
    try:
        len(value)
    except TypeError:  # numbers, 0-d arrays
        return False
    return True


def representable(values: np.ndarray, dtype: np.dtype) -> np.ndarray:
    """float64 ``values`` as ``dtype``: rounded and clipped to its range (integers), or
    clipped to its finite range (floats: tone limits beyond float16's make no inf)."""
    if dtype.kind in "iu":
        info = np.iinfo(dtype)
        return np.clip(np.rint(values), info.min, info.max).astype(dtype)
    limit = float(np.finfo(dtype).max)
    return np.clip(values, -limit, limit).astype(dtype)


def default_percentiles(values: np.ndarray) -> list[float]:
    """The ``DEFAULT_PERCENTILES`` of ``values`` (finite, at least one), as ``np.percentile``.

    8- and 16-bit integers are counted (one pass, no copy of the image) and
    give numpy's floats bit for bit, once the counting kernel is compiled or
    where the image is large (``counting_pays``); other dtypes and other
    integer images go through ``np.percentile``.
    """
    if values.dtype.kind in "iu" and values.dtype.itemsize <= 2 and counting_pays(values):
        return integer_percentiles(values, DEFAULT_PERCENTILES)
    return [float(v) for v in np.percentile(values, DEFAULT_PERCENTILES)]


def integer_plane_tones(scale: ToneScale, values: np.ndarray) -> np.ndarray | None:
    """``scale.to_tones(values)`` of a C-contiguous 2-D integer plane in one pass; else None.

    With :func:`write_changed_values` the render of an integer plane keeps no
    copy of its initial tones: the write-back computes them again.
    """
    if not _fused(values):
        return None
    from ._tone_loops import integer_tones  # numba is imported on first use only

    tones = np.empty(values.shape, dtype=np.float32)
    integer_tones(values, tones, integer_scale(scale, values.dtype))
    return tones


def write_changed_values(
    scale: ToneScale, target: np.ndarray, values: np.ndarray, tones: np.ndarray
) -> None:
    """Write into ``target`` (holding ``values``) the values of the tones that changed.

    A tone has changed where its bits differ from those of
    ``integer_plane_tones(scale, values)``; its value is
    ``scale.from_tones(tone, target.dtype)``. One pass, no temporary array.
    ``values`` and ``target`` are C-contiguous integer planes of one dtype.
    """
    from ._tone_loops import rounded_tones, write_back  # numba is imported on first use only

    if _is_paper_scale(scale, values.dtype) and target.flags.c_contiguous:
        rounded_tones(target, tones)
        return
    write_back(target, values, tones, integer_scale(scale, values.dtype))


def write_listed_values(
    scale: ToneScale, target: np.ndarray, values: np.ndarray, tones: np.ndarray, indices
) -> None:
    """:func:`write_changed_values` where only the pixels of flat ``indices`` may have changed.

    ``indices`` (int64, repeats allowed) lists every pixel whose tone a pass
    wrote (``labyrinth_pass``'s ``changes``); the others are not visited.
    ``values`` is a C-contiguous integer plane, ``target`` a plane of its dtype.
    """
    from ._tone_loops import write_back_at  # numba is imported on first use only

    write_back_at(target, values, tones, indices, integer_scale(scale, values.dtype))


def integer_scale(scale: ToneScale, dtype: np.dtype) -> IntegerScale:
    """``scale`` as the numba loops over integer planes take it, for integers of ``dtype``."""
    gain = scale._gain
    wide = np.dtype(dtype).itemsize > 2 or not scale._fits_float32
    if scale._fits_float32:
        low32, gain32 = np.float32(scale.low), np.float32(gain)
    else:  # float32 of the limits or the gain may not be finite
        low32, gain32 = np.float32(0.0), np.float32(1.0)
    info = np.iinfo(dtype)
    return IntegerScale(
        bool(_is_paper_scale(scale, dtype)),
        float(scale.low),
        float(gain),
        low32,
        gain32,
        bool(wide),
        float(info.min),
        float(info.max),
    )


def fits_banded_pass(values: np.ndarray) -> bool:
    """Whether ``values`` is a plane ``_banded_pass.banded_pass`` takes (C-contiguous
    2-D integers)."""
    return _fused(values)


def _is_paper_scale(scale: ToneScale, dtype: np.dtype) -> bool:
    """uint8 values on the scale (0, 255): each value is its own tone."""
    return np.dtype(dtype) == np.uint8 and (scale.low, scale.high) == (0.0, 255.0)


def _fused(values: np.ndarray) -> bool:
    return values.dtype.kind in "iu" and values.ndim == 2 and values.flags.c_contiguous
