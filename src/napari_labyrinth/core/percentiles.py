"""``numpy.percentile`` (its default "linear" method), bit for bit, from ranks.

The default tone limits are percentiles of an image's values. numpy finds them
by partitioning a copy of the whole image; an image of 8- or 16-bit integers
holds at most 65536 distinct values, so one count of each value gives the
order statistics, and the interpolation below gives numpy's exact floats.
The default limits need only the values of low and high ranks: most often
a sample places a window of values around them and one sweep counts those
windows in the few blocks of values that reach them (exact: the counts show
whether each rank lies in its window); else a first, vectorised pass over
blocks of values (their least and greatest) shows which few blocks hold
them, and only those are counted.
``lazy.streamed_percentiles`` takes the counting route over the blocks of a dask array.
"""

from __future__ import annotations

import functools
from collections.abc import Sequence

import numpy as np


def linear_ranks(count: int, q: Sequence[float]) -> tuple[list[int], np.ndarray]:
    """Ranks (previous, next for each percentile) and weights, as numpy's 'linear' method."""
    q = tuple(q)
    if not all(type(v) in (float, int) for v in q):  # numpy scalars keep their precision
        return _linear_ranks.__wrapped__(count, q)
    ranks, gammas = _linear_ranks(count, q)
    return list(ranks), gammas.copy()


@functools.lru_cache(maxsize=64)
def _linear_ranks(count: int, q: tuple[float, ...]) -> tuple[list[int], np.ndarray]:
    """:func:`linear_ranks` of one image size and percentiles, computed once (a dozen
    numpy steps on a few values, slow beside an image's copy)."""
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
    gammas.flags.writeable = False
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
    in one sweep, within windows of values a sample places around them
    (:func:`sampled_rank_values`), or where the sample's windows miss them, in
    the tails that hold them (:func:`tail_rank_values`) when these are few,
    otherwise in one count of every value (a numba loop and a few operations
    on the 256 or 65536 counts). Either way, no copy of the image is
    partitioned as numpy does.
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
    ranked = sampled_rank_values(flat, ranks)
    if ranked is None:
        ranked = tail_rank_values(flat, ranks)
    if ranked is None:
        counts = np.zeros(int(info.max) - int(info.min) + 1, dtype=np.int64)
        count_values(flat, int(info.min), counts)
        ranked = np.searchsorted(np.cumsum(counts), ranks, side="right") + int(info.min)
    return ranked_percentiles([int(v) for v in ranked], gammas, dtype)


#: Values from which ``counting_pays`` compiles the counting kernels for a call: above it,
#: numpy's partition of a copy of the values costs more than a fraction of a second.
COMPILE_FROM_VALUES = 1 << 23


def counting_pays(values: np.ndarray) -> bool:
    """Whether :func:`integer_percentiles` is the route for the 8- or 16-bit ``values``.

    It is where its counting kernel is compiled (in this process or in numba's
    disk cache) or the values are so many that its compile pays within the
    call; else ``np.percentile`` gives the same floats at once, where the first
    count would wait seconds on numba.
    """
    if values.size >= COMPILE_FROM_VALUES:
        return True
    # numba is imported on first use only, not with the package
    from ._jit import is_compiled
    from ._tone_loops import sampled_tail_values

    flat = values.reshape(-1)
    ranks = np.zeros(2, np.int64)
    return is_compiled(sampled_tail_values, flat, 0, 0, 1, ranks, ranks, SAMPLE_SPOTS)


def ranked_percentiles(ranked: Sequence[int], gammas: np.ndarray, dtype) -> list[float]:
    """:func:`lerp` of the values ``ranked`` (previous, next for each percentile) of
    integers of ``dtype``, as a list of floats.

    Where each difference ``next - previous`` holds in ``dtype`` (always for
    unsigned integers) the same float64 operations in Python's floats (no numpy
    step on a few values, slow beside an image's copy); else numpy's, whose
    differences wrap around in ``dtype``.
    """
    info = np.iinfo(dtype)
    pairs = list(zip(ranked[0::2], ranked[1::2]))
    if not all(info.min <= following - previous <= info.max for previous, following in pairs):
        values = np.asarray(ranked).astype(dtype)
        return [float(v) for v in lerp(values[0::2], values[1::2], gammas)]
    out = []
    for (previous, following), weight in zip(pairs, gammas.tolist()):
        difference = following - previous
        if weight >= 0.5:
            out.append(following - difference * (1 - weight))
        else:
            out.append(previous + difference * weight)
    return [float(v) for v in out]


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
    from ._tone_loops import tail_values  # numba is imported on first use only

    info = np.iinfo(flat.dtype)
    offset = int(info.min)
    shift = max(0, flat.dtype.itemsize * 8 - _COARSE_BITS)
    values = np.empty(len(ranks), np.int64)
    bins = ((int(info.max) - offset) >> shift) + 1
    if not tail_values(flat, offset, shift, bins, np.asarray(ranks, np.int64), values):
        return None
    return [int(v) for v in values]


#: Spots of ``SPOT_VALUES`` values that ``sampled_rank_values`` samples: enough that
#: its windows are narrow (few blocks counted), few enough that the sample costs
#: little beside the sweep; arrays of fewer than 64 values a spot are not sampled.
SAMPLE_SPOTS = 1024


def sampled_rank_values(
    flat: np.ndarray, ranks: Sequence[int], spots: int = SAMPLE_SPOTS
) -> list[int] | None:
    """The values of ``ranks`` among the 8- or 16-bit integers ``flat`` in one sweep
    (``_tone_loops.sampled_tail_values``), or None where its sample's windows miss a
    rank, the values are noisy, or fewer than ``64 * spots``.

    A sample of the values places a window of values around the low ranks and
    one around the high ranks; one sweep counts every value in or below the low
    window and in or above the high one, in the blocks of values that reach
    them. A rank's value found in its window is exact whatever the sample was;
    the counts show whether it lies there.
    """
    from ._tone_loops import sampled_tail_values  # numba is imported on first use only

    info = np.iinfo(flat.dtype)
    offset = int(info.min)
    shift = max(0, flat.dtype.itemsize * 8 - _COARSE_BITS)
    bins = ((int(info.max) - offset) >> shift) + 1
    values = np.empty(len(ranks), np.int64)
    if not sampled_tail_values(
        flat, offset, shift, bins, np.asarray(ranks, np.int64), values, spots
    ):
        return None
    return [int(v) for v in values]
