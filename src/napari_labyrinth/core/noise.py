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

Each row's residuals are summed on their own and the rows' sums exactly, so
that every path that renders a plane (whole, in bands, in tiles, in blocks of
a dask image, on several threads) gets the same number from the same values.
A JPEG's noise is mostly at the scale of its blocks, where Immerkær's mask
reads little of it: the noise gate takes the larger of this estimate and the
dark field's (:func:`dark_field_sigma`).

Both are measured in one sweep over the plane's tones, a band of rows at a
time (``_noise_loops``), with the arithmetic of the numpy reading they
replaced (``_noise_reference``, the tests' oracle), bit for bit.

References
----------
J. Immerkær, "Fast noise variance estimation", Computer Vision and Image
Understanding 64 (2), 300-302 (1996).
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np

from .._threads import run_shares
from .tone_scale import ToneScale, integer_scale

#: ``sqrt(pi / 2) / 6``: the mean absolute residual of the mask times this is sigma.
_SIGMA_PER_RESIDUAL = math.sqrt(math.pi / 2.0) / 6.0

#: Rows of the plane read at once by default (a plane read band by band from a file).
_BAND_ROWS = 256

#: Bytes of tones made and measured at once, at most: a band of rows that stays in a
#: core's own cache between the two.
_TONE_BYTES = 1 << 20

#: Rows and pixels of a thread's share of a plane, at least: a thread costs more than
#: a smaller one.
_MIN_THREAD_ROWS = 64
_MIN_THREAD_PIXELS = 1 << 17


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
    return _measure(_checked(plane), None, _BAND_ROWS, dark=False).residual_sigma()


def tone_noise_sigma(
    values, scale: ToneScale, band_rows: int = _BAND_ROWS, workers: int = 1
) -> float:
    """The noise of the plane ``values`` in the tones of ``scale``, which the noise gate
    compares the local variance with: the larger of Immerkær's estimate
    (:func:`noise_sigma`) and :func:`dark_field_sigma`, both read on the tones
    the kernel sees (``scale.to_tones``), in one sweep over the plane.

    This is the one place a rendering measures a plane's noise: every path
    that renders the plane (or a plane of the same tones) gets the same number.
    ``band_rows`` bounds the rows read and held at a time (a plane read band
    by band from a file); ``workers`` threads share the rows of a plane held
    in memory. The number depends on neither.
    """
    values = _checked(values)
    measures = _measure(values, scale, max(int(band_rows), 1), dark=True, workers=workers)
    return max(measures.residual_sigma(), measures.dark_sigma())


def _checked(plane):
    """``plane`` as an array, or as it is where it reads its rows itself: an array-like
    with ``shape``, ``ndim`` and ``plane[rows]`` for a slice of rows (a plane read band
    by band from a file, ``io.bands.PlaneBands``)."""
    if not all(hasattr(plane, name) for name in ("shape", "ndim", "__getitem__")):
        plane = np.asarray(plane)
    if plane.ndim != 2:
        raise ValueError(f"a noise estimate takes a 2-D plane, got {plane.ndim} dimensions")
    return plane


def dark_stride(height: int, width: int) -> int:
    """The stride of the rows :func:`dark_field_sigma` samples: at most ``_SAMPLES``
    pixels, the same rows for the same shape."""
    return max(1, math.ceil((height - 2) * (width - 2) / _SAMPLES))


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

    Rows are sampled with a stride that keeps at most ``_SAMPLES`` pixels
    (:func:`dark_stride`), so that a huge plane costs no more. V is computed
    as the sums of the tones and of their squares over the 3 x 3 window less
    the centre's (Eq. 1's sums in another order than the kernel's: an
    estimate), and the quantile is ``np.quantile``'s (linear), bit for bit.
    """
    return _measure(_checked(values), scale, _BAND_ROWS, dark=True).dark_sigma()


@dataclasses.dataclass
class _Measures:
    """What one sweep over a plane found (``_noise_loops``): each interior row's sum of
    absolute residuals, the finite residuals, the dark field's sampled pixels, and its
    dark ones' V: ``variances[starts[i]:ends[i]]`` counted by ``histogram`` (the bins
    of ``_noise_loops.band_noise``), or for uint8 values on the scale (0, 255) only
    counted, by ``64 V`` (``paper_histogram``, ``_noise_loops.paper_band_noise``)."""

    row_sums: np.ndarray
    finite: int = 0
    sampled: int = 0
    dark: int = 0
    variances: np.ndarray | None = None
    starts: np.ndarray | None = None
    ends: np.ndarray | None = None
    histogram: np.ndarray | None = None
    paper_histogram: np.ndarray | None = None

    def residual_sigma(self) -> float:
        """Immerkær's sigma: the mean absolute residual times ``_SIGMA_PER_RESIDUAL``."""
        if self.finite == 0:
            return 0.0
        # each row summed, then the rows' sums exactly (fsum): the same float64 for the
        # same values, whatever the bands of rows and the threads they were measured in
        return math.fsum(self.row_sums[1:-1].tolist()) / self.finite * _SIGMA_PER_RESIDUAL

    def dark_sigma(self) -> float:
        """:func:`dark_field_sigma` of the sweep: 0 without a dark field."""
        if self.dark == 0 or self.dark < MIN_DARK_SHARE * self.sampled:
            return 0.0
        return math.sqrt(self._quantile() / _QUANTILE_V)

    def _quantile(self) -> float:
        """``np.quantile`` of the dark V's at ``DARK_QUANTILE`` (method "linear"), bit for
        bit: the two values of neighbouring ranks it interpolates between, and its
        interpolation."""
        from . import _noise_loops  # numba is imported on first use only

        n = self.dark
        virtual = (n - 1) * DARK_QUANTILE
        below = math.floor(virtual)
        if self.paper_histogram is not None:
            low, high = _noise_loops.paper_ranked_values(self.paper_histogram, below)
        else:
            low, high = _noise_loops.ranked_values(
                self.variances, self.starts, self.ends, self.histogram, below
            )
        low, high = float(low), float(high)
        if virtual >= n - 1:  # the last value
            return high
        gamma = virtual - below
        difference = high - low
        if gamma >= 0.5:  # numpy's _lerp: from the upper value
            return high - difference * (1 - gamma)
        return low + difference * gamma


