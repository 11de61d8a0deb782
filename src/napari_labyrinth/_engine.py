"""The run engine: drives the numba kernel over planes, passes and threads.

A run is a generator. It yields a :class:`Progress` after every pass of
every plane and returns the rendered array and its diagnostics; closing it
(``generator.close()``) cancels the run: planes in flight stop after their
current pass, planes not started never start, and nothing is left running
when ``close`` returns. The engine knows arrays, layouts and tone scales;
argument checking and presets belong to the API.
"""

from __future__ import annotations

import _thread
import collections
import dataclasses
import functools
import heapq
import logging
import math
import os
import queue
import threading
import time
from collections.abc import Generator
from concurrent.futures import ThreadPoolExecutor
from typing import Any

import numpy as np

from ._pages import empty_in_plain_pages
from .core.codes import DIAGNOSTIC_FIELDS, OPTION_CODES, SKIPPED
from .core.parameters import LabyrinthParameters
from .core.planes import PlaneLayout
from .core.tone_scale import (
    ToneScale,
    banded_scale_arguments,
    fits_banded_pass,
    integer_plane_tones,
    write_changed_values,
    write_listed_values,
)

#: dtype of the per-pass diagnostics: one count per field of ``DIAGNOSTIC_FIELDS``.
DIAGNOSTICS_DTYPE = np.dtype([(name, np.int64) for name in DIAGNOSTIC_FIELDS])

#: Bytes of a cache line: per-thread counters are padded to whole lines.
_CACHE_LINE = 64

_LOG = logging.getLogger("napari_labyrinth")


@dataclasses.dataclass(frozen=True)
class Progress:
    """A progress event of a run: one more pass of one plane is done.

    Attributes
    ----------
    done, total : int
        Plane-passes done so far and in the whole run (every rendering of a
        sweep included; alpha planes are not rendered and not counted).
    run : int
        Which rendering of a sweep (0 otherwise).
    plane : int
        Flat index of the plane among the image's planes (colour axis last).
    pass_number : int
        Passes done on that plane, from 1.
    partial : ndarray or None
        The array this rendering fills, as :func:`render` returns it: with
        ``record_passes`` (stack mode) the plane after this pass is already in
        it, at index ``pass_number``; otherwise a plane lands in it after its
        last pass. Read it, never write to it.
    tone_limits : (float, float) or None
        The values the run maps to tones 0 and 255 (``Result.tone_limits``):
        what the passes so far look like on the tone scale they ran on, as the
        metrics read them (:meth:`~napari_labyrinth.core.tone_scale.ToneScale.to_tones`).
    """

    done: int
    total: int
    run: int
    plane: int
    pass_number: int
    partial: Any = dataclasses.field(default=None, repr=False, compare=False)
    tone_limits: tuple[float, float] | None = None


