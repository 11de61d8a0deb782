"""Lazy (dask) images: exact tone limits in bounded memory, block runs.

What the API and the command line need when an image does not fit in memory:

- ``default_tone_limits``: the tone limits :func:`napari_labyrinth.labyrinth`
  would choose for the whole image (the 0.5th and 99.5th percentiles of its
  finite values), computed bit for bit as ``numpy.percentile`` computes them,
  by streaming over the blocks of a dask array: histograms locate the order
  statistics, then the few values of the bins that hold them are gathered.
- ``render_lazy``: the rendering of a dask array as a lazy dask array, whole
  planes per block, each plane drawing the random stream of its index in the
  whole array (the API's path for dask input).
- ``run_blocks``: compute every block of a dask array and hand it to a
  writer, with a per-plane progress callback, under the local threaded
  scheduler or a ``dask.distributed`` client, holding only a few blocks in
  memory at a time.

dask is imported on first use, as everywhere else in the package.
"""

from __future__ import annotations

import contextlib
import dataclasses
import functools
import math
import sys
from collections.abc import Callable, Sequence
from typing import Any

import numpy as np

from ._budget import refuse_unaffordable, refuse_unaffordable_result
from ._engine import render, run_to_end
from .core.colour import TONES, LuminancePlanes, luminance, luminance_for_limits
from .core.parameters import LabyrinthParameters
from .core.percentiles import lerp, linear_ranks
from .core.planes import (
    PlaneLayout,
    normalise_channel_axis,
    resolve_alpha,
    resolve_layout_colour,
    validate_shape,
    validate_stream_range,
    without_alpha,
)
from .core.tone_scale import (
    DEFAULT_PERCENTILES,
    resolve_tone_scale,
    separated_limits,
    validate_dtype,
)

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

ProgressCallback = Callable[[int, int], Any]


class ComputeError(RuntimeError):
    """A block could not be computed: a corrupt chunk, a lost worker, ... (one line)."""


#: Errors that already say what went wrong about a file, passed on as they are.
_PLAIN_ERRORS = (OSError, ValueError, TypeError, MemoryError)


@contextlib.contextmanager
def computing():
    """Turn any other exception raised while computing into a one-line ComputeError."""
    try:
        yield
    except _PLAIN_ERRORS:
        raise
    except Exception as exc:
        where = "the dask cluster" if type(exc).__module__.startswith("distributed") else ""
        text = " ".join(str(exc).split()) or "no details"
        prefix = f"{where} failed: " if where else ""
        raise ComputeError(f"{prefix}{type(exc).__name__}: {text}") from exc


# -- rendering -----------------------------------------------------------------------------------


