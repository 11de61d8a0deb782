"""Numba loops of the tone scale for integer planes: one pass over the data each.

- ``count_values``: the histogram of 8- and 16-bit integers, from which
  ``percentiles.integer_percentiles`` takes the default tone limits exactly;
- ``sampled_tail_values``: the same limits in one sweep, counted in
  windows of values that a sample places around them;
- ``block_extremes`` and ``count_tails``: the same limits from the few
  blocks of values that can hold them (``percentiles`` says when), both
  run, with the steps between them, by ``tail_values``;
- ``integer_tones``: the 0-255 tones of a plane, as ``ToneScale.to_tones``;
- ``write_back``: the values of the tones that changed, as
  ``ToneScale.from_tones``, written over the source values in place, with no
  mask and no temporary array; a tone has changed where its bits differ from
  those of the source value's tone, computed again (nothing else is kept);
- ``write_back_at``: the same at listed pixels only (those a pass wrote);
- ``rounded_tones``: the same for uint8 on the paper's own scale (0, 255),
  where a tone *is* its value: every tone is rounded back, changed or not.

Each loop does the arithmetic of its numpy counterpart in the same precision
and order (float32 for 8- and 16-bit values, float64 for 32-bit ones), so the
results are bit for bit the same; ``tests/_engine/test_render_loop.py`` checks it.
"""

import math

import numpy as np
from numba import njit

from ._jit import cached_njit
from ._kernel import prefetch_flat

# the loops' arguments: imported here, their file is part of the loops' cache stamp
from ._kernel_arguments import IntegerScale  # noqa: F401


@cached_njit(nogil=True)
def count_values(flat, offset, counts):
    """Add to ``counts[v - offset]`` one for every value v of the 1-D array ``flat``.

    Four tables take every fourth value: a run of equal values (common in an
    image) then increments four counters in turn instead of one counter after
    itself, which waits for its own previous increment.
    """
    for start in range(0, flat.shape[0], _COUNT_BLOCK):
        _count_block(flat[start : start + _COUNT_BLOCK], offset, counts)


#: Values counted at most at a time into uint32 tables (none overflows).
_COUNT_BLOCK = 1 << 31


@njit(nogil=True)
def _count_block(flat, offset, counts):
    size = counts.shape[0]
    first, second = np.zeros(size, np.uint32), np.zeros(size, np.uint32)
    third, fourth = np.zeros(size, np.uint32), np.zeros(size, np.uint32)
    quads = flat.shape[0] // 4 * 4
    for i in range(0, quads, 4):
        first[np.intp(flat[i]) - offset] += 1
        second[np.intp(flat[i + 1]) - offset] += 1
        third[np.intp(flat[i + 2]) - offset] += 1
        fourth[np.intp(flat[i + 3]) - offset] += 1
    for i in range(quads, flat.shape[0]):
        first[np.intp(flat[i]) - offset] += 1
    for k in range(size):
        counts[k] += np.int64(first[k]) + np.int64(second[k]) + np.int64(third[k])
        counts[k] += np.int64(fourth[k])


#: Values in a block of ``block_extremes``: few, so that the tails' blocks are few.
EXTREMES_BLOCK = 64


@njit(inline="always")
def _extremes(chunk, size):
    """The least and greatest of ``chunk[:size]`` (a known ``size``: a vector reduction)."""
    low = high = chunk[0]
    for i in range(size):
        low = min(low, chunk[i])
        high = max(high, chunk[i])
    return low, high


@cached_njit(nogil=True)
def block_extremes(flat, offset, shift, below, above):
    """The least and greatest value of every ``EXTREMES_BLOCK`` values of ``flat``.

    Returns ``(least, greatest)``, one entry a block (the last may be
    shorter). ``below[k]`` is incremented for every block whose least value
    lies in the coarse bin k, ``(v - offset) >> shift``, ``above[k]`` for
    every block whose greatest value does.
    """
    n = flat.shape[0]
    blocks = (n + EXTREMES_BLOCK - 1) // EXTREMES_BLOCK
    least, greatest = np.empty(blocks, flat.dtype), np.empty(blocks, flat.dtype)
    for b in range(blocks):
        chunk = flat[b * EXTREMES_BLOCK : (b + 1) * EXTREMES_BLOCK]
        if chunk.shape[0] == EXTREMES_BLOCK:
            least[b], greatest[b] = _extremes(chunk, EXTREMES_BLOCK)
        else:
            least[b], greatest[b] = _extremes(chunk, chunk.shape[0])
    for b in range(blocks):
        below[(np.intp(least[b]) - offset) >> shift] += 1
        above[(np.intp(greatest[b]) - offset) >> shift] += 1
    return least, greatest