def _measure(values, scale: ToneScale | None, band_rows: int, *, dark: bool, workers: int = 1):
    """One sweep over the plane ``values`` (its tones on ``scale``; None: the values as
    float64): :class:`_Measures`. ``workers`` threads take a share of the rows each,
    a plane held in memory only."""
    height, width = values.shape
    measures = _Measures(np.zeros(max(height, 2), np.float64))
    if height < 3 or width < 3:
        return measures
    from . import _noise_loops  # numba is imported on first use only

    stride = dark_stride(height, width) if dark else 0
    shares = min((height - 2) // _MIN_THREAD_ROWS, height * width // _MIN_THREAD_PIXELS)
    workers = max(1, min(int(workers), shares))
    if not isinstance(values, np.ndarray):
        workers = 1  # read band by band, in order
    # uint8 values on the scale (0, 255), their own tones: measured in integers (a
    # strided view of them: its tones made band by band)
    paper = scale is not None and values.dtype == np.uint8
    paper = paper and integer_scale(scale, np.uint8).paper_uint8
    paper = paper and (values.flags.c_contiguous if isinstance(values, np.ndarray) else True)
    # the interior rows, a share a thread; each share's sampled rows have their room
    bounds = [1 + round(k * (height - 2) / workers) for k in range(workers + 1)]
    inner = width - 2
    sampled = [inner * _sampled_before(bound, stride) for bound in bounds]
    if paper:
        histograms = [np.zeros(_noise_loops.PAPER_BINS, np.int64) for _ in range(workers)]
        variances = None
    else:
        histograms = [np.zeros(_noise_loops.HISTOGRAM_BINS, np.int64) for _ in range(workers)]
        variances = np.empty(max(1, sampled[-1]), np.float64)
    counts = [np.array([0, 0, 0 if paper else sampled[k]], np.int64) for k in range(workers)]
    measure = _measure_paper_rows if paper else _measure_rows
    share = (values, scale, band_rows, stride, measures.row_sums, variances)

    def run(k):
        first = 0 if k == 0 else bounds[k] - 1
        last = height if k == workers - 1 else bounds[k + 1] + 1
        measure(*share, first, last, histograms[k], counts[k])

    run_shares(run, workers)
    measures.finite = sum(int(c[0]) for c in counts)
    measures.sampled = sum(int(c[1]) for c in counts)
    if not stride:
        return measures
    histogram = histograms[0]
    for other in histograms[1:]:
        histogram += other
    if paper:
        measures.dark = sum(int(c[2]) for c in counts)
        measures.paper_histogram = histogram
    else:
        measures.starts = np.array(sampled[:-1], np.int64)
        measures.ends = np.array([int(c[2]) for c in counts], np.int64)
        measures.dark = int((measures.ends - measures.starts).sum())
        measures.variances, measures.histogram = variances, histogram
    return measures


def _sampled_before(row: int, stride: int) -> int:
    """The dark field's sampled rows ``1, 1 + stride, ...`` before ``row``; 0 without."""
    return 0 if stride <= 0 else max(0, (row - 1 + stride - 1) // stride)


def _measure_rows(values, scale, band_rows, stride, row_sums, variances, start, stop, histogram,
                  counts):  # fmt: skip
    """``_noise_loops.band_noise`` over the rows ``start <= y < stop`` of ``values`` (the
    rows ``start < y < stop - 1`` measured), read ``band_rows`` rows at a time from
    ``start``, made tones ``_TONE_BYTES`` at a time with the two rows above."""
    from ._noise_loops import band_noise  # numba is imported on first use only
    from ._tone_loops import integer_tones

    width = values.shape[1]
    dtype = np.float64 if scale is None else np.float32
    rows = max(1, _TONE_BYTES // (np.dtype(dtype).itemsize * width))
    tones = np.empty((rows + 2, width), dtype)
    fused = None
    if scale is not None and values.dtype.kind in "iu":
        fused = integer_scale(scale, values.dtype)
    kept = 0  # rows at the top of ``tones``: the last two of the rows before
    for band_start in range(start, stop, band_rows):
        band = values[band_start : min(stop, band_start + band_rows)]  # each row read once
        for first in range(0, band.shape[0], rows):
            piece = band[first : first + rows]
            made = tones[kept : kept + piece.shape[0]]
            if scale is None:
                made[...] = piece
            elif fused is not None and piece.flags.c_contiguous:
                integer_tones(piece, made, fused)
            else:
                made[...] = scale.to_tones(piece)
            held = kept + piece.shape[0]
            band_noise(tones[:held], band_start + first - kept, stride, row_sums, variances,
                       histogram, counts)  # fmt: skip
            kept = min(2, held)
            tones[:kept] = tones[held - kept : held]


def _measure_paper_rows(values, scale, band_rows, stride, row_sums, variances, start, stop,
                        histogram, counts):  # fmt: skip
    """``_noise_loops.paper_band_noise`` over the rows ``start <= y < stop`` of uint8
    ``values`` on the scale (0, 255) (their own tones), as :func:`_measure_rows`: a plane
    in memory in one call, one read band by band with the two rows above each band."""
    from ._noise_loops import paper_band_noise  # numba is imported on first use only

    if isinstance(values, np.ndarray):
        paper_band_noise(values[start:stop], start, stride, row_sums, histogram, counts)
        return
    kept = None
    for band_start in range(start, stop, band_rows):
        band = np.ascontiguousarray(values[band_start : min(stop, band_start + band_rows)])
        first = band_start
        if kept is not None:
            band, first = np.concatenate([kept, band]), band_start - kept.shape[0]
        paper_band_noise(band, first, stride, row_sums, histogram, counts)
        kept = band[-2:]


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