def render_lazy(
    image,
    parameters: LabyrinthParameters,
    seed: int,
    *,
    channel_axis,
    tone_limits,
    plane_offset: int,
    record_passes: bool,
    colour: str | None = None,
    alpha: bool | None = None,
):
    """A lazy dask array rendering ``image`` block by block, whole planes per block.

    In the luminance mode (``colour``) a block holds every channel of its
    planes, and the default tone limits are those of the luminance, streamed.
    A big-endian image is rendered as its native-order equivalent and the
    result cast back to its dtype.

    Raises
    ------
    TypeError, ValueError
        Naming ``image`` or the option at fault, before any block is read:
        unknown chunk sizes, or planes too large to render in this
        machine's memory (see ``_budget``).
    """
    import dask.array as da

    given = np.dtype(image.dtype)
    image, channel_axis, has_alpha, layout = checked_lazy(image, channel_axis, alpha)
    dtype = image.dtype
    validate_stream_range(plane_offset, layout.n_planes)
    if record_passes:  # a block holds the plane and every pass of it
        what = f"each plane's stack of the input and {parameters.passes} passes"
        refuse_unaffordable_result(
            layout.plane_shape, dtype, parameters.passes + 1, what, lazy=True
        )
    in_luminance = resolve_layout_colour(colour, image.shape, channel_axis, alpha) == "luminance"
    if tone_limits is None:
        tone_limits = _streamed_limits(image, channel_axis, has_alpha, in_luminance)
    scale = resolve_tone_scale(np.empty(0, dtype), tone_limits)
    planes = image if channel_axis is None else da.moveaxis(image, channel_axis, -3)
    whole = {planes.ndim - 2: -1, planes.ndim - 1: -1}
    if channel_axis is not None:
        whole[planes.ndim - 3] = -1  # alpha is recognised by its position among all channels
    planes = planes.rechunk(whole)
    block_channel_axis = None if channel_axis is None else planes.ndim - 3
    leading_total = planes.shape[:-2]

    def render_block(block, block_info=None):
        location = block_info[0]["array-location"]
        layout = PlaneLayout(
            block.shape,
            block_channel_axis,
            plane_offset=plane_offset,
            leading_origin=tuple(start for start, _ in location[:-2]),
            leading_total=leading_total,
            alpha=has_alpha,
        )
        if not in_luminance:
            rendering = render(block, layout, scale, parameters, seed, record_passes=record_passes)
            result, _ = run_to_end(rendering)
            return result
        grey = LuminancePlanes(block, scale=scale)  # the block is in the layout of planes
        rendering = render(
            grey.tones,
            layout.luminance_layout(),
            TONES,
            parameters,
            seed,
            record_passes=record_passes,
        )
        tones, _ = run_to_end(rendering)
        if not record_passes:
            result = block.copy()
            grey.put_back_all(result, tones)
            return result
        result = np.empty((parameters.passes + 1,) + block.shape, dtype=block.dtype)
        result[...] = block
        for k in range(1, parameters.passes + 1):
            grey.put_back_all(result[k], tones[k])
        return result

    if record_passes:
        rendered = planes.map_blocks(
            render_block,
            new_axis=0,
            chunks=((parameters.passes + 1,),) + planes.chunks,
            dtype=dtype,
        )
        shift = 1
    else:
        rendered = planes.map_blocks(render_block, dtype=dtype)
        shift = 0
    if channel_axis is not None:
        rendered = da.moveaxis(rendered, -3, channel_axis + shift)
    return rendered if dtype == given else rendered.astype(given)


def _check_known_shape(image) -> None:
    """Refuse a dask array whose chunk sizes are unknown (NaN), naming ``image``."""
    if any(math.isnan(size) for size in image.shape):
        raise ValueError(
            f"image is a dask array with unknown chunk sizes (shape {image.shape}, e.g. after "
            "boolean indexing): call image.compute_chunk_sizes() first"
        )


def rendering_tone_limits(image, *, channel_axis=None, alpha=None, colour=None):
    """The tone limits :func:`render_lazy` finds for a dask ``image`` given none: exact and
    streamed (those of its luminance in the luminance mode), or None for uint8 (the
    paper's scale, no scan). What ``variance_threshold="auto"`` measures its probe on, so
    that a dask image gets the V its numpy array gets.

    Raises
    ------
    TypeError, ValueError
        As :func:`render_lazy`, before any block is read.
    """
    image, channel_axis, has_alpha, _ = checked_lazy(image, channel_axis, alpha)
    in_luminance = resolve_layout_colour(colour, image.shape, channel_axis, alpha) == "luminance"
    return _streamed_limits(image, channel_axis, has_alpha, in_luminance)


def checked_lazy(image, channel_axis, alpha):
    """A dask image checked before any block is read, in native byte order; its channel
    axis (normalised), whether it has alpha, and its layout of planes.

    Raises
    ------
    TypeError, ValueError
        Naming ``image`` or the option at fault.
    """
    if isinstance(getattr(image, "_meta", None), np.ma.MaskedArray):
        raise TypeError(
            "image is a dask masked array, whose mask the rendering would lose: pass "
            "dask.array.ma.filled(image, np.nan) (a float image: NaN pixels are kept as they "
            "are and never count as neighbours) or dask.array.ma.getdata(image)"
        )
    given = np.dtype(image.dtype)
    dtype = validate_dtype(given if given.isnative else given.newbyteorder("="))
    _check_known_shape(image)
    validate_shape(image.shape)
    channel_axis = normalise_channel_axis(channel_axis, image.ndim)
    has_alpha = resolve_alpha(alpha, image.shape, channel_axis)
    layout = PlaneLayout(tuple(image.shape), channel_axis, alpha=has_alpha)
    refuse_unaffordable("image", layout.plane_shape, dtype, planes=1, what="each plane")
    if dtype != given:
        image = image.astype(dtype)
    return image, channel_axis, has_alpha, layout