@cached_njit(nogil=True)
def count_tails(flat, least, greatest, low_stop, low_start, low_counts, high_start, high_counts):
    """Count the values below ``low_stop`` and those from ``high_start`` on.

    ``low_counts[i % 4, v - low_start]`` for ``v = flat[i] < low_stop``
    (``low_start`` is the least value of ``flat``), ``high_counts[i % 4, v -
    high_start]`` for ``v >= high_start`` (sum the four rows); only the
    blocks whose extremes (``block_extremes``) reach a tail are read, each
    asked from memory a few blocks ahead (the processor cannot foresee which).
    """
    n = flat.shape[0]
    visited = np.empty(least.shape[0], np.intp)
    count = 0
    for b in range(least.shape[0]):
        visited[count] = b
        count += np.intp(least[b]) < low_stop or np.intp(greatest[b]) >= high_start
    for k in range(count):
        if k + _AHEAD < count:
            ahead = visited[k + _AHEAD] * EXTREMES_BLOCK
            prefetch_flat(flat, ahead)
            prefetch_flat(flat, min(n - 1, ahead + EXTREMES_BLOCK - 1))
        b = visited[k]
        start = b * EXTREMES_BLOCK
        stop = min(n, start + EXTREMES_BLOCK)
        # four tables take every fourth value (as count_values): a run of equal
        # values does not wait on its own increments
        if np.intp(least[b]) < low_stop:
            _count_below(flat, start, stop, low_stop, low_start, low_counts)
        if np.intp(greatest[b]) >= high_start:
            _count_from(flat, start, stop, high_start, high_counts)


@njit(inline="always")
def _count_below(flat, start, stop, bound, first, counts):
    """``counts[i % 4, v - first] += 1`` for the values ``v = flat[i] < bound``,
    ``start <= i < stop`` (``start`` a multiple of 4), four values a step: the
    four rows' increments do not wait on each other."""
    first_row, second_row, third_row, fourth_row = counts[0], counts[1], counts[2], counts[3]
    quads = start + (stop - start) // 4 * 4
    for i in range(start, quads, 4):
        a, b = np.intp(flat[i]), np.intp(flat[i + 1])
        c, d = np.intp(flat[i + 2]), np.intp(flat[i + 3])
        if a < bound:
            first_row[a - first] += 1
        if b < bound:
            second_row[b - first] += 1
        if c < bound:
            third_row[c - first] += 1
        if d < bound:
            fourth_row[d - first] += 1
    for i in range(quads, stop):
        value = np.intp(flat[i])
        if value < bound:
            counts[i & 3, value - first] += 1


@njit(inline="always")
def _count_from(flat, start, stop, bound, counts):
    """``counts[i % 4, v - bound] += 1`` for the values ``v = flat[i] >= bound``."""
    first_row, second_row, third_row, fourth_row = counts[0], counts[1], counts[2], counts[3]
    quads = start + (stop - start) // 4 * 4
    for i in range(start, quads, 4):
        a, b = np.intp(flat[i]), np.intp(flat[i + 1])
        c, d = np.intp(flat[i + 2]), np.intp(flat[i + 3])
        if a >= bound:
            first_row[a - bound] += 1
        if b >= bound:
            second_row[b - bound] += 1
        if c >= bound:
            third_row[c - bound] += 1
        if d >= bound:
            fourth_row[d - bound] += 1
    for i in range(quads, stop):
        value = np.intp(flat[i])
        if value >= bound:
            counts[i & 3, value - bound] += 1


