"""Numba loops of the noise estimate (``noise``): one sweep over a plane's tones.

- ``band_noise``: over a band of rows of tones, Immerkær's residuals of every
  row it holds the neighbours of, summed row by row, and the dark field's V of
  Eq. 1 on the sampled rows among them (each dark pixel's V noted, and counted
  in a histogram of its leading bits);
- ``ranked_values``: the two values of neighbouring ranks of the noted V's,
  which the ``DARK_QUANTILE`` quantile interpolates between, found from that
  histogram without sorting them.

Each loop does the arithmetic of the numpy reading it replaced
(``_noise_reference``) in the same precision and order: the float64 sums of a
row are numpy's pairwise summation (:func:`pairwise_sum`), the dark field's
sums those of its column sums, so that the noise, and the pixels the gate
leaves, are bit for bit the same (``tests/core/test_noise_loops.py``).
"""

import numpy as np
from numba import njit

from ._jit import cached_njit

#: numpy's ``PW_BLOCKSIZE``: rows of at most this many values are summed in 8 lanes.
_PAIRWISE_BLOCK = 128

#: A noted V's histogram bin: its float64 bits shifted right by this many (sign, the
#: exponent and 4 bits of the mantissa: 16 bins an octave).
HISTOGRAM_SHIFT = 48

#: Bins of the histogram of V (non-negative float64: the sign bit is 0).
HISTOGRAM_BINS = 1 << (63 - HISTOGRAM_SHIFT)

#: Tones under which a neighbourhood's mean is dark (``noise.DARK_TONE``, which must
#: equal it: the tests check).
DARK_TONE = 20.0


@njit
def pairwise_sum(values, start, n, stack):
    """``values[start:start + n]`` summed as numpy sums a contiguous float64 row
    (``np.add.reduce``'s pairwise summation: 8 lanes in blocks of up to 128 values,
    halves of a multiple of 8 above, the halves' sums added).

    numpy recurses into the halves; here a stack of them is walked (a numba
    function that calls itself is loaded from numba's cache broken): ``stack`` is
    room for it, a (4, 64) float64 array (positions and sizes are exact there).
    """
    if n <= _PAIRWISE_BLOCK:
        return _block_sum(values, start, n)
    # the halves under way: their start, size, whether the first half is summed, its sum
    starts, sizes, first_done, first_sums = stack[0], stack[1], stack[2], stack[3]
    top = 0
    starts[0], sizes[0] = start, n
    while True:
        size = np.int64(sizes[top])
        if size > _PAIRWISE_BLOCK:  # split: the first half next
            half = size // 2
            half -= half % 8
            first_done[top] = 0.0
            starts[top + 1], sizes[top + 1] = starts[top], half
            top += 1
            continue
        total = _block_sum(values, np.int64(starts[top]), size)
        while True:  # hand the sum up to the halves it completes
            top -= 1
            if top < 0:
                return total
            if first_done[top] == 0.0:  # the first half: the second one next
                first_done[top], first_sums[top] = 1.0, total
                half = np.int64(sizes[top]) // 2
                half -= half % 8
                starts[top + 1], sizes[top + 1] = starts[top] + half, sizes[top] - half
                top += 1
                break
            total = first_sums[top] + total


@njit
def _block_sum(values, start, n):
    """numpy's sum of at most ``_PAIRWISE_BLOCK`` values: in order below 8, else 8 lanes."""
    if n < 8:
        total = -0.0  # numpy's start: a row of -0.0 sums to -0.0
        for i in range(start, start + n):
            total += values[i]
        return total
    r0, r1, r2, r3 = values[start], values[start + 1], values[start + 2], values[start + 3]
    r4, r5, r6, r7 = values[start + 4], values[start + 5], values[start + 6], values[start + 7]
    i = start + 8
    stop = start + n - n % 8
    while i < stop:
        r0 += values[i]
        r1 += values[i + 1]
        r2 += values[i + 2]
        r3 += values[i + 3]
        r4 += values[i + 4]
        r5 += values[i + 5]
        r6 += values[i + 6]
        r7 += values[i + 7]
        i += 8
    total = ((r0 + r1) + (r2 + r3)) + ((r4 + r5) + (r6 + r7))
    while i < start + n:
        total += values[i]
        i += 1
    return total