def _streamed_limits(image, channel_axis, has_alpha, in_luminance):
    """The default tone limits of a native-order dask image, None for uint8."""
    if image.dtype == np.uint8:
        return None
    if in_luminance:
        values = luminance_for_limits(lazy_luminance(image, channel_axis), image.dtype)
        return default_tone_limits(values)  # exact, streamed
    return default_tone_limits(image, channel_axis, has_alpha)  # exact, streamed


def lazy_luminance(image, channel_axis: int):
    """The luminance (float64, ``core.colour.luminance``) of a dask array's R, G, B, lazily.

    Shaped as ``image`` without its colour axis; each block is computed from
    the same block's channels.
    """
    axis = channel_axis % image.ndim
    channels = image.rechunk({axis: -1})
    return channels.map_blocks(
        luminance,
        axis=axis,
        drop_axis=axis,
        dtype=np.float64,
        meta=np.empty((0,) * (image.ndim - 1)),
    )


# -- tone limits ----------------------------------------------------------------------------------


def is_lazy(image: Any) -> bool:
    """Whether ``image`` is a dask array (checked without importing dask): the API renders
    it lazily."""
    return type(image).__module__.split(".")[0] == "dask" and hasattr(image, "chunks")


def is_in_memory(data: Any) -> bool:
    """Whether ``data`` is a numpy array; other array-likes (dask, zarr, ...) load planes on
    demand, so the widget renders only the plane on screen and leaves the rest lazy."""
    return isinstance(data, np.ndarray)


def default_tone_limits(
    image: Any, channel_axis: int | None = None, alpha: bool | None = None
) -> tuple[float, float]:
    """The tone limits :func:`~napari_labyrinth.labyrinth` uses by default, for any array.

    Parameters
    ----------
    image : ndarray or dask array
        The image, as it will be passed to ``labyrinth``.
    channel_axis : int, optional
        Its colour axis; with 4 channels the last (alpha) is left out, as the
        API does.
    alpha : bool, optional
        Whether the last channel is alpha (see ``core.planes.resolve_alpha``).

    Returns
    -------
    (low, high) : tuple of float
        (0, 255) for uint8; otherwise the 0.5th and 99.5th percentiles of the
        finite values, equal bit for bit to ``numpy.percentile`` on the same
        values held in memory ((0, 1) without finite values, ``high = low + 1``
        for a constant image, see ``core.tone_scale.separated_limits``). Passing them as ``tone_limits`` renders exactly
        what ``labyrinth`` renders without them.

    Notes
    -----
    A dask array is never loaded whole: 8- and 16-bit integers take one pass
    over the data (a count of every value); other types take a min/max pass,
    a histogram pass and a pass that gathers the distinct values of the bins
    holding the order statistics (more only for extremely concentrated data,
    or values beside far outliers: then a min/max pass of a bin's own values
    and a histogram over their range).
    Memory stays within a few blocks and a few MB of partial results.
    """
    values = without_alpha(image, channel_axis, alpha)
    if not is_lazy(values):
        scale = resolve_tone_scale(np.asarray(values), None)
        return scale.low, scale.high
    if np.dtype(values.dtype) == np.uint8:
        return 0.0, 255.0
    result = percentiles(values, DEFAULT_PERCENTILES)
    if result is None:
        return 0.0, 1.0
    return separated_limits(*result)


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
    import dask

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


# -- running blocks -------------------------------------------------------------------------------


def current_client():
    """The ``dask.distributed`` client dask computes with, or None."""
    if "distributed" not in sys.modules:
        return None
    from distributed import default_client

    try:
        return default_client()
    except ValueError:
        return None


def block_locations(chunks: tuple[tuple[int, ...], ...]) -> list[tuple[tuple[int, int], ...]]:
    """``((start, stop), ...)`` of every block, in C order (that of ``to_delayed().ravel()``)."""
    starts = [np.concatenate(([0], np.cumsum(c))) for c in chunks]
    return [
        tuple((int(s[i]), int(s[i + 1])) for s, i in zip(starts, index))
        for index in np.ndindex(tuple(len(c) for c in chunks))
    ]