@cached_njit(nogil=True)
def tail_values(flat, offset, shift, bins, ranks, values):
    """``percentiles.tail_rank_values`` in one call: True and the values of ``ranks`` in
    ``values``, or False when the blocks that may hold them are more than a quarter.

    ``offset`` is the least value of the dtype, ``shift`` the coarse bins' shift
    and ``bins`` their number (``((greatest value - offset) >> shift) + 1``).
    Each step is that of the Python reading it replaced, in integers: the
    same bounds, the same blocks counted, the same values.
    """
    n, block = flat.shape[0], EXTREMES_BLOCK
    below, above = np.zeros(bins, np.int64), np.zeros(bins, np.int64)
    least, greatest = block_extremes(flat, offset, shift, below, above)
    blocks, full = least.shape[0], n // block
    below_full, above_full = below.copy(), above.copy()
    if full < blocks:  # the last block is shorter: it holds at least one value
        below_full[(np.intp(least[blocks - 1]) - offset) >> shift] -= 1
        above_full[(np.intp(greatest[blocks - 1]) - offset) >> shift] -= 1
    # index k: the blocks whose extreme lies below the bound offset + (k << shift)
    least_below, greatest_below = np.zeros(bins + 1, np.int64), np.zeros(bins + 1, np.int64)
    surely_below, surely_from = np.zeros(bins + 1, np.int64), np.zeros(bins + 1, np.int64)
    above_full_below = below_full_below = 0
    surely_from[0] = (block - 1) * full + blocks
    for k in range(bins):
        least_below[k + 1] = least_below[k] + below[k]
        greatest_below[k + 1] = greatest_below[k] + above[k]
        above_full_below += above_full[k]
        below_full_below += below_full[k]
        surely_below[k + 1] = (block - 1) * above_full_below + least_below[k + 1]
        surely_from[k + 1] = (block - 1) * (full - below_full_below) + blocks
        surely_from[k + 1] -= greatest_below[k + 1]
    highest_low, lowest_high = -1, n  # the highest rank of the low tail, the lowest of the high
    for r in ranks:
        if 2 * r < n:
            highest_low = max(highest_low, r)
        else:
            lowest_high = min(lowest_high, r)
    lowest, highest = np.intp(least.min()), np.intp(greatest.max())
    low_stop, high_start = lowest, highest + 1  # empty tails
    visited = 0
    if highest_low >= 0:  # the least bound below which highest_low + 1 values surely lie
        k = np.searchsorted(surely_below, highest_low + 1, side="left")
        if k > bins:
            return False
        low_stop = offset + (k << shift)
        visited += least_below[k]
    if lowest_high < n:  # the greatest bound from which n - lowest_high values surely lie
        k = bins
        while k >= 0 and surely_from[k] < n - lowest_high:
            k -= 1
        if k < 0:
            return False
        high_start = offset + (k << shift)
        visited += blocks - greatest_below[k]
    if 4 * visited > blocks:
        return False
    low_counts = np.zeros((4, max(0, low_stop - lowest)), np.int64)
    high_counts = np.zeros((4, max(0, highest + 1 - high_start)), np.int64)
    count_tails(flat, least, greatest, low_stop, lowest, low_counts, high_start, high_counts)
    low_cumulative = np.cumsum(low_counts[0] + low_counts[1] + low_counts[2] + low_counts[3])
    high_cumulative = np.cumsum(
        high_counts[0] + high_counts[1] + high_counts[2] + high_counts[3]
    )
    under_high = n - (high_cumulative[-1] if high_cumulative.shape[0] else 0)
    for i in range(ranks.shape[0]):
        r = ranks[i]
        if 2 * r < n:
            values[i] = np.searchsorted(low_cumulative, r, side="right") + lowest
        else:
            values[i] = np.searchsorted(high_cumulative, r - under_high, side="right")
            values[i] += high_start
    return True


#: Blocks ``count_tails`` asks from memory ahead of the one it counts.
_AHEAD = 8


#: Values of one spot of the sample of ``sampled_tail_values``: every fourth of
#: ``4 * SPOT_VALUES`` values in a row (one cache line of 16-bit values).
SPOT_VALUES = 8

#: Golden ratio's fraction: spot k of a sample starts at the fraction k * _GOLDEN (mod 1)
#: of the values, so that the spots fall on every row and column of a plane alike.
_GOLDEN = 0.6180339887498949


@cached_njit(nogil=True)
def sample_starts(n, spots):
    """Where each of ``spots`` spots of ``sampled_tail_values`` starts among ``n`` values."""
    span = n - 4 * SPOT_VALUES + 1
    starts = np.empty(spots, np.intp)
    for k in range(spots):
        starts[k] = min(span - 1, np.intp(((k + 0.5) * _GOLDEN) % 1.0 * span))
    return starts


