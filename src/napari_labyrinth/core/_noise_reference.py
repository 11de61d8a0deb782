"""The noise estimate in numpy, as the noise gate measured it before its compiled loops:
the oracle of ``noise`` and ``_noise_loops``.

Each function is the numpy reading that ``noise.tone_noise_sigma``,
``noise.noise_sigma`` and ``noise.dark_field_sigma`` replaced, unchanged: the
tests require the two to give the same float64, bit for bit, on every plane
(``tests/core/test_noise_loops.py``). It shares no code with ``_noise_loops``;
the constants (what is measured) are ``noise``'s.

The cost that made it an oracle: every band of rows became float64 tones and a
dozen float64 temporaries of its size (the mask's sums, ``isfinite``,
``where``, ``abs``), and the dark field's sampled rows were made tones again:
about two thirds of a pass of the kernel over the plane (2048², uint8, one
thread), paid on every plane with the gate on.
"""

from __future__ import annotations

import math

import numpy as np

from . import noise as _noise
from .tone_scale import ToneScale


def tone_noise_sigma(values, scale: ToneScale, band_rows: int = _noise._BAND_ROWS) -> float:
    """``noise.tone_noise_sigma``: the larger of :func:`residual_sigma` and
    :func:`dark_field_sigma` on the tones of ``scale``."""
    values = _noise._checked(values)
    band_rows = max(int(band_rows), 1)
    return max(residual_sigma(values, scale, band_rows), dark_field_sigma(values, scale))


def noise_sigma(plane) -> float:
    """``noise.noise_sigma``: Immerkær's sigma of the values themselves."""
    return residual_sigma(_noise._checked(plane), None)


def _rows(values: np.ndarray, rows, scale: ToneScale | None) -> np.ndarray:
    """``values[rows]`` as float64: the values, or their tones on ``scale``."""
    band = values[rows]
    if scale is None:
        return band.astype(np.float64)
    return scale.to_tones(band).astype(np.float64)


def residual_sigma(values, scale: ToneScale | None, band_rows: int = _noise._BAND_ROWS) -> float:
    """Immerkær's sigma of ``values`` (or of their tones on ``scale``), read ``band_rows``
    rows at a time and measured on ``_MEASURED_BYTES`` of float64 tones at a time; the
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
    return math.fsum(row_sums) / count * _noise._SIGMA_PER_RESIDUAL


#: Bytes of float64 tones convolved at once, at most (fewer rows of a wide plane).
_MEASURED_BYTES = 4 << 20


def _measured_rows(width: int) -> int:
    """Rows of float64 tones measured at once: ``_MEASURED_BYTES`` of them, at most
    ``_BAND_ROWS``."""
    return max(1, min(_noise._BAND_ROWS, _MEASURED_BYTES // (8 * width)))


def _mask_residual(rows: np.ndarray) -> np.ndarray:
    """The mask of ``noise``'s docstring over the interior of ``rows``."""
    above, middle, below = rows[:-2], rows[1:-1], rows[2:]
    corners = above[:, :-2] + above[:, 2:] + below[:, :-2] + below[:, 2:]
    sides = above[:, 1:-1] + below[:, 1:-1] + middle[:, :-2] + middle[:, 2:]
    return corners - 2 * sides + 4 * middle[:, 1:-1]


def dark_field_sigma(values: np.ndarray, scale: ToneScale) -> float:
    """``noise.dark_field_sigma``: the ``DARK_QUANTILE`` quantile of V over the sampled
    rows' dark pixels (``np.quantile``), matched with white noise's."""
    height, width = values.shape
    if height < 3 or width < 3:
        return 0.0
    stride = _noise.dark_stride(height, width)
    rows = _measured_rows(width)
    variances = []
    dark_pixels = total = 0
    for start in range(1, height - 1, rows * stride):
        centres = np.arange(start, min(height - 1, start + rows * stride), stride)
        # the rows above, at and below the centres, in one read
        window = np.split(_rows(values, np.concatenate([centres - 1, centres, centres + 1]),
                                scale), 3)  # fmt: skip
        centre = window[1][:, 1:-1]
        # the 3 x 3 sums of the values and of their squares, less the centre's: Eq. 1's
        # sums over the 8 neighbours (in another order than the kernel's: an estimate)
        sums = _box(window[0] + window[1] + window[2]) - centre
        squares = _box(window[0] ** 2 + window[1] ** 2 + window[2] ** 2) - centre**2
        mean = sums / 8.0
        variance = np.maximum(squares / 8.0 - mean**2, 0.0)
        dark = (mean < _noise.DARK_TONE) & np.isfinite(variance)
        variances.append(variance[dark])
        dark_pixels += int(dark.sum())
        total += mean.size
    if dark_pixels == 0 or dark_pixels < _noise.MIN_DARK_SHARE * total:
        return 0.0
    variance = float(np.quantile(np.concatenate(variances), _noise.DARK_QUANTILE))
    return math.sqrt(variance / _noise._QUANTILE_V)


def _box(columns: np.ndarray) -> np.ndarray:
    """Sums of three neighbouring columns:
    ``columns[:, x - 1] + columns[:, x] + columns[:, x + 1]``."""
    return columns[:, :-2] + columns[:, 1:-1] + columns[:, 2:]
