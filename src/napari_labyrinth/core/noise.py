"""The noise of an image plane, measured from the plane itself, and the noise gate's floor.

:func:`noise_sigma` is Immerkær's fast estimate of the standard deviation of
additive white noise: the plane convolved with the difference of two
Laplacians,

::

     1 -2  1
    -2  4 -2
     1 -2  1

cancels every linear ramp (and most of a smooth image), and what is left of
white noise of deviation sigma has a deviation of 6 sigma (the mask's squares
sum to 36); for Gaussian noise the mean absolute residual is
``sqrt(2 / pi) * 6 * sigma``. Edges leave residuals too, so the estimate is
an upper bound that is close on images whose edges are few (a dark field,
a smooth texture) and larger on busy ones.

The sums run over fixed bands of rows in a fixed order, so that every path
that renders a plane (whole, in bands, in tiles, in blocks of a dask image)
gets the same number from the same values. A JPEG's noise is mostly at the
scale of its blocks, where Immerkær's mask reads little of it: the noise gate
takes the larger of this estimate and the dark field's (:func:`dark_field_sigma`).

References
----------
J. Immerkær, "Fast noise variance estimation", Computer Vision and Image
Understanding 64 (2), 300-302 (1996).
"""

from __future__ import annotations

import math

import numpy as np

from .tone_scale import ToneScale

#: ``sqrt(pi / 2) / 6``: the mean absolute residual of the mask times this is sigma.
_SIGMA_PER_RESIDUAL = math.sqrt(math.pi / 2.0) / 6.0

#: Rows of the plane convolved at once by default: bounds the residuals' memory (float64).
_BAND_ROWS = 256

#: Bytes of float64 tones convolved at once, at most (fewer rows of a wide plane).
_MEASURED_BYTES = 4 << 20


def noise_sigma(plane: np.ndarray) -> float:
    """Immerkær's estimate of the deviation of the noise of a 2-D plane, in its values' units.

    Parameters
    ----------
    plane : (H, W) ndarray
        Integer or float values; non-finite values and the residuals they
        touch do not count.

    Returns
    -------
    float
        sigma, >= 0; 0 for a plane under 3 x 3 pixels or without a finite
        3 x 3 neighbourhood.
    """
    return _residual_sigma(_checked(plane), None)


def tone_noise_sigma(values, scale: ToneScale, band_rows: int = _BAND_ROWS) -> float:
    """The noise of the plane ``values`` in the tones of ``scale``, which the noise gate
    compares the local variance with: the larger of Immerkær's estimate
    (:func:`noise_sigma`) and :func:`dark_field_sigma`, both read on the tones
    the kernel sees (``scale.to_tones``, made band of rows by band of rows).

    This is the one place a rendering measures a plane's noise: every path
    that renders the plane (or a plane of the same tones) gets the same number.
    ``band_rows`` bounds the rows read and held at a time (a plane read band
    by band from a file); the number does not depend on it.
    """
    values = _checked(values)
    band_rows = max(int(band_rows), 1)
    return max(_residual_sigma(values, scale, band_rows), dark_field_sigma(values, scale))


def _checked(plane):
    """``plane`` as an array, or as it is where it reads its rows itself: an array-like
    with ``shape``, ``ndim`` and ``plane[rows]`` for a slice or an integer array of rows
    (a plane read band by band from a file, ``io.bands.PlaneBands``)."""
    if not all(hasattr(plane, name) for name in ("shape", "ndim", "__getitem__")):
        plane = np.asarray(plane)
    if plane.ndim != 2:
        raise ValueError(f"a noise estimate takes a 2-D plane, got {plane.ndim} dimensions")
    return plane


def _rows(values: np.ndarray, rows, scale: ToneScale | None) -> np.ndarray:
    """``values[rows]`` as float64: the values, or their tones on ``scale``."""
    band = values[rows]
    if scale is None:
        return band.astype(np.float64)
    return scale.to_tones(band).astype(np.float64)


def _residual_sigma(values, scale: ToneScale | None, band_rows: int = _BAND_ROWS) -> float:
    """Immerkær's sigma of ``values`` (or of their tones on ``scale``), read ``band_rows``
    rows at a time and measured on ``_MEASURED_BYTES`` of float64 tones at a time (the
    tones and the mask's sums of a whole band would take many times its memory); the
    result depends on neither."""
    height, width = values.shape
    if height < 3 or width < 3:
        return 0.0
    measured = _measured_rows(width)
    row_sums, count = [], 0
    kept = None  # the last two rows of the band before: the rows above the next band's first
    for start in range(0, height, band_rows):
        band = values[start : min(height, start + band_rows)]  # each row read once
        if kept is not None:
            band = np.concatenate([kept, band])
        kept = band[-2:]
        for first in range(1, band.shape[0] - 1, measured):
            last = min(band.shape[0] - 1, first + measured)
            residual = _mask_residual(_rows(band, slice(first - 1, last + 1), scale))
            finite = np.isfinite(residual)
            row_sums.extend(np.abs(np.where(finite, residual, 0.0)).sum(axis=1).tolist())
            count += int(finite.sum())
    if count == 0:
        return 0.0
    # each row summed, then the rows' sums exactly (fsum): the same float64 for the same
    # values, whatever the bands of rows they were read in
    return math.fsum(row_sums) / count * _SIGMA_PER_RESIDUAL