@cached_njit(nogil=True)
def sampled_tail_values(flat, offset, shift, bins, ranks, values, spots):
    """The values of ``ranks`` (0 the least) of the 8- or 16-bit integers ``flat`` in one
    sweep, with bounds from a sample; False when the sample's bounds miss a rank, when
    the sample shows nearly every block reaching a tail (noise: a count of every value
    costs less), or for fewer than ``64 * spots`` values.

    A sample of ``spots`` spots (``sample_starts``) of ``SPOT_VALUES`` values is
    binned in the coarse bins ``(v - offset) >> shift`` (``bins`` of them). Around
    each tail's ranks the sample gives a window of values, ``[floor, stop)`` for the
    low ranks (2 r < n), ``[start, ceiling)`` for the others, wide enough for the
    sample's error; a window of more than ``_WIDEST_WINDOW`` values (sparse values,
    as a few bright objects on a dark field leave above the background) is cut to
    that many around the sample's likeliest value of the ranks. One sweep takes the
    extremes of every ``EXTREMES_BLOCK`` values and, in the blocks that reach a window
    or beyond, counts every value of the window and those beyond it
    (``_count_window_below``, ``_count_window_from``; a block of one value at once). A
    rank's value is exact when it lies in its window, which the counts show: else
    False, and nothing is kept.
    """
    n, block = flat.shape[0], EXTREMES_BLOCK
    if n < 64 * spots or spots < 1:
        return False
    starts = sample_starts(n, spots)
    coarse = np.zeros(bins, np.int64)
    for k in range(spots):
        for i in range(starts[k], starts[k] + 4 * SPOT_VALUES, 4):
            coarse[(np.intp(flat[i]) - offset) >> shift] += 1
    sampled = spots * SPOT_VALUES
    below = np.zeros(bins + 1, np.int64)  # below[k]: sampled values in the bins before k
    for k in range(bins):
        below[k + 1] = below[k] + coarse[k]
    lowest_low, highest_low, lowest_high, highest_high = n, -1, n, -1
    for r in ranks:
        if 2 * r < n:
            lowest_low, highest_low = min(lowest_low, r), max(highest_low, r)
        else:
            lowest_high, highest_high = min(lowest_high, r), max(highest_high, r)
    end = offset + (bins << shift)  # past the last bin
    floor = stop = offset  # no low ranks: an empty window below every value
    start = ceiling = end
    if highest_low >= 0:
        floor = _bin_edge(below, _sample_position(lowest_low, n, sampled, -1), offset, shift)
        stop = _bin_edge(below, _sample_position(highest_low, n, sampled, 1), offset, shift)
        stop += 1 << shift
    if highest_high >= 0:
        start = _bin_edge(below, _sample_position(lowest_high, n, sampled, -1), offset, shift)
        ceiling = _bin_edge(below, _sample_position(highest_high, n, sampled, 1), offset, shift)
        ceiling += 1 << shift
    if stop - floor > _WIDEST_WINDOW:  # sparse values: the window around the likeliest
        middle = _sample_position((lowest_low + highest_low) / 2, n, sampled, 0)
        floor, stop = _narrowed(floor, stop, _bin_edge(below, middle, offset, shift), shift)
    if ceiling - start > _WIDEST_WINDOW:
        middle = _sample_position((lowest_high + highest_high) / 2, n, sampled, 0)
        start, ceiling = _narrowed(start, ceiling, _bin_edge(below, middle, offset, shift), shift)
    # the blocks the sweep would count: a sample of whole blocks (a spot's 8 values tell
    # little of a block's 64 in noise, where nearly every block reaches a window)
    full = n // block
    reaching = 0
    for first in sample_starts(full * block, _GUARD_BLOCKS) // block * block:
        least, greatest = _extremes(flat[first : first + block], block)
        if least != greatest:  # a block of one value is counted without a visit
            reaching += (np.intp(least) < stop) + (np.intp(greatest) >= start)
    if 2 * reaching > _GUARD_BLOCKS:  # counting half the blocks or more: count every value
        return False
    # slot 0: values below the window; the last slot: values from its end on
    low_counts = np.zeros((4, stop - floor + 2), np.int64)
    high_counts = np.zeros((4, ceiling - start + 2), np.int64)
    top = ceiling - start + 1
    for b in range(full):  # blocks of a known size: their extremes are vector reductions
        first = b * block
        least, greatest = _extremes(flat[first : first + block], block)
        if least == greatest:  # one value (a background, a saturated area): no visit
            value = np.intp(least)
            if value < stop:
                low_counts[0, max(value + 1 - floor, 0)] += block
            if value >= start:
                high_counts[0, min(value + 1 - start, top)] += block
            continue
        if np.intp(least) < stop:
            _count_window_below(flat, first, first + block, stop, 1 - floor, low_counts)
        if np.intp(greatest) >= start:
            _count_window_from(flat, first, first + block, start, top, high_counts)
    if full * block < n:  # the last, shorter block
        _count_window_below(flat, full * block, n, stop, 1 - floor, low_counts)
        _count_window_from(flat, full * block, n, start, top, high_counts)
    low = low_counts[0] + low_counts[1] + low_counts[2] + low_counts[3]
    high = high_counts[0] + high_counts[1] + high_counts[2] + high_counts[3]
    low_cumulative, high_cumulative = np.cumsum(low[1:-1]), np.cumsum(high[1:-1])
    under = low[0]  # values below floor
    under_start = n - high[-1] - (high_cumulative[-1] if high_cumulative.shape[0] else 0)
    found = np.empty(ranks.shape[0], np.int64)
    for i in range(ranks.shape[0]):
        r = ranks[i]
        if 2 * r < n:
            if r < under or r >= under + (low_cumulative[-1] if low_cumulative.shape[0] else 0):
                return False
            found[i] = np.searchsorted(low_cumulative, r - under, side="right") + floor
        else:
            if r < under_start or r >= n - high[-1]:
                return False
            found[i] = np.searchsorted(high_cumulative, r - under_start, side="right") + start
    for i in range(ranks.shape[0]):  # an array assignment would compile numba's shape checks
        values[i] = found[i]
    return True