def run_blocks(
    array,
    write: Callable[[np.ndarray, tuple[tuple[int, int], ...]], Any],
    *,
    plane_axes: Sequence[int] = (-2, -1),
    on_client: bool = False,
    progress: ProgressCallback | None = None,
) -> None:
    """Compute every block of a dask array and pass it to ``write(block, location)``.

    Parameters
    ----------
    array : dask array
    write : callable
        ``write(block, ((start, stop), ...))``. Called inside the tasks (by
        the local threads or by the cluster's workers, so it must pickle and
        be safe to call concurrently on different blocks) unless
        ``on_client``.
    plane_axes : sequence of int, optional
        The axes of a plane: the others count the planes for ``progress``.
    on_client : bool, optional
        Bring every block to this process and call ``write`` here, one at a
        time (for a file only this process can write). Only makes a
        difference under a ``dask.distributed`` client.
    progress : callable, optional
        ``progress(planes_done, planes_total)`` after each block.

    Notes
    -----
    Memory: the local scheduler runs one chain of tasks (read, render,
    write) per thread and keeps no rendered block once written; on a cluster
    the workers write (or the blocks come back as they finish and are
    written and released at once).
    """
    plane_axes = {axis % array.ndim for axis in plane_axes}
    lead = [axis for axis in range(array.ndim) if axis not in plane_axes]
    total = int(np.prod([array.shape[axis] for axis in lead]))
    client = current_client()
    if client is not None and on_client:
        _run_on_client(client, array, write, lead, total, progress)
        return
    counts = array.map_blocks(
        _write_block,
        write=write,
        lead=tuple(lead),
        dtype=np.int64,
        chunks=tuple((1,) * len(c) for c in array.chunks),
        meta=np.empty((0,) * array.ndim, dtype=np.int64),
    )
    if client is not None:
        _run_futures(client, counts, total, progress)
    else:
        _run_local(counts, total, progress)


def _write_block(block, write, lead, block_info=None):
    location = tuple(tuple(pair) for pair in block_info[0]["array-location"])
    write(block, location)
    planes = int(np.prod([block.shape[axis] for axis in lead]))
    return np.full((1,) * block.ndim, planes, dtype=np.int64)


def _run_local(counts, total: int, progress: ProgressCallback | None) -> None:
    import os
    from concurrent.futures import ThreadPoolExecutor

    from dask.callbacks import Callback

    name = counts.name
    done = 0

    class _Planes(Callback):
        def _posttask(self, key, result, dsk, state, worker_id):
            nonlocal done
            if isinstance(key, tuple) and key[0] == name:
                done += int(result.sum())
                if progress is not None:
                    progress(done, total)

    # Our own pool, so that after a failure the blocks still being written
    # finish before the caller removes what they write into.
    pool = ThreadPoolExecutor(max_workers=os.cpu_count() or 1)
    try:
        with _Planes(), computing():
            counts.compute(scheduler="threads", pool=pool)
    finally:
        pool.shutdown(wait=True, cancel_futures=True)


def _run_futures(client, counts, total: int, progress: ProgressCallback | None) -> None:
    from distributed import as_completed

    futures = client.compute(list(counts.to_delayed().ravel()))
    done = 0
    try:
        for future in as_completed(futures):
            with computing():
                done += int(future.result().sum())
            future.release()
            if progress is not None:
                progress(done, total)
    except BaseException:
        _cancel_and_wait(client, futures)
        raise


def _run_on_client(client, array, write, lead, total, progress) -> None:
    from distributed import as_completed

    locations = block_locations(array.chunks)
    futures = client.compute(list(array.to_delayed().ravel()))
    where = {future.key: location for future, location in zip(futures, locations)}
    done = 0
    try:
        for future in as_completed(futures):
            with computing():
                block = future.result()
            location = where.pop(future.key)
            future.release()
            write(block, location)
            done += int(np.prod([location[axis][1] - location[axis][0] for axis in lead]))
            if progress is not None:
                progress(done, total)
    except BaseException:
        _cancel_and_wait(client, futures)
        raise


def _cancel_and_wait(client, futures, timeout: float = 60.0) -> None:
    """Cancel ``futures`` and wait until no worker still runs one of them."""
    import time

    keys = {future.key for future in futures}
    client.cancel(futures)
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        try:
            running = client.run(_executing_keys)
        except (OSError, RuntimeError, ValueError):  # the cluster is gone: nothing runs
            return
        if not keys.intersection(key for worker in running.values() for key in worker):
            return
        time.sleep(0.05)


def _executing_keys(dask_worker) -> list:
    """Keys of the tasks a worker is running (run on the worker by ``Client.run``)."""
    return [task.key for task in dask_worker.state.executing]