@cached_njit(nogil=True)
def band_noise(tones, first_row, stride, row_sums, variances, histogram, counts):
    """Immerkær's residuals and the dark field's V over a band of rows of tones.

    Parameters
    ----------
    tones : (R, W) float32 or float64 C-contiguous array
        The rows ``first_row .. first_row + R - 1`` of a plane (tones, or values).
        The rows whose two neighbours it holds are measured:
        ``first_row < y < first_row + R - 1``.
    first_row : int
    stride : int
        The dark field's sampled rows are those with ``(y - 1) % stride == 0``;
        0: no dark field.
    row_sums : (H,) float64 array
        ``row_sums[y]``: the sum of the row's absolute residuals (the mask of
        ``noise``'s docstring, non-finite ones counted as 0), as numpy sums it.
    variances : float64 array
        Each dark pixel's V of Eq. 1 (over its 8 neighbours, as
        ``_noise_reference.dark_field_sigma`` computes it) is written at
        ``counts[2]``, which counts them: room for one a sampled pixel.
    histogram : (HISTOGRAM_BINS,) int64 array
        Incremented at the bin of every V noted (its bits >> ``HISTOGRAM_SHIFT``).
    counts : (3,) int64 array
        Incremented: the finite residuals, the sampled pixels, the dark ones.
    """
    rows, width = tones.shape
    inner = width - 2
    if inner < 1 or rows < 3:
        return
    # three rows of the band in float64, each converted once, taken in turn
    above, middle, below = np.empty(width), np.empty(width), np.empty(width)
    _as_float64(tones[0], above)
    _as_float64(tones[1], middle)
    magnitudes = np.empty(inner, np.float64)
    stack = np.empty((4, 64), np.float64)  # pairwise_sum's
    columns, column_squares = np.empty(width), np.empty(width)
    means, dark_variances = np.empty(inner), np.empty(inner)
    finite_count = 0
    noted = counts[2]
    bits = variances.view(np.int64)  # a non-negative float64's bits rise with it
    for k in range(1, rows - 1):
        y = first_row + k
        _as_float64(tones[k + 1], below)
        row_finite = 0
        for x in range(inner):
            # the mask in the order of the numpy reading: corners, sides, centre
            corners = ((above[x] + above[x + 2]) + below[x]) + below[x + 2]
            sides = ((above[x + 1] + below[x + 1]) + middle[x]) + middle[x + 2]
            residual = (corners - 2.0 * sides) + 4.0 * middle[x + 1]
            magnitude = abs(residual)
            finite = magnitude < np.inf  # False for NaN
            magnitudes[x] = magnitude if finite else 0.0
            row_finite += finite
        finite_count += row_finite
        row_sums[y] = pairwise_sum(magnitudes, 0, inner, stack)
        if stride > 0 and (y - 1) % stride == 0:
            # the dark field: the 3 x 3 sums of the tones and of their squares, less the
            # centre's, from the column sums (above + middle) + below; every pixel's mean
            # and V first, then the dark ones noted
            for x in range(width):
                columns[x] = (above[x] + middle[x]) + below[x]
                column_squares[x] = (above[x] * above[x] + middle[x] * middle[x]) + (
                    below[x] * below[x]
                )
            for x in range(inner):
                centre = middle[x + 1]
                sums = ((columns[x] + columns[x + 1]) + columns[x + 2]) - centre
                squares = (column_squares[x] + column_squares[x + 1]) + column_squares[x + 2]
                squares = squares - centre * centre
                mean = sums / 8.0
                variance = squares / 8.0 - mean * mean
                # np.maximum(variance, 0.0): NaN stays NaN
                dark_variances[x] = 0.0 if variance < 0.0 else variance
                means[x] = mean
            counts[1] += inner
            for x in range(inner):
                variance = dark_variances[x]
                variances[noted] = variance  # kept only if dark: written anyway (no branch)
                if means[x] < DARK_TONE and abs(variance) < np.inf:
                    histogram[bits[noted] >> HISTOGRAM_SHIFT] += 1
                    noted += 1
        above, middle, below = middle, below, above
    counts[0] += finite_count
    counts[2] = noted