#: Widest window of values ``sampled_tail_values`` counts (a wider one is cut to it).
_WIDEST_WINDOW = 1 << 14

#: Blocks whose extremes ``sampled_tail_values`` reads to foresee how many blocks the
#: sweep would count (one in 256 of a 2048² plane's).
_GUARD_BLOCKS = 256


@njit
def _sample_position(rank, n, sampled, side):
    """The position in the sorted sample of the value of ``rank`` among ``n``, moved
    towards ``side`` (-1 down, 1 up) by a margin of the sample's error (its values
    come in spots of ``SPOT_VALUES`` neighbours, which err together)."""
    expected = (rank + 0.5) * sampled / n
    spread = expected * (sampled - expected) / sampled  # binomial variance
    margin = 3.0 * math.sqrt(SPOT_VALUES * (spread + 1.0)) + SPOT_VALUES
    return expected + side * margin


@njit
def _narrowed(first, last, bin_start, shift):
    """The window ``[first, last)`` cut to ``_WIDEST_WINDOW`` values around the coarse bin
    that starts at ``bin_start`` (where the sample places a rank's value)."""
    centre = bin_start + (1 << shift) // 2
    first = max(first, centre - _WIDEST_WINDOW // 2)
    last = min(last, first + _WIDEST_WINDOW)
    return max(first, last - _WIDEST_WINDOW), last


@njit
def _bin_edge(below, position, offset, shift):
    """The least value of the coarse bin that holds ``position`` of the sorted sample
    (``below[k]`` sampled values lie in the bins before k); beyond the sample, the
    bin of its least or greatest value (a window that ends there and misses a rank
    beyond it shows it: the two sweeps take over)."""
    bins = below.shape[0] - 1
    position = min(max(position, 0.0), below[bins] - 1.0)
    k = np.searchsorted(below, position, side="right") - 1  # below[k] <= position
    return offset + (min(max(k, 0), bins - 1) << shift)


@njit(inline="always")
def _count_window_below(flat, first, last, stop, shift, counts):
    """``counts[i % 4, max(v + shift, 0)] += 1`` for the values ``v = flat[i] < stop``,
    ``first <= i < last`` (``first`` a multiple of 4): with ``shift = 1 - floor``,
    the values of the window ``[floor, stop)`` each in its slot, those below in
    slot 0. Four values a step, into four rows: their increments do not wait on
    each other."""
    first_row, second_row, third_row, fourth_row = counts[0], counts[1], counts[2], counts[3]
    quads = first + (last - first) // 4 * 4
    for i in range(first, quads, 4):
        a, b = np.intp(flat[i]), np.intp(flat[i + 1])
        c, d = np.intp(flat[i + 2]), np.intp(flat[i + 3])
        if a < stop:
            first_row[max(a + shift, 0)] += 1
        if b < stop:
            second_row[max(b + shift, 0)] += 1
        if c < stop:
            third_row[max(c + shift, 0)] += 1
        if d < stop:
            fourth_row[max(d + shift, 0)] += 1
    for i in range(quads, last):
        value = np.intp(flat[i])
        if value < stop:
            first_row[max(value + shift, 0)] += 1


@njit(inline="always")
def _count_window_from(flat, first, last, start, top, counts):
    """``counts[i % 4, min(v - start + 1, top)] += 1`` for the values ``v = flat[i] >=
    start``: those of the window ``[start, start + top - 1)`` each in its slot from 1,
    those past it in slot ``top``."""
    first_row, second_row, third_row, fourth_row = counts[0], counts[1], counts[2], counts[3]
    quads = first + (last - first) // 4 * 4
    shift = 1 - start
    for i in range(first, quads, 4):
        a, b = np.intp(flat[i]), np.intp(flat[i + 1])
        c, d = np.intp(flat[i + 2]), np.intp(flat[i + 3])
        if a >= start:
            first_row[min(a + shift, top)] += 1
        if b >= start:
            second_row[min(b + shift, top)] += 1
        if c >= start:
            third_row[min(c + shift, top)] += 1
        if d >= start:
            fourth_row[min(d + shift, top)] += 1
    for i in range(quads, last):
        value = np.intp(flat[i])
        if value >= start:
            first_row[min(value + shift, top)] += 1


@njit(inline="always")
def _tone(value, low, gain, low32, gain32, wide):
    """The tone of one integer value (``ToneScale.to_tones``)."""
    if wide:  # 32-bit integers: float64, then rounded to float32
        tone = np.float32((np.float64(value) - low) * gain)
    else:  # exact in float32: computed there
        tone = (np.float32(value) - low32) * gain32
    return min(max(tone, np.float32(0.0)), np.float32(255.0))


@cached_njit(nogil=True)
def integer_tones(values, tones, scale):
    """Fill the float32 plane ``tones`` with the tones of the integer plane ``values``
    on ``scale`` (an ``IntegerScale``)."""
    height, width = values.shape
    low, gain, low32, gain32, wide = scale.low, scale.gain, scale.low32, scale.gain32, scale.wide
    for y in range(height):
        for x in range(width):
            tones[y, x] = _tone(values[y, x], low, gain, low32, gain32, wide)


@cached_njit(nogil=True)
def write_back(target, source, tones, scale):
    """Where a tone of ``tones`` differs from that of ``source``, write its value to ``target``.

    The value is ``rint(tone / gain + low)`` clipped to ``[lowest, highest]``
    (``ToneScale.from_tones``; the fields of ``scale``, an ``IntegerScale``);
    ``target`` holds the source values elsewhere.
    """
    height, width = source.shape
    low, gain, low32, gain32, wide = scale.low, scale.gain, scale.low32, scale.gain32, scale.wide
    lowest, highest = scale.lowest, scale.highest
    for y in range(height):
        for x in range(width):
            tone = tones[y, x]
            before = _tone(source[y, x], low, gain, low32, gain32, wide)
            # the same bits (+0 and -0 differ): the pixel did not change
            if tone == before and math.copysign(1.0, tone) == math.copysign(1.0, before):
                continue
            value = np.rint(np.float64(tone) / gain + low)
            target[y, x] = min(max(value, lowest), highest)


@cached_njit(nogil=True)
def write_back_at(target, source, tones, indices, scale):
    """``write_back`` at the pixels of flat indices ``y * W + x`` in ``indices`` only.

    Every other pixel must have its source tone (the pass did not write it);
    an index may be listed more than once.
    """
    width = source.shape[1]
    low, gain, low32, gain32, wide = scale.low, scale.gain, scale.low32, scale.gain32, scale.wide
    lowest, highest = scale.lowest, scale.highest
    # write_back's body, repeated: shared through an inlined helper it made write_back's
    # whole-plane loop three times slower (6.3 ms against 2.1 ms at 2048²)
    for index in indices:
        y, x = index // width, index % width
        tone = tones[y, x]
        before = _tone(source[y, x], low, gain, low32, gain32, wide)
        if tone == before and math.copysign(1.0, tone) == math.copysign(1.0, before):
            continue
        value = np.rint(np.float64(tone) / gain + low)
        target[y, x] = min(max(value, lowest), highest)


@cached_njit(nogil=True)
def rounded_tones(target, tones):
    """``target[...] = rint(tones)`` clipped to 0-255: uint8 values on the scale (0, 255).

    ``target`` and ``tones`` are C-contiguous planes of one shape.

    There a tone that did not change is its value, so every pixel may be
    written; no source is read and no comparison made.
    """
    flat_tones, flat_target = tones.ravel(), target.ravel()
    for i in range(flat_tones.shape[0]):
        # rint of a float32 is that of its float64 (from_tones' precision)
        tone = min(max(flat_tones[i], np.float32(0.0)), np.float32(255.0))
        flat_target[i] = np.uint8(np.rint(tone))