def render(
    image: np.ndarray,
    layout: PlaneLayout,
    scale: ToneScale,
    parameters: LabyrinthParameters,
    seed: int,
    *,
    record_passes: bool,
    workers: int = 1,
) -> Generator[tuple[int, int, np.ndarray], None, tuple[np.ndarray, np.ndarray]]:
    """Render every plane of ``image``; yield ``(plane, pass_number, result)`` after each pass.

    With several planes and ``workers > 1`` planes run concurrently on
    threads (the kernel holds no GIL); the workers left over (all of them
    for a single plane) go to each plane's :func:`run_pass`: its exact-order
    tiles or checkerboard bands. Returns (as the generator's
    value) the rendered image, or with ``record_passes`` the input followed by
    the image after every pass, and the diagnostics in the image's layout.
    """
    passes = parameters.passes
    source = layout.to_planes(image)
    leading = layout.leading_shape
    counts = _diagnostic_counts(layout, passes)
    planes = list(layout.rendered_indices())
    plane_workers = max(1, min(workers, len(planes)))
    banded = _banded_render(image, source, planes, parameters, max(1, workers // plane_workers))
    result, targets = _allocate(image, layout, passes, record_passes, written_whole=banded)
    stop = threading.Event()

    def passes_of(index):
        """Every pass over one plane, yielding after each; stops early once ``stop`` is set."""
        if not passes:
            return
        values = source[index]
        if banded:  # tones in and values out, band of rows by band of rows
            work = _banded_tones(values.shape, passes == 1 and not record_passes, parameters)
            changes = new_changes(values.size)
            for pass_index in range(passes):
                if stop.is_set():
                    return
                write_out = record_passes or pass_index == passes - 1
                _banded_pass(
                    values,
                    targets[pass_index if record_passes else 0][index] if write_out else None,
                    work,
                    scale,
                    parameters,
                    seed=seed,
                    plane_index=layout.stream_index(index),
                    pass_index=pass_index,
                    counts=counts[(pass_index,) + index],
                    changes=changes,
                )
                yield pass_index + 1
            return
        # integer planes: tones in one pass, and no copy of them kept (see _write_back)
        work = integer_plane_tones(scale, values)
        initial = changes = None
        if work is None:
            initial = np.ascontiguousarray(scale.to_tones(values))
            work = initial.copy()
        else:  # the pixels the passes write, for a write-back that visits only them
            changes = new_changes(work.size)
        has_nonfinite = image.dtype.kind == "f" and not np.isfinite(work).all()
        for pass_index in range(passes):
            if stop.is_set():
                return
            run_pass(
                work,
                parameters,
                seed=seed,
                plane_index=layout.stream_index(index),
                pass_index=pass_index,
                counts=counts[(pass_index,) + index],
                has_nonfinite=has_nonfinite,
                workers=max(1, workers // plane_workers),  # spare threads: tiles
                changes=changes,
            )
            if record_passes:
                _write_back(targets[pass_index][index], values, initial, work, scale, changes)
            yield pass_index + 1
        if not record_passes and passes:
            _write_back(targets[0][index], values, initial, work, scale, changes)

    flat = {index: int(np.ravel_multi_index(index, leading)) if index else 0 for index in planes}
    if plane_workers == 1:
        for index in planes:
            for pass_number in passes_of(index):
                yield flat[index], pass_number, result
    else:
        for plane, pass_number in _on_threads(
            planes, passes, passes_of, flat, plane_workers, stop
        ):
            yield plane, pass_number, result
    diagnostics = layout.to_image_layout(counts.view(DIAGNOSTICS_DTYPE)[..., 0])
    return result, np.ascontiguousarray(diagnostics)


def _allocate(
    image: np.ndarray,
    layout: PlaneLayout,
    passes: int,
    record_passes: bool,
    *,
    written_whole: bool = False,
):
    """The result (a copy of the image, or the input and a copy per pass) and, in the
    layout of planes, where each pass (or the last) is written. A large result is
    in plain pages (``_pages``): its first touches, made by the render threads,
    must not stall a GUI's event loop.

    ``written_whole``: the passes write every pixel of the planes they render
    (the banded pass), so only the others (alpha) are copied there.
    """
    if record_passes:
        result = empty_in_plain_pages((passes + 1,) + image.shape, image.dtype)
        if written_whole:
            result[0] = image
        else:
            result[...] = image
        targets = [layout.to_planes(result[k]) for k in range(1, passes + 1)]
    else:
        result = empty_in_plain_pages(image.shape, image.dtype)
        if not written_whole:
            result[...] = image
        targets = [layout.to_planes(result)]
    if written_whole:
        source = layout.to_planes(image)
        for index in np.ndindex(layout.leading_shape):
            if layout.is_alpha(index):
                for target in targets:
                    target[index] = source[index]
    return result, targets


def _banded_render(image, source, planes, parameters, plane_threads) -> bool:
    """Whether every plane renders on one thread by ``_banded_pass``: integer planes that
    are C-contiguous, in an order of rows (not the checkerboard), not in tiles."""
    if not parameters.passes or not planes or image.dtype.kind not in "iu":
        return False
    if parameters.scan == "checkerboard":
        return False
    if plane_threads > 1 and exact_order_refusal(parameters) is None:
        shape = source.shape[-2:]
        rows = default_tile(shape, 2, parameters)[0]
        if math.prod(shape) >= MIN_PARALLEL_PIXELS and shape[0] > rows:
            return False  # the plane's passes may run in tiles on several threads
    return all(fits_banded_pass(source[index]) for index in planes)


def _banded_tones(shape, only_pass, parameters) -> np.ndarray:
    """The float32 tones ``_banded_pass`` updates: a ring of one band of rows and the rows
    around it for the only pass of a plane (any border but "wrap"), else a whole plane."""
    from .core._banded_pass import band_rows

    rows = band_rows(shape[1]) + 2
    if only_pass and parameters.border != "wrap" and rows < shape[0]:
        return np.empty((rows, shape[1]), dtype=np.float32)
    return np.empty(shape, dtype=np.float32)


def _banded_pass(
    values, target, work, scale, parameters, *, seed, plane_index, pass_index, counts, changes
) -> None:
    """One pass of ``core._banded_pass.banded_pass`` over ``work``, the tones of ``values``:
    made in the first pass, and the values written into ``target`` unless it is None."""
    from .core._banded_pass import band_rows, banded_kernel  # numba is imported on first use only

    banded_pass = banded_kernel(*_variant_options(parameters))
    write_out = target is not None
    if not write_out:  # never written then, but typed as written: numba refuses a read-only
        target = np.empty((0, 0), values.dtype)  # array there (``values`` may be one)
    banded_pass(
        values,
        target,
        work,
        band_rows(values.shape[1]),
        pass_index == 0,
        write_out,
        *banded_scale_arguments(scale, values.dtype),
        *_kernel_arguments(parameters),
        np.uint64(seed),
        plane_index,
        pass_index,
        *_kernel_options(parameters),
        counts,
        changes,
    )


def _diagnostic_counts(layout: PlaneLayout, passes: int) -> np.ndarray:
    """Zeroed counts per pass and plane; alpha planes count every pixel as skipped."""
    counts = np.zeros((passes,) + layout.leading_shape + (len(DIAGNOSTIC_FIELDS),), np.int64)
    for index in np.ndindex(layout.leading_shape):
        if layout.is_alpha(index):
            counts[(slice(None),) + index + (SKIPPED,)] = math.prod(layout.plane_shape)
    return counts


def _on_threads(planes, passes, passes_of, flat, plane_workers, stop):
    """Run ``passes_of(plane)`` for every plane on a pool; yield as passes finish."""
    finished: queue.SimpleQueue = queue.SimpleQueue()  # (plane, pass) or an error

    def run(index):
        try:
            for pass_number in passes_of(index):
                finished.put((flat[index], pass_number))
        except BaseException as error:  # noqa: BLE001 - raised in the caller's thread
            finished.put(error)

    expected = len(planes) * passes
    pool = ThreadPoolExecutor(plane_workers, thread_name_prefix="napari-labyrinth")
    try:
        for index in planes:
            pool.submit(run, index)
        for _ in range(expected):
            item = finished.get()
            if isinstance(item, BaseException):
                raise item
            yield item
    finally:  # done, failed, or closed by the caller: nothing is left running
        stop.set()
        pool.shutdown(wait=True, cancel_futures=True)


def run_to_end(steps: Generator[Any, None, Any]) -> Any:
    """Run a generator to its end and return its value (the result of :func:`render`)."""
    while True:
        try:
            next(steps)
        except StopIteration as finished:
            return finished.value


def run_pass(
    tones: np.ndarray,
    parameters: LabyrinthParameters,
    *,
    seed: int = 0,
    plane_index: int = 0,
    pass_index: int = 0,
    counts: np.ndarray | None = None,
    has_nonfinite: bool | None = None,
    workers: int = 1,
    tile: tuple[int, int] | None = None,
    changes: np.ndarray | None = None,
) -> np.ndarray:
    """Run one pass of the numba kernel on a float32 plane of 0-255 tones, in place.

    The low-level entry point (no tone mapping, no copies, no validation of
    ``tones``): ``tones`` must be a C-contiguous 2-D float32 array.
    ``counts``, if given, is an int64 array of ``len(DIAGNOSTIC_FIELDS)`` that
    the pass increments. ``changes``, if given (see :func:`new_changes`),
    collects the flat indices of the pixels the pass writes. Returns ``counts``.

    With ``workers > 1`` a large plane runs on several threads: in the
    paper's raster order as parallelogram tiles of ``tile = (rows,
    diagonals)`` pixels (see :func:`exact_order_tiles`), bit for bit the
    result of one thread; with ``scan="checkerboard"`` in bands of rows of
    each colour. A raster plane of one band of tiles, or by default of fewer
    than ``MIN_PARALLEL_PIXELS`` pixels, runs on one thread, as does an order
    the tiles cannot reproduce (:func:`exact_order_refusal`; the
    ``napari_labyrinth`` logger says so). Without ``tile``, the tiles take no
    more threads than :func:`idle_cores`: on a core shared with a busy task,
    a tile thread would hold up the others.
    """
    labyrinth_pass = _pass_kernel(parameters)
    if counts is None:
        counts = np.zeros(len(DIAGNOSTIC_FIELDS), dtype=np.int64)
    if changes is None:  # room for none: every call compiles to the same kernel
        changes = new_changes(0)
    if has_nonfinite is None:
        has_nonfinite = not np.isfinite(tones).all()
    arguments = (tones, *_kernel_arguments(parameters), np.uint64(seed), plane_index, pass_index)
    options = (*_kernel_options(parameters), has_nonfinite)
    if parameters.scan == "checkerboard":
        _checkerboard_bands(
            labyrinth_pass, arguments, options, counts, tones.shape[0], workers, changes
        )
        return counts
    if workers > 1:
        refusal = exact_order_refusal(parameters)
        rows, diagonals = tile or default_tile(tones.shape, workers, parameters)
        if refusal is not None:
            _LOG.info("one thread for this plane: %s", refusal)
        elif tones.shape[0] > rows and (tile is not None or tones.size >= MIN_PARALLEL_PIXELS):
            if tile is None:  # by default, no more threads than idle cores
                workers = min(workers, idle_cores())
            if workers > 1:
                _exact_order(
                    labyrinth_pass, arguments, options, counts, rows, diagonals, workers, changes
                )
                return counts
    # every call gives every argument: one compiled kernel serves all of them, and
    # numba's dispatcher takes its fast path (an omitted argument costs ~90 µs a call)
    labyrinth_pass(*arguments, *options, counts, -1, 0, -1, 0, -1, changes, *_WHOLE_PLANE)
    return counts


def new_changes(pixels: int) -> np.ndarray:
    """An empty list of written pixels for :func:`run_pass` on a plane of ``pixels`` pixels.

    ``changes[0]`` counts the writes, ``changes[1:]`` holds the first ones'
    flat indices: room for a few percent of the plane (a pass writes far
    fewer pixels than it keeps); past it the write-back visits every pixel.
    """
    capacity = 0 if pixels == 0 else max(4096, pixels // 16)
    changes = np.empty(capacity + 1, dtype=np.int64)
    changes[0] = 0
    return changes


def listed_changes(changes: np.ndarray) -> np.ndarray | None:
    """The flat indices noted in ``changes``; None if they did not all fit."""
    written = int(changes[0])
    return changes[1 : written + 1] if written < changes.shape[0] else None


def _empty_copies(changes: np.ndarray, count: int) -> list[np.ndarray]:
    """``count`` empty lists of written pixels with the room of ``changes``."""
    copies = [np.empty_like(changes) for _ in range(count)]
    for copy in copies:
        copy[0] = 0
    return copies


def _gather_changes(changes: np.ndarray, parts: list[np.ndarray]) -> None:
    """Append to ``changes`` those that threads noted in lists of their own (``parts``)."""
    for part in parts:
        listed = listed_changes(part)
        written = int(changes[0])
        if listed is None or written + len(listed) >= changes.shape[0]:
            changes[0] = changes.shape[0]  # more than fit: visit every pixel
            continue
        changes[written + 1 : written + 1 + len(listed)] = listed
        changes[0] = written + len(listed)


#: ``labyrinth_pass``'s ``row_offset`` and ``plane_height`` for a plane held whole.
_WHOLE_PLANE = (0, -1)

#: Planes with fewer pixels run on one thread: the tiles would cost more than they gain.
MIN_PARALLEL_PIXELS = 256 * 256


def idle_cores() -> int:
    """The cores this process may use that run no other task now (at least 1).

    Linux counts the tasks that run or wait to run in ``/proc/loadavg`` (the
    caller is one of them). The tiles of one plane wait on each other: a tile
    thread that shares its core with a busy task holds up the others, and
    two threads on one free core run slower than one thread, so a pass takes
    no more threads than there are idle cores. A count is an instant: a task
    that runs for a moment (a kernel thread, a short command) would cost a
    whole pass its threads. So a core counts as busy only if another task ran
    in two readings at least ``_SETTLE`` seconds apart: the last reading of
    the previous ``_MEMORY`` seconds that is old enough, or else a second
    reading taken ``_SETTLE`` seconds later (only when the first saw a task).
    Elsewhere: every core.
    """
    cores = len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else os.cpu_count()
    cores = cores or 1
    others = _other_tasks()
    if others is None:
        return cores
    now = time.monotonic()
    earlier = [seen for at, seen in _READINGS if _SETTLE <= now - at <= _MEMORY]
    _READINGS.append((now, others))
    if others and not earlier:  # nothing to compare with: look again a moment later
        time.sleep(_SETTLE)
        again = _other_tasks()
        _READINGS.append((time.monotonic(), others if again is None else again))
        earlier = [others if again is None else again]
    return max(1, cores - min(others, earlier[-1] if earlier else others))


#: Seconds between two readings of ``idle_cores`` that must both see a task.
_SETTLE = 0.002

#: Seconds during which ``idle_cores`` uses a reading of an earlier call.
_MEMORY = 1.0

#: ``(time.monotonic(), other tasks)`` of the last readings of ``idle_cores``.
_READINGS: collections.deque = collections.deque(maxlen=16)


def _other_tasks() -> int | None:
    """Tasks that run or wait to run now besides the caller (``/proc/loadavg``); None
    where it cannot be read."""
    try:
        with open("/proc/loadavg", encoding="ascii") as loadavg:
            running = int(loadavg.read().split()[3].split("/")[0])
    except (OSError, ValueError, IndexError):
        return None
    return max(0, running - 1)


def exact_order_refusal(parameters: LabyrinthParameters) -> str | None:
    """Why the parallelogram tiles cannot reproduce the scan of ``parameters``; None if they can.

    The tiles need every pixel to read no neighbour outside its 3 x 3
    neighbourhood and, in that neighbourhood, the row above and the pixel to
    its left updated, the rest not yet: the raster scan with the borders
    ``"inside"``, ``"mirror"`` and ``"nearest"`` (each reads its 3 x 3
    neighbourhood, mirrored or repeated onto itself).
    """
    if parameters.scan == "serpentine":
        return "scan='serpentine' runs odd rows right to left, which the tiles cannot follow"
    if parameters.scan != "raster":
        return f"scan={parameters.scan!r} has its own order"
    if parameters.border == "wrap":
        return "border='wrap' makes the first rows and columns neighbours of the last ones"
    return None


def default_tile(
    shape: tuple[int, int], workers: int, parameters: LabyrinthParameters | None = None
) -> tuple[int, int]:
    """``(rows, diagonals)`` of the tiles of a plane for ``workers`` threads.

    Enough bands (16 per worker, up to 64 rows) and tiles per band (up to 2 per
    worker) that the threads soon all run and seldom wait on each other, tiles
    large enough that their cost is small (``benchmarks/bench_parallel.py
    --sections tiles model`` measures both). A pass that tests Eq. 2 first
    (``condition_order="mean_first"``, the paper's) keeps most pixels after
    Eq. 2 alone and costs about a sixth of one that tests Eq. 4 first: its
    bands are twice as tall (8 per worker, up to 128 rows), which halves the
    tiles' cost per pixel (paper, 2048², tiles on one thread, CPU time over
    the serial pass: about 6 % -> 4-5 %; on 2 threads as fast or faster).
    """
    height, width = shape
    cheap = parameters is not None and parameters.condition_order == "mean_first"
    bands = 8 if cheap else 16  # per worker
    rows = int(np.clip(height // (bands * workers), 16, 128 if cheap else 64))
    return rows, int(np.clip(width // (2 * workers), 128, 512))


def exact_order_tiles(shape: tuple[int, int], rows: int, diagonals: int) -> list[list[int]]:
    """The parallelogram tiles of a plane, band by band of ``rows`` rows.

    Tile j of band i holds the pixels with ``i * rows <= y < (i + 1) * rows``
    and ``j * diagonals <= x + y < (j + 1) * diagonals``. In coordinates
    (y, s = x + y) a pixel's neighbours that the raster scan updates before it
    lie at (-1, -2), (-1, -1), (-1, 0) and (0, -1), those it updates after it
    at (0, 1), (1, 0), (1, 1) and (1, 2). So a tile reads tiles (i - 1, j - 1),
    (i - 1, j) and (i, j - 1) updated and tiles (i, j + 1), (i + 1, j) and
    (i + 1, j + 1) not yet, and no other: tile (i, j) may run as soon as
    tile (i - 1, j) (or the whole band above, past its last tile) and tile
    (i, j - 1) are done, beside any other tile. Returns, for every band, the
    indices j of its non-empty tiles.
    """
    height, width = shape
    bands = []
    for row_start in range(0, height, rows):
        row_stop = min(height, row_start + rows)
        bands.append(list(range(row_start // diagonals, (row_stop + width - 2) // diagonals + 1)))
    return bands


def _exact_order(
    labyrinth_pass, arguments, options, counts, rows, diagonals, workers, changes=None
) -> None:
    """Run the tiles of ``exact_order_tiles`` on threads, each as soon as it may run.

    The tiles that may run wait in a queue, the upper band first; a free
    thread takes the next one, runs it (the kernel holds no GIL), then queues
    the tiles it freed: the next of its band and the waiting one of the band
    below. A thread with nothing to take sleeps on a condition variable (never
    spins), and a thread that the system holds back holds up only the tiles
    that need its own: the others take the rest of the plane meanwhile.
    """
    tones = arguments[0]
    height = tones.shape[0]
    tiles = exact_order_tiles(tones.shape, rows, diagonals)
    bands = len(tiles)
    workers = min(workers, bands)
    position = [0] * bands  # the index in tiles[band] of the band's next tile
    finished = [0] * bands  # the band is done up to (not including) tile j = finished[band]
    waiting = [True] * bands  # neither queued nor running
    ready: list[int] = []  # bands whose next tile may run (a heap: the upper band first)
    remaining = [sum(map(len, tiles))]
    changed = threading.Condition()
    band_counts = padded_counts(workers)
    if changes is None:
        changes = new_changes(0)
    worker_changes = _empty_copies(changes, workers)  # each thread notes its own
    failed: list[BaseException] = []

    def queue_if_ready(band):
        """Queue ``band`` if its next tile may run (called holding ``changed``); 1 if queued."""
        if band >= bands or not waiting[band] or position[band] == len(tiles[band]):
            return 0
        j = tiles[band][position[band]]
        if band == 0 or finished[band - 1] >= min(j, tiles[band - 1][-1]) + 1:
            waiting[band] = False
            heapq.heappush(ready, band)
            return 1
        return 0

    head = (*arguments, *options)
    sleeping = [0]  # threads waiting on ``changed``: woken only if there is work for them

    def work(worker):
        own_counts, own_changes = band_counts[worker], worker_changes[worker]
        band = j = -1
        try:
            while True:
                with changed:  # one hold per tile: the last one's end, the next one's start
                    if band >= 0:
                        finished[band] = j + 1
                        position[band] += 1
                        remaining[0] -= 1
                        waiting[band] = True
                        freed = queue_if_ready(band) + queue_if_ready(band + 1)
                        if freed and sleeping[0]:
                            changed.notify(freed)
                    while not ready and remaining[0] and not failed:
                        sleeping[0] += 1
                        changed.wait()
                        sleeping[0] -= 1
                    if failed or not remaining[0]:
                        changed.notify_all()  # the others stop too
                        return
                    band = heapq.heappop(ready)
                    j = tiles[band][position[band]]
                labyrinth_pass(
                    *head, own_counts, -1, band * rows, min(height, (band + 1) * rows),
                    j * diagonals, (j + 1) * diagonals, own_changes, *_WHOLE_PLANE,
                )  # fmt: skip
        except BaseException as error:  # noqa: BLE001 - raised in the caller's thread
            with changed:
                failed.append(error)
                changed.notify_all()

    queue_if_ready(0)
    # threading.Thread.start() waits until the new thread runs: 0.1-0.2 ms, and
    # milliseconds when its core is busy, while only the first tile can run. So the
    # helpers start without a wait, and each releases its lock when it is done.
    done = [_start_helper(work, k) for k in range(1, workers)]
    work(0)
    for lock in done:
        lock.acquire()
    if failed:
        raise failed[0]
    counts += band_counts[:, : len(DIAGNOSTIC_FIELDS)].sum(axis=0)
    _gather_changes(changes, worker_changes)


def _start_helper(work, worker: int) -> threading.Lock:
    """Start ``work(worker)`` on a new thread without waiting for it to run; the returned
    lock is held until ``work`` has returned (acquire it to wait for that)."""
    done = threading.Lock()
    done.acquire()

    def run():
        try:
            work(worker)
        finally:
            done.release()

    try:
        _thread.start_new_thread(run, ())
    except RuntimeError:  # no thread to be had: the others take its tiles
        done.release()
    return done


def padded_counts(rows: int) -> np.ndarray:
    """Zeroed ``(rows, 8)`` int64 counts, each row a whole, aligned cache line.

    Threads that write counts of their own never share a cache line.
    """
    stride = max(len(DIAGNOSTIC_FIELDS), _CACHE_LINE // 8)
    raw = np.zeros(rows * stride + _CACHE_LINE // 8, dtype=np.int64)
    offset = (-raw.ctypes.data % _CACHE_LINE) // 8
    return raw[offset : offset + rows * stride].reshape(rows, stride)


def _checkerboard_bands(
    labyrinth_pass, arguments, options, counts, height, workers, changes
) -> None:
    """The four colours in turn, the rows of each split among ``workers`` threads."""
    bands = np.linspace(0, height, min(workers, max(1, height // 2)) + 1).astype(int)
    band_counts = padded_counts(len(bands) - 1)
    band_changes = _empty_copies(changes, len(bands) - 1)
    for colour in range(4):  # the pixels of one colour are independent of each other
        if len(bands) == 2:
            labyrinth_pass(
                *arguments, *options, band_counts[0], colour, 0, height, 0, -1, band_changes[0],
                *_WHOLE_PLANE,
            )  # fmt: skip
            continue
        with ThreadPoolExecutor(len(bands) - 1) as pool:
            for future in [
                pool.submit(
                    labyrinth_pass, *arguments, *options, band_counts[k], colour, start, stop,
                    0, -1, band_changes[k], *_WHOLE_PLANE,
                )  # fmt: skip
                for k, (start, stop) in enumerate(zip(bands[:-1], bands[1:]))
            ]:
                future.result()
    counts += band_counts[:, : len(DIAGNOSTIC_FIELDS)].sum(axis=0)
    _gather_changes(changes, band_changes)


@functools.lru_cache(maxsize=64)
def _kernel_arguments(parameters: LabyrinthParameters) -> tuple[Any, ...]:
    """Thresholds, range limits, T_inf, T_sup and max tries as the kernel takes them."""
    range_bounds = np.array(parameters.tone_ranges[1:-1], dtype=np.float64)
    tone_low = np.array([low for low, _ in parameters.tones], dtype=np.float64)
    tone_high = np.array([high for _, high in parameters.tones], dtype=np.float64)
    return (
        parameters.mean_threshold,
        parameters.variance_threshold,
        range_bounds,
        tone_low,
        tone_high,
        parameters.max_tries,
    )


def _variant_options(parameters: LabyrinthParameters) -> tuple[int, bool]:
    """The options that select the kernel's compiled variant: ``condition_order``'s code
    and ``include_centre`` (``core._kernel.pass_kernel``)."""
    return OPTION_CODES["condition_order"][parameters.condition_order], parameters.include_centre


def _pass_kernel(parameters: LabyrinthParameters):
    """The numba kernel of one pass (``labyrinth_pass``) compiled for ``parameters``."""
    from .core._kernel import pass_kernel  # numba is imported on first use only

    return pass_kernel(*_variant_options(parameters))


@functools.lru_cache(maxsize=64)
def _kernel_options(parameters: LabyrinthParameters) -> tuple[Any, ...]:
    """The options' codes in the order of ``codes.OPTION_CODES``, then ``include_centre``."""
    codes = tuple(codes[getattr(parameters, name)] for name, codes in OPTION_CODES.items())
    return (*codes, parameters.include_centre)


def _write_back(target, values, initial, work, scale, changes) -> None:
    """The changed tones' values into ``target``: fused for an integer plane (no ``initial``),
    at the pixels the passes wrote if ``changes`` holds them all."""
    listed = None if changes is None else listed_changes(changes)
    if listed is not None:
        write_listed_values(scale, target, values, work, listed)
    elif initial is None:
        write_changed_values(scale, target, values, work)
    else:
        write_changes(target, initial, work, scale)


def write_changes(
    target: np.ndarray, initial: np.ndarray, work: np.ndarray, scale: ToneScale
) -> None:
    """Map back into ``target`` (holding the source values) the tones that changed."""
    changed = initial.view(np.uint32) != work.view(np.uint32)
    target[changed] = scale.from_tones(work[changed], target.dtype)