@njit
def _as_float64(row, out):
    """``out[:] = row`` (a row of float32 or float64 tones), as a plain loop."""
    for x in range(row.shape[0]):
        out[x] = np.float64(row[x])


@cached_njit(nogil=True)
def ranked_values(variances, starts, ends, histogram, rank):
    """The values of ranks ``rank`` and ``rank + 1`` (from 0; the last rank for a rank
    past it) in ascending order of the V's ``variances[starts[i]:ends[i]]``, all of
    them, as ``np.partition`` places them.

    ``histogram`` counts them by the bins of ``band_noise``. The bins before the
    one holding ``rank`` are passed by their counts; the values of that bin and of
    the next non-empty one are copied out, and each rank's value is found among
    them a byte of its bits at a time (:func:`_value_of_rank`): no sort, whatever
    the ties.
    """
    total = 0
    for i in range(starts.shape[0]):
        total += ends[i] - starts[i]
    last = total - 1
    low_rank, high_rank = min(rank, last), min(rank + 1, last)
    before = low_before = 0
    low_bin = high_bin = -1
    for b in range(histogram.shape[0]):
        count = histogram[b]
        if low_bin < 0 and before + count > low_rank:
            low_bin, low_before = b, before
        if before + count > high_rank:
            high_bin = b
            break
        before += count
    size = histogram[low_bin] + (histogram[high_bin] if high_bin != low_bin else 0)
    chosen = np.empty(size, np.int64)
    bits = variances.view(np.int64)  # a non-negative float64's bits rise with it
    taken = 0
    for i in range(starts.shape[0]):
        for j in range(starts[i], ends[i]):
            b = bits[j] >> HISTOGRAM_SHIFT
            if b == low_bin or b == high_bin:
                chosen[taken] = bits[j]
                taken += 1
    low = _value_of_rank(chosen, low_rank - low_before)
    high = _value_of_rank(chosen, high_rank - low_before)
    pair = np.array([low, high], np.int64)
    values = pair.view(np.float64)
    return values[0], values[1]


@njit
def _value_of_rank(bits, rank):
    """The value of rank ``rank`` (from 0) in ascending order of the non-negative int64
    ``bits``: a radix selection, a byte at a time from the highest."""
    candidates = bits
    for shift in range(56, -8, -8):
        counts = np.zeros(256, np.int64)
        for value in candidates:
            counts[(value >> shift) & 255] += 1
        digit = 0
        while rank >= counts[digit]:
            rank -= counts[digit]
            digit += 1
        if counts[digit] == candidates.shape[0]:
            continue  # all of them share this byte
        kept = np.empty(counts[digit], np.int64)
        taken = 0
        for value in candidates:
            if (value >> shift) & 255 == digit:
                kept[taken] = value
                taken += 1
        candidates = kept
    return candidates[0]


#: Residuals a row's sum holds in 32 bits (each at most 2040). (A loop over the row in
#: pieces of this many instead compiled badly for a processor with AVX-512: 3x slower.)
_SUMMED_IN_32_BITS = (1 << 31) // 2040


#: Bins of :func:`paper_band_noise`'s histogram of ``8 Q - S**2`` over the dark pixels:
#: at most ``7 * (8 * DARK_TONE - 1)**2`` (all of S on one neighbour), plus one.
PAPER_BINS = 7 * (8 * int(DARK_TONE) - 1) ** 2 + 1


