"""``numpy.percentile`` of a dask array's finite values, bit for bit, in bounded memory.

Histograms locate the order statistics, then the few values of the bins that
hold them are gathered: every pass scans the blocks and merges the partial
results in a tree, holding a few blocks and a few MB of partial results.
"""

from __future__ import annotations

import dataclasses
import functools
import math
from collections.abc import Sequence
from typing import Any

import numpy as np

from ..core.percentiles import lerp, linear_ranks
from .errors import computing

#: Bins of each histogram pass (a float32 or 32-bit integer image takes one
#: min/max pass, one histogram pass and one gathering pass).
HISTOGRAM_BINS = 1 << 16

#: Distinct values a gathering pass keeps per bin before it gives up and the
#: bin is split by another histogram pass (bounds the memory of a pass).
GATHER_LIMIT = 1 << 18

#: Partial results merged by each task of the reduction tree.
TREE_FANIN = 8

#: Histogram levels before giving up (each level splits a bin 65536 ways).
MAX_LEVELS = 8

#: Values of a block scanned at once (bounds the temporaries of a pass).
SLAB = 1 << 20


def percentiles(array: Any, q: Sequence[float]) -> list[float] | None:
    """``numpy.percentile`` of the finite values of a dask array, bit for bit.

    Parameters
    ----------
    array : dask array
        Integer or float values; NaN and infinities are left out.
    q : sequence of float
        Percentiles in [0, 100].

    Returns
    -------
    list of float or None
        What ``[float(v) for v in np.percentile(finite_values, q)]`` returns
        (linear interpolation), or None if there is no finite value.
    """
    dtype = np.dtype(array.dtype)
    blocks = _blocks(array)
    if dtype.kind in "iu" and dtype.itemsize <= 2:
        info = np.iinfo(dtype)
        count = int(array.size)
        root = _Window(lo=float(info.min), scale=1.0, bins=int(info.max) - int(info.min) + 1)
        root = dataclasses.replace(root, exact=True)
    else:
        count, low, high = _reduce(blocks, (("range", None),))[0]
        if count == 0:
            return None
        root = _root_window(dtype, low, high)
    ranks, gammas = linear_ranks(count, q)
    values = _order_statistics(blocks, dtype, root, sorted(set(ranks)))
    previous = np.array([values[r] for r in ranks[0::2]], dtype=dtype)
    following = np.array([values[r] for r in ranks[1::2]], dtype=dtype)
    return [float(v) for v in lerp(previous, following, gammas)]


@dataclasses.dataclass(frozen=True)
class _Window:
    """A set of values: those that fell in bin ``k`` of each histogram of ``chain``.

    ``lo``, ``scale``, ``bins`` and ``shift`` define this window's own histogram:
    ``bin(v) = clip(floor(ldexp(v - lo, shift) * scale), 0, bins - 1)``, a
    monotonic function, so each bin holds a contiguous run of the sorted values
    and the predicate, not the (approximate) bin edges, decides membership.
    ``shift`` (exact: a power of two) keeps ``scale`` finite for values closer
    together than float64's normal range (subnormal values): 0 for any other.
    """

    chain: tuple[tuple[float, float, int, int, int], ...] = ()  # (lo, scale, bins, k, shift)
    lo: float = 0.0
    scale: float = 1.0
    bins: int = HISTOGRAM_BINS
    exact: bool = False  # every bin holds one value: lo + k
    shift: int = 0

    def spanning(self, dtype: np.dtype, low: float, high: float) -> _Window:
        """This window, its histogram over ``[low, high]``, the least and greatest of its
        values: values far from the others (a NoData value of -3.4e38 beside values in
        [0, 1]) leave the others few bins of a histogram over the whole range; a
        histogram over their own range separates them."""
        own = _root_window(dtype, low, high)
        return dataclasses.replace(own, chain=self.chain)

    def child(self, k: int) -> _Window:
        return _Window(
            chain=self.chain + ((self.lo, self.scale, self.bins, k, self.shift),),
            lo=self.lo + math.ldexp(k / self.scale, -self.shift),
            scale=self.scale * HISTOGRAM_BINS,
            shift=self.shift,
        )


def _root_window(dtype: np.dtype, low: float, high: float) -> _Window:
    if dtype.kind in "iu" and high - low + 1 <= HISTOGRAM_BINS:
        return _Window(lo=low, scale=1.0, bins=int(high - low) + 1, exact=True)
    span = high - low
    if not math.isfinite(span):
        span = float(np.finfo(np.float64).max)
    if span == 0:
        return _Window(lo=low, scale=1.0, bins=1)
    # every level multiplies the scale by HISTOGRAM_BINS: below this span it would overflow
    shift = -math.frexp(span)[1] if span < _LEAST_UNSHIFTED_SPAN else 0
    return _Window(lo=low, scale=HISTOGRAM_BINS / math.ldexp(span, shift), shift=shift)


#: Spans of values below this are binned at a power-of-two magnification (``_Window.shift``).
_LEAST_UNSHIFTED_SPAN = 2.0**-512


