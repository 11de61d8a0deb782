"""``numpy.percentile`` (its default "linear" method), bit for bit, from ranks.

The default tone limits are percentiles of an image's values. numpy finds them
by partitioning a copy of the whole image; an image of 8- or 16-bit integers
holds at most 65536 distinct values, so one count of each value gives the
order statistics, and the interpolation below gives numpy's exact floats.
The default limits need only the values of low and high ranks: most often
a first, vectorised pass over blocks of values (their least and greatest)
shows that a few blocks hold them, and only those are counted.
``lazy.py`` takes the counting route over the blocks of a dask array.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np


def linear_ranks(count: int, q: Sequence[float]) -> tuple[list[int], np.ndarray]:
    """Ranks (previous, next for each percentile) and weights, as numpy's 'linear' method."""
    quantiles = np.true_divide(tuple(q), 100)
    virtual = (count - 1) * quantiles
    previous = np.floor(virtual)
    following = previous + 1
    above = virtual >= count - 1
    previous[above] = count - 1
    following[above] = count - 1
    previous = previous.astype(np.intp)
    following = following.astype(np.intp)
    # numpy computes gamma from the *fixed* previous index (-1 for the last element)
    fixed_previous = np.where(above, -1, previous)
    gammas = np.asanyarray(virtual - fixed_previous, dtype=virtual.dtype)
    ranks = [int(r) for pair in zip(previous, following) for r in pair]
    return ranks, gammas


def lerp(a: np.ndarray, b: np.ndarray, t: np.ndarray) -> np.ndarray:
    """numpy's private ``_lerp`` of ``np.percentile``, operation for operation."""
    diff_b_a = b - a
    result = np.add(a, diff_b_a * t)
    np.subtract(
        b,
        diff_b_a * (1 - t),
        out=result,
        where=t >= 0.5,
        casting="unsafe",
        dtype=type(result.dtype),
    )
    return result


def counts_percentiles(counts: np.ndarray, offset: int, dtype, q: Sequence[float]) -> list[float]:
    """``np.percentile`` of values of ``dtype`` of which ``counts[k]`` equal ``offset + k``."""
    ranks, gammas = linear_ranks(int(counts.sum()), q)
    # the value of rank r is the first whose cumulative count exceeds r
    values = np.searchsorted(np.cumsum(counts), ranks, side="right") + offset
    values = values.astype(dtype)
    return [float(v) for v in lerp(values[0::2], values[1::2], gammas)]


def integer_percentiles(values: np.ndarray, q: Sequence[float]) -> list[float]:
    """``[float(v) for v in np.percentile(values, q)]`` of 8- or 16-bit integers, by counting.

    The values of the ranks np.percentile interpolates between are counted:
    in the tails that hold them (:func:`tail_rank_values`) when these are
    few, otherwise in one count of every value (a numba loop and a few
    operations on the 256 or 65536 counts). Either way, no copy of the
    image is partitioned as numpy does.
    """
    from ._tone_loops import count_values  # numba is imported on first use only

    dtype = np.dtype(values.dtype)
    if dtype.kind not in "iu" or dtype.itemsize > 2:
        raise TypeError(f"integer_percentiles takes 8- or 16-bit integers, not {dtype}")
    if values.size == 0:
        raise ValueError("integer_percentiles of no values")
    info = np.iinfo(dtype)
    flat = values.reshape(-1)
    ranks, gammas = linear_ranks(flat.size, q)
    ranked = tail_rank_values(flat, ranks)
    if ranked is None:
        counts = np.zeros(int(info.max) - int(info.min) + 1, dtype=np.int64)
        count_values(flat, int(info.min), counts)
        ranked = np.searchsorted(np.cumsum(counts), ranks, side="right") + int(info.min)
    ranked = np.asarray(ranked).astype(dtype)
    return [float(v) for v in lerp(ranked[0::2], ranked[1::2], gammas)]


#: Coarse bins of values in which ``tail_rank_values`` places the tails' bounds.
_COARSE_BITS = 12


def tail_rank_values(flat: np.ndarray, ranks: Sequence[int]) -> list[int] | None:
    """The values of ``ranks`` (0 the least) among the 8- or 16-bit integers ``flat``, or
    None when the blocks that may hold them are more than a quarter of all blocks.

    The ranks below the middle are counted below a bound ``low_stop``, the
    others from a bound ``high_start`` on. A block of ``EXTREMES_BLOCK`` values
    whose greatest value lies below a bound has all its values below it, one
    whose least value does has at least one: so the block extremes
    (``block_extremes``) give, for every coarse bound, a number of values
    that certainly lie below it, and ``low_stop`` is the least bound below
    which the highest low rank certainly lies (``high_start`` the greatest,
    likewise). Only the blocks that reach a tail are then counted
    (``count_tails``): exact, whatever the values.
    """
    from ._tone_loops import EXTREMES_BLOCK, block_extremes, count_tails  # numba on first use

    n, block = flat.shape[0], EXTREMES_BLOCK
    info = np.iinfo(flat.dtype)
    offset = int(info.min)
    shift = max(0, flat.dtype.itemsize * 8 - _COARSE_BITS)
    bins = (int(info.max) - offset >> shift) + 1
    below, above = np.zeros(bins, np.int64), np.zeros(bins, np.int64)
    least, greatest = block_extremes(flat, offset, shift, below, above)
    blocks, full = least.shape[0], n // block
    below_full, above_full = below.copy(), above.copy()
    if full < blocks:  # the last block is shorter: it holds at least one value
        below_full[int(least[-1]) - offset >> shift] -= 1
        above_full[int(greatest[-1]) - offset >> shift] -= 1
    # index k: the blocks whose extreme lies below the bound offset + (k << shift)
    least_below = np.concatenate(([0], np.cumsum(below)))
    greatest_below = np.concatenate(([0], np.cumsum(above)))
    surely_below = (block - 1) * np.concatenate(([0], np.cumsum(above_full))) + least_below
    surely_from = (block - 1) * (full - np.concatenate(([0], np.cumsum(below_full))))
    surely_from += blocks - greatest_below
    low = [r for r in ranks if 2 * r < n]
    high = [r for r in ranks if 2 * r >= n]
    lowest, highest = int(least.min()), int(greatest.max())
    low_stop, high_start = lowest, highest + 1  # empty tails
    visited = 0
    if low:
        k = int(np.searchsorted(surely_below, max(low) + 1, side="left"))
        if k > bins:
            return None
        low_stop = offset + (k << shift)
        visited += int(least_below[k])
    if high:
        # surely_from does not increase with k: the last k where it holds n - min(high)
        k = int(np.searchsorted(-surely_from, -(n - min(high)), side="right")) - 1
        if k < 0:
            return None
        high_start = offset + (k << shift)
        visited += blocks - int(greatest_below[k])
    if 4 * visited > blocks:
        return None
    low_counts = np.zeros((4, max(0, low_stop - lowest)), np.int64)
    high_counts = np.zeros((4, max(0, highest + 1 - high_start)), np.int64)
    count_tails(flat, least, greatest, low_stop, lowest, low_counts, high_start, high_counts)
    low_cumulative = np.cumsum(low_counts.sum(axis=0))
    high_cumulative = np.cumsum(high_counts.sum(axis=0))
    under_high = n - (int(high_cumulative[-1]) if high_cumulative.size else 0)
    values = []
    for r in ranks:
        if 2 * r < n:
            values.append(int(np.searchsorted(low_cumulative, r, side="right")) + lowest)
        else:
            values.append(int(np.searchsorted(high_cumulative, r - under_high, side="right"))
                          + high_start)  # fmt: skip
    return values