@cached_njit(nogil=True)
def paper_band_noise(values, first_row, stride, row_sums, histogram, counts):
    """:func:`band_noise` of uint8 values on the scale (0, 255), whose tones are the
    values: in integers, which give the float64 of the numpy reading exactly.

    A tone is then an integer from 0 to 255, and every float64 the numpy reading
    makes of a row holds an integer under 2**53: the mask's residual (at most
    8 * 255 either way), the row's sum (pairwise or not: exact) and, for the dark field, the
    sums S and Q of the 8 neighbours' tones and of their squares. Its V is
    ``Q / 8 - (S / 8)**2 = (8 Q - S**2) / 64`` exactly (a multiple of 1/64 under
    2**20: no rounding, and never below 0), and a pixel is dark where
    ``S / 8 < DARK_TONE``, ``S < 8 * DARK_TONE``. So the dark V's are counted by
    ``8 Q - S**2`` in ``histogram`` (:data:`PAPER_BINS`), which their quantile is
    read from (:func:`paper_ranked_values`); none is kept.

    ``values`` is a (R, W) uint8 C-contiguous array of the rows ``first_row ..``;
    ``row_sums``, ``stride`` and ``counts`` as for :func:`band_noise` (``counts[2]``
    counts the dark pixels).
    """
    rows, width = values.shape
    inner = width - 2
    if inner < 1 or rows < 3:
        return
    vertical = np.empty(width, np.int16)
    magnitudes = np.empty(inner, np.int16)
    columns, sums = np.empty(width, np.int16), np.empty(inner, np.int16)
    column_squares, squares = np.empty(width, np.int32), np.empty(inner, np.int32)
    dark_sum = np.int16(8 * DARK_TONE)
    dark = 0
    for k in range(1, rows - 1):
        y = first_row + k
        above, middle, below = values[k - 1], values[k + 0], values[k + 1]
        # the mask is the product of two second differences, [1, -2, 1] down the columns
        # and across the rows: in integers, the same sum as the numpy reading's corners,
        # sides and centre. Every step is within +-2040: 16-bit integers (numba would
        # widen them to 64 bits, a quarter of the lanes), each cut back to them
        for x in range(width):
            vertical[x] = np.int16(np.int16(above[x]) + np.int16(below[x])) - np.int16(
                2 * np.int16(middle[x])
            )
        for x in range(inner):
            residual = np.int16(vertical[x] + vertical[x + 2])
            residual = np.int16(residual - np.int16(2 * vertical[x + 1]))
            magnitudes[x] = residual if residual >= 0 else np.int16(-residual)
        if inner < _SUMMED_IN_32_BITS:  # a row's sum fits 32 bits (and so runs in more lanes)
            part = np.int32(0)
            for x in range(inner):
                part += np.int32(magnitudes[x])
            total = np.int64(part)
        else:
            total = np.int64(0)
            for x in range(inner):
                total += magnitudes[x]
        row_sums[y] = np.float64(total)
        if stride <= 0 or (y - 1) % stride != 0:
            continue
        # S and Q of every pixel of the row first (in 16 and 32 bits: more lanes), then the
        # dark ones counted
        for x in range(width):
            a, m, b = np.int32(above[x]), np.int32(middle[x]), np.int32(below[x])
            columns[x] = np.int16(np.int16(above[x]) + np.int16(middle[x])) + np.int16(below[x])
            column_squares[x] = np.int32(a * a + m * m) + np.int32(b * b)
        for x in range(inner):
            centre = np.int32(middle[x + 1])
            sums[x] = np.int16(np.int16(columns[x] + columns[x + 1]) + columns[x + 2]) - np.int16(
                centre
            )
            squares[x] = np.int32(column_squares[x] + column_squares[x + 1]) + np.int32(
                column_squares[x + 2] - centre * centre
            )
        counts[1] += inner
        for x in range(inner):
            if sums[x] < dark_sum:
                histogram[8 * np.int64(squares[x]) - np.int64(sums[x]) * sums[x]] += 1
                dark += 1
    counts[0] += (rows - 2) * inner
    counts[2] += dark


@cached_njit(nogil=True)
def paper_ranked_values(histogram, rank):
    """The V's of ranks ``rank`` and ``rank + 1`` (the last for a rank past it) among the
    dark pixels counted by :func:`paper_band_noise`: ``bin / 64``, exactly the float64
    the numpy reading computed."""
    total = 0
    for b in range(histogram.shape[0]):
        total += histogram[b]
    last = total - 1
    low_rank, high_rank = min(rank, last), min(rank + 1, last)
    before = 0
    low = high = -1
    for b in range(histogram.shape[0]):
        before += histogram[b]
        if low < 0 and before > low_rank:
            low = b
        if before > high_rank:
            high = b
            break
    return low / 64.0, high / 64.0