def _bin(values: np.ndarray, lo: float, scale: float, bins: int, shift: int = 0) -> np.ndarray:
    with np.errstate(over="ignore"):  # float64 extremes: inf lands in the last bin
        offset = values - lo
        if shift:
            offset = np.ldexp(offset, shift)
        index = np.floor(offset * scale)
    np.clip(index, 0, bins - 1, out=index)
    return index.astype(np.intp)


def _order_statistics(blocks, dtype: np.dtype, root: _Window, ranks: list[int]) -> dict[int, Any]:
    """Values of the given ranks (0-based, among the sorted finite values)."""
    # rank -> (window, rank within it, "hist", "gather" or "range")
    pending = {rank: (root, rank, "hist") for rank in ranks}
    found: dict[int, Any] = {}
    for _ in range(3 * MAX_LEVELS + 1):
        if not pending:
            return found
        plan = tuple(dict.fromkeys((mode, window) for window, _, mode in pending.values()))
        results = dict(zip(plan, _reduce(blocks, plan)))
        for rank, (window, within, mode) in list(pending.items()):
            result = results[(mode, window)]
            if mode == "range":  # the window's histogram spans its own values only
                _, low, high = result
                pending[rank] = (window.spanning(dtype, low, high), within, "hist")
                continue
            if mode == "gather":
                if result is not None:
                    values, counts = result
                    position = int(np.searchsorted(np.cumsum(counts), within, side="right"))
                    found[rank] = values[position]
                    del pending[rank]
                else:  # too many distinct values: split the range they span
                    pending[rank] = (window, within, "range")
                continue
            cumulative = np.cumsum(result)
            k = int(np.searchsorted(cumulative, within, side="right"))
            within -= int(cumulative[k - 1]) if k else 0
            if window.exact:
                found[rank] = np.array(window.lo + k).astype(dtype)[()]
                del pending[rank]
            elif len(window.chain) >= MAX_LEVELS:
                raise ValueError(_UNFOUND)
            else:
                pending[rank] = (window.child(k), within, "gather")
    raise ValueError(_UNFOUND)


_UNFOUND = (
    "cannot find the default tone limits of these values; pass tone_limits (--tone-limits on "
    "the command line)"
)


def _blocks(array) -> list:
    return list(array.to_delayed().ravel())


def _reduce(blocks: list, plan: tuple) -> list:
    """Scan every block for each ``(mode, window)`` of ``plan``; merge in a tree."""
    import dask  # dask is optional: imported on first use

    scan = dask.delayed(_scan_block, pure=True)
    merge = dask.delayed(_merge, pure=True)
    parts = [scan(block, plan) for block in blocks]
    while len(parts) > 1:
        parts = [merge(plan, *parts[i : i + TREE_FANIN]) for i in range(0, len(parts), TREE_FANIN)]
    with computing():
        (result,) = dask.compute(parts[0])
    return result


def _scan_block(block: np.ndarray, plan: tuple) -> list:
    flat = np.asarray(block).reshape(-1)
    floating = flat.dtype.kind == "f"
    results: list[Any] = [None] * len(plan)
    for start in range(0, max(flat.size, 1), SLAB):
        part = flat[start : start + SLAB]
        as_float = part.astype(np.float64)
        if floating:
            finite = np.isfinite(as_float)
            if not finite.all():
                part, as_float = part[finite], as_float[finite]
        slab = []
        for mode, window in plan:
            inside = None
            for lo, scale, bins, k, shift in () if window is None else window.chain:
                match = _bin(as_float, lo, scale, bins, shift) == k
                inside = match if inside is None else inside & match
            if mode == "range":
                values = as_float if inside is None else as_float[inside]
                if values.size:
                    slab.append((values.size, float(values.min()), float(values.max())))
                else:
                    slab.append((0, math.inf, -math.inf))
                continue
            if mode == "hist":
                values = as_float if inside is None else as_float[inside]
                index = _bin(values, window.lo, window.scale, window.bins, window.shift)
                slab.append(np.bincount(index, minlength=window.bins))
            else:
                values = part if inside is None else part[inside]
                slab.append(_distinct(values))
        results = _merge(plan, results, slab) if start else slab
    return results


def _distinct(values: np.ndarray) -> tuple[np.ndarray, np.ndarray] | None:
    distinct, counts = np.unique(values, return_counts=True)
    if distinct.size > GATHER_LIMIT:
        return None
    return distinct, counts.astype(np.int64)


def _merge(plan: tuple, *parts: list) -> list:
    merged = []
    for index, (mode, _) in enumerate(plan):
        items = [part[index] for part in parts]
        if mode == "range":
            merged.append(
                (
                    sum(item[0] for item in items),
                    min(item[1] for item in items),
                    max(item[2] for item in items),
                )
            )
        elif mode == "hist":
            merged.append(functools.reduce(np.add, items))
        elif any(item is None for item in items):
            merged.append(None)
        else:
            values = np.concatenate([item[0] for item in items])
            counts = np.concatenate([item[1] for item in items])
            distinct, inverse = np.unique(values, return_inverse=True)
            if distinct.size > GATHER_LIMIT:
                merged.append(None)
            else:
                summed = np.bincount(inverse, counts, distinct.size).astype(np.int64)
                merged.append((distinct, summed))
    return merged