def _measured_rows(width: int) -> int:
    """Rows of float64 tones measured at once: ``_MEASURED_BYTES`` of them, at most ``_BAND_ROWS``."""
    return max(1, min(_BAND_ROWS, _MEASURED_BYTES // (8 * width)))


def _mask_residual(rows: np.ndarray) -> np.ndarray:
    """The mask of the module's docstring over the interior of ``rows``."""
    above, middle, below = rows[:-2], rows[1:-1], rows[2:]
    corners = above[:, :-2] + above[:, 2:] + below[:, :-2] + below[:, 2:]
    sides = above[:, 1:-1] + below[:, 1:-1] + middle[:, :-2] + middle[:, 2:]
    return corners - 2 * sides + 4 * middle[:, 1:-1]


def dark_field_sigma(values: np.ndarray, scale: ToneScale) -> float:
    """The noise of the plane's dark field in tones, from the variance of Eq. 1 there.

    The pixels whose 8 neighbours' mean lies below ``DARK_TONE`` tones are the
    dark field; where they are at least ``MIN_DARK_SHARE`` of the plane, the
    ``DARK_QUANTILE`` quantile of their neighbours' variance V, divided by the
    same quantile for white noise of deviation 1 (``_QUANTILE_V``), is the
    noise's variance. A JPEG leaves little of a camera's noise at the highest
    frequencies, which Immerkær's mask reads, and more at the scale of its
    8 x 8 blocks, which V reads. That noise is correlated between neighbours,
    so V, the spread around the neighbours' own mean, reads less than the
    field's variance, and heavy-tailed: the median of V read 0.6 of the field's
    deviation on a JPEG of quality 80, the 90th percentile 0.97
    (``docs/study/noise-gate.md``). 0 without a dark field.

    Rows are sampled with a stride that keeps at most ``_SAMPLES`` pixels (the
    same rows for the same shape), so that a huge plane costs no more, and
    measured a few at a time (``_measured_rows``).
    """
    height, width = values.shape
    if height < 3 or width < 3:
        return 0.0
    stride = max(1, math.ceil((height - 2) * (width - 2) / _SAMPLES))
    rows = _measured_rows(width)
    variances = []
    dark_pixels = total = 0
    for start in range(1, height - 1, rows * stride):
        centres = np.arange(start, min(height - 1, start + rows * stride), stride)
        # the rows above, at and below the centres, in one read (a band read from a file
        # reads each chunk of rows it touches once)
        window = np.split(_rows(values, np.concatenate([centres - 1, centres, centres + 1]),
                                scale), 3)  # fmt: skip
        centre = window[1][:, 1:-1]
        # the 3 x 3 sums of the values and of their squares, less the centre's: Eq. 1's
        # sums over the 8 neighbours (in another order than the kernel's: an estimate)
        sums = _box(window[0] + window[1] + window[2]) - centre
        squares = _box(window[0] ** 2 + window[1] ** 2 + window[2] ** 2) - centre**2
        mean = sums / 8.0
        variance = np.maximum(squares / 8.0 - mean**2, 0.0)
        dark = (mean < DARK_TONE) & np.isfinite(variance)
        variances.append(variance[dark])
        dark_pixels += int(dark.sum())
        total += mean.size
    if dark_pixels == 0 or dark_pixels < MIN_DARK_SHARE * total:
        return 0.0
    variance = float(np.quantile(np.concatenate(variances), DARK_QUANTILE))
    return math.sqrt(variance / _QUANTILE_V)


def _box(columns: np.ndarray) -> np.ndarray:
    """Sums of three neighbouring columns: ``columns[:, x - 1] + columns[:, x] + columns[:, x + 1]``."""
    return columns[:, :-2] + columns[:, 1:-1] + columns[:, 2:]


#: Tones under which a neighbourhood's mean is dark (the study's dark regions: 20).
DARK_TONE = 20.0

#: The share of a plane's pixels that must be dark for its dark field to be measured.
MIN_DARK_SHARE = 0.05

#: The quantile of the dark field's V that :func:`dark_field_sigma` matches with white noise's:
#: high enough to read the tail of a JPEG's correlated, heavy-tailed noise, low enough that a
#: few edges among the dark pixels do not move it.
DARK_QUANTILE = 0.9

#: The ``DARK_QUANTILE`` quantile of V of Eq. 1 (8 neighbours) for white Gaussian noise of
#: deviation 1: 8 V is a chi-square of 7 degrees of freedom, whose 90th percentile is 12.0170.
_QUANTILE_V = 12.017037 / 8.0

#: Pixels :func:`dark_field_sigma` reads at most (rows sampled with a stride beyond).
_SAMPLES = 1 << 20


def variance_floor(noise_gate: float, sigma: float) -> float:
    """The local variance at or below which the noise gate leaves a pixel alone, in tones².

    ``(noise_gate * sigma) ** 2`` for a gate that is on; -1 (no variance is at
    or below it) for ``noise_gate == 0``, the gate off.
    """
    if noise_gate <= 0.0:
        return -1.0
    return float(noise_gate * sigma) ** 2
