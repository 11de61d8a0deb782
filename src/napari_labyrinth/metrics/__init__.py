"""Numbers that describe a labyrinthine tiling and the edges it enhances.

Every metric works on 2-D grayscale planes of any real dtype and is
deterministic. Images are compared on the same footing by converting them to
float64; metrics that compare an input with its rendering take both on the
same tone scale (for uint8, the paper's 0-255).

The fine-scale component of an image, used by several metrics, is
``h = g - G_1 * g`` (the image minus its Gaussian blur with sigma 1 pixel):
it holds the 1-3 pixel structure that the tiling draws.

:func:`describe` computes every metric at once, sharing the maps they have in
common; :func:`describe_steps` yields them one at a time (a caller can stop
between two), and :class:`Comparison` keeps the maps of an original for the
renderings of it that follow (the passes of a stack). The heavy work runs in
numba kernels (:mod:`._metrics_kernels`) that release the GIL, on
``workers`` threads. The Gaussian windows, the fine-scale component and the
wall map are those of ``scipy.ndimage.gaussian_filter``, bit for bit; the
structure tensors are float32, and those behind ``orientation_coherence``
and ``contour_alignment`` are decimated: the window is within a few per cent
of :func:`orientation`'s (see :mod:`._metrics_kernels` and ``docs/metrics.md``).
"""

from __future__ import annotations

import _thread
import collections
import dataclasses
import math
import os
import sys
import threading
import weakref
from collections.abc import Callable, Iterator
from typing import Any, NamedTuple

import numpy as np

from ..core.parameters import WORKERS, Parameter
from ..core.tone_scale import resolve_tone_scale, validate_tone_limits
from ._lazy_kernels import _numba_kernels, _weights

#: Window (Gaussian sigma, pixels) over which local statistics are averaged.
WINDOW_SIGMA = 2.0

#: Local lag-1 correlation along the walls above which texture counts as walls.
ALONG_THRESHOLD = 0.3

#: Walls alternate with gaps across them: the local correlation across at lag w
#: (w = 1 or 2 pixels, the wall width) must be below -ALTERNATION_THRESHOLD and
#: at lag 2w above +ALTERNATION_THRESHOLD. A single edge anti-correlates at lag
#: w but does not come back at 2w.
ALTERNATION_THRESHOLD = 0.1

#: Local RMS of the fine-scale component (tones) below which a region is flat.
ENERGY_FLOOR = 6.0

#: Least fraction of wall pixels for the wall metrics to be defined (else NaN).
MIN_COVER = 0.01

#: Gaussian sigma of the input's contours in :func:`contour_alignment`.
CONTOUR_SIGMA = 4.0

#: The Gaussian sigma (pixels) of a structure tensor's window: :func:`orientation`'s
#: ``sigma``. Below the least, every window is one pixel wide (from about 0.08 on, the
#: next weight is below float32's resolution). The largest, the scale of a large image's
#: broadest contours, bounds the rows a thread holds smoothed (``16 * sigma + 2`` of a
#: tile: ``_FULL_WIDTH_RING_BYTES``) and the time, which grows with sigma (at the
#: largest, about a minute for a 2048 x 2048 plane on two cores).
SIGMA = Parameter(
    name="sigma",
    kind="float",
    paper=None,
    low=0.01,
    high=256.0,
    label="sigma",
    equation="metrics",
    doc="Gaussian sigma (pixels) of the structure tensor's window",
)

#: :func:`contour_alignment`'s ``contour_sigma``: the bounds of :data:`SIGMA`.
CONTOUR_SIGMA_PARAMETER = dataclasses.replace(
    SIGMA,
    name="contour_sigma",
    label="contour sigma",
    doc="Gaussian sigma (pixels) of the structure tensor of the input's contours",
)

#: The metrics, in the order :func:`describe` and :func:`describe_steps` give them.
METRICS = (
    "texture_added",
    "labyrinth_cover",
    "wall_width",
    "orientation_coherence",
    "contour_alignment",
    "edge_enhancement",
)

# Lag vectors (dy, dx) of the four lattice directions (their normals: (1, 0), (0, 1),
# (1, -1), (1, 1); see _metrics_kernels.FAMILIES).
_DIRECTIONS = ((0, 1), (1, 0), (1, 1), (1, -1))

#: Least sigma (pixels) of the walls' and contours' structure tensors computed on the
#: original grid after a 1-2-1 filter of the doubled grid's products
#: (``_metrics_kernels.decimated_tensor_band``); below, that filter's variance would be
#: too large a part of the window's, and the tensor is the doubled grid's.
_DECIMATED_SIGMA = 1.0

#: Rows per band below which a plane is not split into more bands.
_MIN_BAND_ROWS = 64
#: A band takes ``1 / (_SHARES_PER_WORKER * workers)`` of the rows left (``_guided_edges``).
_SHARES_PER_WORKER = 2


def _plane(image, name="image") -> np.ndarray:
    array = np.asarray(image)
    if array.ndim != 2:
        raise ValueError(f"{name} must be a 2-D grayscale plane, got shape {array.shape}")
    if array.dtype.kind not in "uif" or array.dtype == np.bool_:
        raise TypeError(f"{name} must hold real numbers, got dtype {array.dtype}")
    if min(array.shape) < 3:
        raise ValueError(f"{name} must be at least 3 x 3 pixels, got shape {array.shape}")
    return array


def _float_plane(array: np.ndarray, *, copy: bool = False) -> np.ndarray:
    """A C-contiguous float64 copy of (or, with ``copy=False``, view on) a checked plane."""
    if copy:
        return np.array(array, dtype=np.float64, order="C", copy=True)
    return np.ascontiguousarray(array, dtype=np.float64)


#: Dtypes the kernels read as they are: every value is exact in float64, and every
#: kernel's arithmetic on a plane's value starts by combining it with a float64 (a
#: sum of two of them is taken in 64-bit integers, also exact), so the maps are those
#: of the plane's float64 copy, bit for bit. A copy of such a plane takes 1 or 2 bytes
#: a pixel instead of float64's 8 (new memory, whose first touch is slow: ``_Pool``).
#: Signed integers are not among them (``abs`` of the most negative value overflows),
#: nor float32 (a sum of two float32 values is rounded to float32).
_KERNEL_DTYPES = (np.dtype(np.uint8), np.dtype(np.uint16))


def _kernel_dtype(dtype) -> np.dtype:
    """The dtype of the copy of a plane of ``dtype`` that the kernels read."""
    dtype = np.dtype(dtype)
    return dtype if dtype in _KERNEL_DTYPES else np.dtype(np.float64)


def _kernel_plane(array: np.ndarray, *, copy: bool = False) -> np.ndarray:
    """A checked plane as the kernels read it: C-contiguous, in :func:`_kernel_dtype`; a
    view when it already is, unless ``copy``."""
    dtype = _kernel_dtype(array.dtype)
    if copy:
        return np.array(array, dtype=dtype, order="C", copy=True)
    return np.ascontiguousarray(array, dtype=dtype)


def _same_shape(before: np.ndarray, after: np.ndarray) -> None:
    if before.shape != after.shape:
        raise ValueError(f"original {before.shape} and rendered {after.shape} differ in shape")


def _validate_workers(workers: Any) -> int | None:
    """``workers`` checked as ``labyrinth(workers=...)`` checks it (:data:`WORKERS`);
    None (every core) stays None."""
    return None if workers is None else WORKERS.validate(workers)


def _default_workers() -> int:
    try:
        cores = len(os.sched_getaffinity(0))
    except AttributeError:  # pragma: no cover - not on Linux
        cores = os.cpu_count() or 1
    return min(max(1, cores), WORKERS.high)


def _in_bands(kernel: Callable, height: int, workers: int | None, *arguments) -> list:
    """``kernel(*arguments, y0, y1)`` on bands of rows covering ``[0, height)``, on threads.

    The rows are cut into bands that get smaller towards the end
    (:func:`_guided_edges`), which the calling thread and ``workers - 1``
    others take one at a time, in order: a band of rows that holds more work
    (walls, texture) does not hold up the others, and the last bands taken
    are short, so the threads finish close together. The kernels' results do
    not depend on the bands; the list of their return values is in the order
    of the bands.

    The calling thread starts on the bands at once and waits only for the
    bands other threads took: a helper thread that runs late (its core
    busy: a thread's start waits 0.2 ms for it to run, milliseconds when
    the other core is busy) finds the bands taken and ends without work.
    """
    workers = _default_workers() if workers is None else max(1, int(workers))
    if workers == 1 or height < 2 * _MIN_BAND_ROWS:
        return [kernel(*arguments, 0, height)]
    edges = _guided_edges(height, workers)
    count = len(edges) - 1
    results: list = [None] * count
    failures: list[BaseException] = []
    state = {"next": 0, "running": 0}
    changed = threading.Condition()

    def work() -> None:
        while True:
            with changed:
                index = state["next"]
                if index >= count or failures:
                    return
                state["next"] = index + 1
                state["running"] += 1
            try:
                results[index] = kernel(*arguments, edges[index], edges[index + 1])
            except BaseException as exc:  # raised in the calling thread below
                failures.append(exc)
            finally:
                with changed:
                    state["running"] -= 1
                    changed.notify_all()

    for _ in range(min(workers, count) - 1):
        try:
            _thread.start_new_thread(work, ())
        except RuntimeError:  # no thread to be had: the calling thread takes its bands
            break
    work()
    with changed:
        changed.wait_for(lambda: state["running"] == 0)
    if failures:
        raise failures[0]
    return results


def _guided_edges(height: int, workers: int) -> list[int]:
    """Edges ``[0, ..., height]`` of bands of rows that get smaller towards the end.

    Each band takes ``1 / (_SHARES_PER_WORKER * workers)`` of the rows left (at
    least ``_MIN_BAND_ROWS``; the last takes a remainder shorter than that
    too). Equal bands leave the threads waiting for the last one taken, whose
    work varies with the walls in it (a 2048² plane's wall pass in 8 bands
    left up to 17 ms of one of two cores idle); here the threads end within
    one short band of each other, at the cost of a few more bands (11 for
    2048 rows on 2 threads, each with its rows of margin).
    """
    edges, start = [0], 0
    while start < height:
        left = height - start
        rows = max(_MIN_BAND_ROWS, -(-left // (_SHARES_PER_WORKER * workers)))
        if left - rows < _MIN_BAND_ROWS:
            rows = left
        start += rows
        edges.append(start)
    return edges


def _copy_rows(target: np.ndarray, source: np.ndarray, y0: int, y1: int) -> None:
    np.copyto(target[y0:y1], source[y0:y1], casting="unsafe")  # real dtypes: exact in float64


def _copy_in_bands(target: np.ndarray, source: np.ndarray, workers: int | None) -> None:
    """``target[...] = source`` on bands of rows, on threads (numpy's copy releases the GIL).

    A first copy into a new array is mostly its page faults (a 2048 x 2048
    float64 plane is 32 MB of memory the process may never have touched):
    threads share them.
    """
    _in_bands(_copy_rows, source.shape[0], workers, target, source)


class _LastPlane:
    """A thread-safe cache of one value: the one computed for the last plane's content.

    A plane matches when it equals the kept copy of a plane, value for value
    (NaN matching NaN): the metrics depend on nothing else. Comparing costs
    a read of both planes, less than hashing one.
    """

    def __init__(self):
        self._entry: tuple[Any, np.ndarray, Any] | None = None
        self._lock = threading.Lock()

    def get(self, key, array: np.ndarray, make: Callable[[np.ndarray], tuple[np.ndarray, Any]]):
        """The value kept for (``key``, ``array``'s content), or ``make(array)``'s.

        ``make`` returns the copy of ``array`` it keeps (:func:`_kernel_plane`) and the value.
        """
        with self._lock:
            entry = self._entry
        if (
            entry is not None
            and entry[0] == key
            and entry[1].shape == array.shape
            and np.array_equal(entry[1], array, equal_nan=array.dtype.kind == "f")
        ):
            return entry[2]
        plane, value = make(array)  # outside the lock: another thread may compute it too
        with self._lock:
            self._entry = (key, plane, value)
        return value


class _Pool:
    """Arrays of maps that are done, for the next maps of the same shape.

    A fresh array costs its page faults: a first describe writes about 41
    bytes a pixel of new maps and plane copies, and a virtual machine may
    have to have its host back them first (``docs/metrics.md``). The passes
    of a stack, and the next original of the same shape, take the arrays of
    the last ones instead. Thread-safe. Keeps the arrays of one shape only
    (those of the last array given back), at most ``pixel_bytes`` bytes a
    pixel of it, and drops them all ``idle`` seconds after the last array
    was given back (a timer thread waits that long).
    """

    def __init__(self, pixel_bytes: int = 96, idle: float = 10.0):
        self._pixel_bytes = pixel_bytes
        self._idle = idle
        self._shape: tuple | None = None
        self._arrays: dict[str, list[np.ndarray]] = {}
        self._returned: collections.deque = collections.deque()  # see give_later
        self._timer: threading.Timer | None = None
        self._lock = threading.Lock()

    def take(self, shape: tuple, dtype) -> np.ndarray:
        shape = tuple(shape)
        with self._lock:
            self._drain()
            arrays = self._arrays.get(np.dtype(dtype).str) if shape == self._shape else None
            if arrays:
                return arrays.pop()
        return np.empty(shape, dtype=dtype)

    def give(self, arrays) -> None:
        with self._lock:
            self._drain()
            self._keep(arrays)
            self._restart_timer()

    def give_later(self, arrays) -> None:
        """:meth:`give` that never waits: for finalizers, which the garbage collector may
        run in any thread, even one inside :meth:`give` (it holds the lock)."""
        self._returned.append(arrays)
        if self._lock.acquire(blocking=False):
            try:
                self._drain()
                self._restart_timer()
            finally:
                self._lock.release()

    def clear(self) -> None:
        """Drop every array kept."""
        with self._lock:
            self._returned.clear()
            self._arrays.clear()

    @property
    def nbytes(self) -> int:
        """Bytes of the arrays kept."""
        with self._lock:
            self._drain()
            return sum(a.nbytes for v in self._arrays.values() for a in v)

    def _drain(self) -> None:
        """Keep the arrays given back by :meth:`give_later` (the lock held)."""
        while self._returned:
            self._keep(self._returned.popleft())

    def _keep(self, arrays) -> None:
        for array in arrays:
            if array.base is not None:
                continue  # a view: its base may be in use
            if array.shape != self._shape:
                self._arrays.clear()
                self._shape = array.shape
            kept = sum(a.nbytes for v in self._arrays.values() for a in v)
            if kept + array.nbytes > self._pixel_bytes * array.size:
                continue
            array.flags.writeable = True
            self._arrays.setdefault(array.dtype.str, []).append(array)

    def _restart_timer(self) -> None:
        if self._timer is not None:
            self._timer.cancel()
        self._timer = threading.Timer(self._idle, self.clear)
        self._timer.name = "metrics-pool-release"
        self._timer.daemon = True
        self._timer.start()


#: The pool of every :class:`Comparison`: a stack's passes and the next original of the
#: same shape reuse the memory of the last ones.
_SHARED_POOL = _Pool()


class _Maps:
    """The maps of one plane (:func:`_kernel_plane`), each computed on first use, once
    (thread-safe).

    ``plane`` must not change while the object is in use: callers pass a
    private copy or a plane that lives only for the call. With a ``pool``,
    the maps' arrays come from it and :meth:`release` gives them back.
    """

    def __init__(
        self,
        plane: np.ndarray,
        workers: int | None = None,
        pool: _Pool | None = None,
        *,
        walls: bool = True,
    ):
        self.plane = plane
        self.workers = workers
        self._walls_expected = walls  # False: h's float32 copy is made only if asked for
        self._pool = pool
        self._taken: list[np.ndarray] = []
        self._lock = threading.RLock()
        self._values: dict[Any, Any] = {}

    def _empty(self, dtype=np.float64) -> np.ndarray:
        """A new plane-shaped array (from the pool, if any)."""
        if self._pool is None:
            return np.empty(self.plane.shape, dtype=dtype)
        array = self._pool.take(self.plane.shape, dtype)
        self._taken.append(array)
        return array

    def _float32_pair(self) -> tuple[np.ndarray, np.ndarray]:
        """Two new plane-shaped float32 arrays in one float64 array of the pool (in a first
        describe, the bytes of a rendering's ``h``: :meth:`give_back_fine`)."""
        pair = self._empty(np.float64)
        first, second = pair.reshape(-1).view(np.float32).reshape(2, *self.plane.shape)
        return first, second

    def give_back_fine(self) -> None:
        """Give ``h`` and its float32 copy back to the pool once the maps that read them are
        made (the wall map and the walls' orientation; the energy is the wall pass's).

        The original's contours, made next, take those bytes instead of new
        memory (12 bytes a pixel, whose first touch is slow: :class:`_Pool`).
        Afterwards :meth:`fine` has no ``h``.
        """
        with self._lock:
            if self._pool is None or not {"walls", "wall_orientation"} <= self._values.keys():
                return
            fine = self._values["fine"]
            arrays = [a for a in (fine.fine, fine.fine32) if any(a is t for t in self._taken)]
            self._taken = [t for t in self._taken if not any(t is a for a in arrays)]
            self._values["fine"] = fine._replace(fine=None, fine32=np.empty((1, 1), np.float32))
        self._pool.give(arrays)

    def release(self) -> None:
        """Give the maps' arrays back to the pool; the object must not be used afterwards."""
        if self._pool is not None:
            with self._lock:
                self._values.clear()
                self._pool.give(self._taken)
                self._taken = []

    def _get(self, name: str, compute: Callable[[], Any]):
        with self._lock:
            if name not in self._values:
                self._values[name] = compute()
            return self._values[name]

    def _bands(self, kernel, *arguments) -> list:
        return _in_bands(kernel, self.plane.shape[0], self.workers, *arguments)

    def fine(self) -> tuple[np.ndarray, float]:
        """``h = g - G_1 * g`` and ``sum(h**2)``."""
        fine = self._full_fine()
        return fine.fine, fine.total

    def _fine(self) -> _Fine:
        """``h``'s sums, and ``h`` itself if a pass kept it: none does for an original's maps
        (made with ``walls=False``) that no one asked for ``h`` (see :meth:`_original`), nor
        for a rendering's energy alone (:meth:`energy`); :meth:`_full_fine` always has
        ``h``."""
        with self._lock:
            for name in ("fine", "sums"):
                if name in self._values:
                    return self._values[name]
            if not self._walls_expected:
                return self._original()[0]
        return self._full_fine()

    def measure_fine(self) -> None:
        """Make ``h``'s sums alone (no map kept) unless a pass made them (for
        :func:`texture_added`)."""

        def compute():
            return self._fine_sums(None, _NOT_MADE32, self._fine_pass(*_NOT_MADE_MAPS))

        with self._lock:
            if not {"fine", "original"} & self._values.keys():
                self._get("sums", compute)

    def _original(self) -> tuple[_Fine, np.ndarray, float, np.ndarray, np.ndarray]:
        """An original's sums of ``h``, energy and the energy's sum (``h`` never kept whole),
        and its Sobel magnitude with that kernel's sums, all in one pass."""

        def compute():
            energy = self._empty()
            edges = self._empty()
            sums = self._fine_pass(_NOT_MADE, _NOT_MADE32, energy, edges)
            total = math.fsum(sums[:, 4])
            with self._lock:
                self._values.setdefault("energy", (energy, total))
            return self._fine_sums(None, _NOT_MADE32, sums), energy, total, edges, sums[:, 5:]

        return self._get("original", compute)

    def _fine_pass(self, fine, fine32, energy, edges) -> np.ndarray:
        """``_metrics_kernels.fine_scale_band`` on every row: the maps of the arrays of the
        plane's shape (``_NOT_MADE`` for the others), and the rows' sums."""
        sums = self._row_sums(8)
        self._bands(
            _numba_kernels().fine_scale_band,
            _numba_kernels().plane_tuple(self.plane),
            _weights(1.0),
            _weights(WINDOW_SIGMA),
            fine,
            fine32,
            energy,
            edges,
            sums,
        )
        return sums

    @staticmethod
    def _fine_sums(fine, fine32, sums) -> _Fine:
        """The :class:`_Fine` of ``h`` (None if not kept) from the rows' sums of its pass."""
        return _Fine(
            fine,
            fine32,
            math.fsum(sums[:, 0]),
            float(sums[:, 1].max()),
            not sums[:, 2].any(),
            float(sums[:, 3].max()),
        )

    def _full_fine(self) -> _Fine:
        """``h`` and its sums; where walls are expected, its float32 copy (for the walls'
        orientation) and its energy (the wall pass reads it with ``h``) too, in the same
        pass."""

        def compute():
            with self._lock:
                with_energy = self._walls_expected and "energy" not in self._values
            fine = self._empty()
            fine32 = self._empty(np.float32) if self._walls_expected else _NOT_MADE32
            energy = self._empty() if with_energy else _NOT_MADE
            sums = self._fine_pass(fine, fine32, energy, _NOT_MADE)
            if with_energy:
                with self._lock:
                    self._values.setdefault("energy", (energy, math.fsum(sums[:, 4])))
            result = self._fine_sums(fine, fine32, sums)
            scale = _float32_scale(math.sqrt(result.largest_square))
            if scale != 1.0 and self._walls_expected:  # h**2 would overflow in float32
                result = result._replace(fine32=(fine * scale).astype(np.float32))
            return result

        return self._get("fine", compute)

    @property
    def finite(self) -> bool:
        """Whether ``h`` (so the plane) holds only finite values."""
        return self._fine().finite

    def _row_sums(self, count: int) -> np.ndarray:
        """Per-row partial sums that kernels fill: the totals do not depend on the bands."""
        return np.empty((self.plane.shape[0], count))

    def _fine32(self) -> np.ndarray:
        """``h`` times a power of two in float32, for the walls' structure tensor (see
        :class:`_Fine`)."""
        fine = self._full_fine()
        if fine.fine32.shape == fine.fine.shape:
            return fine.fine32

        def compute():
            scale = _float32_scale(math.sqrt(fine.largest_square))
            return (fine.fine * scale).astype(np.float32)  # as fine_scale_band writes it

        return self._get("fine32", compute)

    def walls(self) -> tuple[np.ndarray, np.ndarray, float]:
        """The wall map, the energy ``G_2 * h**2`` and the energy's sum."""

        def compute():
            fine = self._full_fine()
            energy, total = self.energy()
            walls = self._empty(bool)
            self._bands(
                _numba_kernels().wall_band,
                fine.fine,
                _weights(WINDOW_SIGMA),
                ENERGY_FLOOR**2,
                ALONG_THRESHOLD,
                ALTERNATION_THRESHOLD,
                energy,
                walls,
            )
            return walls, energy, total

        return self._get("walls", compute)

    def energy(self) -> tuple[np.ndarray, float]:
        """The energy ``G_2 * h**2`` and its sum: made with ``h`` where the walls need them
        (:meth:`_full_fine`), with an original's other maps (:meth:`_original`), else alone
        (``h``'s sums kept, not ``h``)."""
        with self._lock:
            if "energy" in self._values:
                return self._values["energy"]
            if not self._walls_expected:
                return self._original()[1:3]

        def compute():
            energy = self._empty()
            sums = self._fine_pass(_NOT_MADE, _NOT_MADE32, energy, _NOT_MADE)
            with self._lock:
                self._values.setdefault("sums", self._fine_sums(None, _NOT_MADE32, sums))
            return energy, math.fsum(sums[:, 4])

        return self._get("energy", compute)

    def cover(self) -> float:
        walls, _, _ = self.walls()
        return int(np.count_nonzero(walls)) / walls.size

    def above_local_mean(self) -> np.ndarray:
        """``g > G_2 * g``: where the plane is above its local mean, at the wall pixels
        (False on the others: :func:`_wall_width` reads it at wall pixels only)."""

        def compute():
            positive = self._empty(bool)
            walls = self.walls()[0]
            self._bands(
                _numba_kernels().local_mean_band,
                _numba_kernels().plane_tuple(self.plane),
                _weights(WINDOW_SIGMA),
                walls,
                positive,
            )
            return positive

        return self._get("above_local_mean", compute)

    def wall_orientation(self) -> tuple[np.ndarray, ...]:
        """Where each row's wall pixels begin, then strength, coherence * strength, cos and
        sin of twice the angle, of ``h``, at the wall pixels only.

        The four maps hold the wall pixels one after the other in row-major
        order, row y's from index ``row_starts[y]`` to ``row_starts[y + 1]``
        (the maps are read on the walls only: a tenth of a plane's memory
        where walls cover a tenth of it). The strengths are those of ``h``
        times a power of two (ratios of them are exact): the tensor reads
        ``h``'s float32 copy (:meth:`_fine32`).
        """

        def compute():
            walls = self.walls()[0]
            return _wall_orientation(self._fine32(), 1.0, WINDOW_SIGMA, self.workers, walls)

        return self._get("wall_orientation", compute)

    def contours(self, sigma: float, walls: np.ndarray) -> tuple[np.ndarray, ...]:
        """The structure tensor's components ``jrr, jrc, jcc`` of the plane itself at
        ``sigma`` (its contours), on ``walls`` (at least).

        The components are kept, not the maps derived from them
        (``_metrics_kernels._derive``): the one metric that reads the
        contours reads them at the walls of a rendering (a few per cent of
        the pixels) and derives them there, the same float32 numbers.

        The maps are computed row by row of column tiles, the rows and tiles
        that hold a pixel of ``walls`` and were not computed for earlier
        walls: a stack's passes compute each part of the original's contours
        once, and only the parts some walls need.
        """
        with self._lock:
            key = ("contours", float(sigma))
            if key not in self._values:
                maps = (self._empty(np.float32), *self._float32_pair())
                tiles = _tensor_tiles(self.plane.shape[1], sigma)
                self._values[key] = (maps, np.zeros((self.plane.shape[0], tiles), dtype=bool))
            maps, done = self._values[key]
            needed = _tile_counts(walls, done.shape[1], self.workers) > 0
            needed &= ~done
            if needed.any():
                scale = _float32_scale(self._fine().largest_tone)
                _tensor(self.plane, scale, sigma, self.workers, needed, maps, components=True)
                done |= needed
            return maps

    def edges(self) -> tuple[np.ndarray, float, bool]:
        """Sobel magnitude, its mean and whether it is constant (made with the energy:
        :meth:`_original`)."""

        def compute():
            edges, sums = self._original()[3:]
            mean = math.fsum(sums[:, 2]) / edges.size
            constant = bool(sums[:, 0].min() == sums[:, 1].max())
            return edges, mean, constant

        return self._get("edges", compute)


#: What stands for a map that :meth:`_Maps._fine_pass` is not asked for (one row: the kernel
#: writes the maps of the plane's height only).
_NOT_MADE = np.empty((1, 1))
_NOT_MADE32 = np.empty((1, 1), dtype=np.float32)
_NOT_MADE_MAPS = (_NOT_MADE, _NOT_MADE32, _NOT_MADE, _NOT_MADE)


class _Fine(NamedTuple):
    fine: np.ndarray | None  # h = g - G_1 * g (None: not kept, see _Maps._original)
    fine32: np.ndarray  # h times a power of two in float32 (1 x 1 if not made: _fine32)
    total: float  # sum(h**2)
    largest_square: float  # max(h**2) over the finite values
    finite: bool  # no NaN or infinity in h
    largest_tone: float  # max(|g|) over the finite values


def _float32_scale(largest: float) -> float:
    """A power of two that brings values up to ``largest`` where float32 squares are safe.

    The scale is at most ``2**1023``, float64's largest power of two: a
    subnormal ``largest`` (below ``2**-1022``) comes up to between ``2**-51``
    and 2, still safe. Its square may leave float64's range: divide by the
    scale twice, never by ``scale**2``.
    """
    if not 0.0 < largest < math.inf or 2.0**-40 <= largest <= 2.0**40:
        return 1.0
    return math.ldexp(1.0, min(-math.frexp(largest)[1], _LARGEST_EXPONENT))


#: The exponent of float64's largest power of two.
_LARGEST_EXPONENT = sys.float_info.max_exp - 1


def _read_only(array: np.ndarray) -> np.ndarray:
    """A read-only view: what a caller gets of a shared map.

    The maps themselves stay writeable (numba compiles a kernel once per
    kind of array it is given; read-only arrays would double the kernels).
    """
    view = array.view()
    view.flags.writeable = False
    return view


def _orientation_maps(plane, scale, sigma, mode, workers, needed, outputs):
    """Structure-tensor maps of ``plane * scale`` into ``outputs`` (four float32 planes).

    ``needed``: the rows of column tiles to compute (see
    ``_metrics_kernels.orientation_band``), None for every pixel.
    """
    kernels = _numba_kernels()
    weights = _weights(2 * sigma, np.float32)
    if needed is None:
        radius = weights.shape[0] - 1
        tiles = 1
        if _ring_bytes(radius, plane.shape[1]) > _FULL_WIDTH_RING_BYTES:
            tiles = kernels.tensor_tiles(plane.shape[1], radius)
        needed = np.ones((plane.shape[0], tiles), dtype=bool)
    _in_bands(
        kernels.orientation_band,
        plane.shape[0],
        workers,
        kernels.plane_tuple(plane),
        scale,
        weights,
        mode,
        needed,
        *outputs,
    )
    return outputs


#: Bytes of the ring of smoothed rows a thread holds (``_metrics_kernels._tensor_tile``)
#: above which a whole plane's tensor is computed in column tiles: a wide sigma's ring
#: grows with it, the tiles' recomputed margins cost time (a fifth at sigma 2).
_FULL_WIDTH_RING_BYTES = 16 * 2**20


def _ring_bytes(radius: int, tile: int) -> int:
    """Bytes of the ring of ``_metrics_kernels._tensor_tile`` for a kernel ``radius`` and a
    ``tile`` of columns."""
    return 3 * (2 * radius + 2) * tile * np.dtype(np.float32).itemsize


def _tile_counts(walls: np.ndarray, tiles: int, workers) -> np.ndarray:
    """The pixels of ``walls`` in each row of ``tiles`` column tiles (see
    ``orientation_band``)."""
    counts = np.empty((walls.shape[0], tiles), dtype=np.int64)
    _in_bands(_numba_kernels().mask_counts, walls.shape[0], workers, walls, counts)
    return counts


def _wall_orientation(plane, scale, sigma, workers, walls):
    """The derived tensor maps (``TENSOR_DERIVED``) of ``plane * scale`` at the pixels of
    ``walls`` only, after the rows' starts (see :meth:`_Maps.wall_orientation`)."""
    kernels = _numba_kernels()
    counts = _tile_counts(walls, _tensor_tiles(plane.shape[1], sigma), workers)
    starts = kernels.mask_starts(counts)
    row_starts = np.append(starts[:, 0], starts[-1, -1] + counts[-1, -1])
    outputs = tuple(np.empty((1, int(row_starts[-1])), dtype=np.float32) for _ in range(4))
    if _decimated(sigma):
        _tensor(plane, scale, sigma, workers, counts > 0, outputs, starts, walls)
        return (row_starts, *(output[0] for output in outputs))
    planes = tuple(np.empty(plane.shape, dtype=np.float32) for _ in range(4))
    _tensor(plane, scale, sigma, workers, counts > 0, planes)
    return (row_starts, *(map_[walls] for map_ in planes))


def _decimated(sigma: float) -> bool:
    """Whether the structure tensor at ``sigma`` is decimated (see ``_DECIMATED_SIGMA``)."""
    return sigma >= _DECIMATED_SIGMA


def _tensor_weights(sigma: float) -> np.ndarray:
    """The float32 Gaussian half-kernel of the structure tensor at ``sigma`` (original pixels)."""
    if _decimated(sigma):
        return _weights(_numba_kernels().decimated_sigma(sigma), np.float32)
    return _weights(2 * sigma, np.float32)  # on the doubled grid


def _tensor_tiles(width: int, sigma: float) -> int:
    """Column tiles of the structure tensor at ``sigma`` when only some pixels are asked for."""
    return _numba_kernels().tensor_tiles(width, _tensor_weights(sigma).shape[0] - 1)


def _tensor(
    plane, scale, sigma, workers, needed, outputs, starts=None, mask=None, *, components=False
):
    """The derived maps (``TENSOR_DERIVED``) of the structure tensor of ``plane * scale`` at
    ``sigma`` into ``outputs``, on the rows of column tiles ``needed``; with ``components``,
    its components (``TENSOR_COMPONENTS``: three outputs).

    From ``sigma = _DECIMATED_SIGMA`` on, the decimated tensor
    (``_metrics_kernels.decimated_tensor_band``; with ``starts``, at the
    pixels of ``mask`` only, one after the other); below, the doubled
    grid's (:func:`orientation`'s).
    """
    kernels = _numba_kernels()
    mode = kernels.TENSOR_COMPONENTS if components else kernels.TENSOR_DERIVED
    if components:
        outputs = (*outputs, np.empty((1, 1), dtype=np.float32))  # not written
    if not _decimated(sigma):
        outputs = _orientation_maps(plane, scale, sigma, mode, workers, needed, outputs)
        return outputs[:3] if components else outputs
    weights = _tensor_weights(sigma)
    if starts is None:
        starts = np.empty((0, 0), dtype=np.int64)
        mask = np.empty((0, 0), dtype=bool)
    _in_bands(
        kernels.decimated_tensor_band,
        plane.shape[0],
        workers,
        kernels.plane_tuple(plane),
        scale,
        weights,
        mode,
        needed,
        starts,
        mask,
        *outputs,
    )
    return outputs[:3] if components else outputs


# --- the maps of renderings, shared between the single metrics ---------------------------

#: Maps of the last plane given to the single metrics, by content (a plane's maps take
#: about 30 to 40 bytes a pixel: one is kept).
_RENDERED = _LastPlane()
#: The :class:`Comparison` of the last original given to :func:`describe`, by content.
_ORIGINALS = _LastPlane()


def _maps_of(image, name: str = "image") -> _Maps:
    """The (cached) maps of a plane given to one of the single metrics."""

    def make(array):
        maps = _Maps(_kernel_plane(array, copy=True))
        return maps.plane, maps

    return _RENDERED.get(None, _plane(image, name), make)


def fine_scale(image) -> np.ndarray:
    """The fine-scale component ``h = g - G_1 * g`` of a plane."""
    fine, _ = _Maps(_kernel_plane(_plane(image)), walls=False).fine()
    return fine  # a new array, the caller's own


def texture_added(original, rendered) -> float:
    """Fine-scale energy of ``rendered`` over that of ``original``.

    ``E(g) = mean(h**2)`` with h the fine-scale component. 1 means no texture
    was added, above 1 texture was added, below 1 the image was smoothed.
    """
    before = _Maps(_kernel_plane(_plane(original, "original")))
    after = _Maps(_kernel_plane(_plane(rendered, "rendered")))
    before.measure_fine()
    after.measure_fine()
    return _texture_added(before, after)


def _texture_added(before: _Maps, after: _Maps) -> float:
    energy_before = before._fine().total / before.plane.size
    energy_after = after._fine().total / after.plane.size
    if energy_before == 0.0:
        return math.inf if energy_after > 0 else 1.0
    return energy_after / energy_before


def wall_map(image) -> np.ndarray:
    """Boolean map of pixels covered by oriented, wall-like fine texture.

    A pixel is on a wall where, for one of the four lattice directions d
    with normal n, the fine-scale component h is locally correlated along d
    (``C(d) > ALONG_THRESHOLD``: walls continue) and alternates across it
    (``C(w n) < -ALTERNATION_THRESHOLD`` and ``C(2 w n) > ALTERNATION_THRESHOLD``
    for a wall width w of 1 or 2 pixels), in a region that is not flat (local
    RMS of h above ``ENERGY_FLOOR`` tones). ``C`` is the local lag
    correlation over a Gaussian window of sigma ``WINDOW_SIGMA``. White and
    salt-and-pepper noise are not correlated along any direction; smooth
    edges and blur do not alternate.

    The local lag correlation is ``C(d) = G * (h(p) h(p + d)) / G * h**2``,
    symmetric in d (the product averaged over d and -d), with G the Gaussian
    window and lags wrapping around the plane. The result is read-only and
    shared between callers.
    """
    walls, _, _ = _maps_of(image).walls()
    return _read_only(walls)


def labyrinth_cover(image) -> float:
    """Fraction of the image covered by labyrinth walls (see :func:`wall_map`)."""
    return _maps_of(image).cover()


def wall_width(image) -> float:
    """Characteristic width of the walls, in pixels, from how often tones cross over.

    Walls and gaps are the signs of ``g - G_2 * g`` (the image minus its local
    mean). Along a line at angle phi across walls of width w running at angle
    theta the sign changes ``|sin(phi - theta)| / w`` times per pixel, on
    average ``2 / (pi w)`` over all phi (Cauchy-Crofton). The rate is counted
    between neighbours on the wall map along the four lattice directions
    (diagonal steps are sqrt(2) long), averaged, and inverted:
    ``w = 2 / (pi * rate)``. NaN when walls cover less than ``MIN_COVER`` of
    the image: there is no wall to measure.
    """
    return _wall_width(_maps_of(image))


def _wall_width(maps: _Maps) -> float:
    if maps.cover() < MIN_COVER:
        return math.nan
    walls, _, _ = maps.walls()
    counts = np.empty((walls.shape[0], len(_DIRECTIONS), 2), dtype=np.int64)
    maps._bands(_numba_kernels().wall_pair_counts, walls, maps.above_local_mean(), counts)
    counts = counts.sum(axis=0)
    rates = [
        flips / both / math.hypot(dy, dx) if both else math.nan
        for (both, flips), (dy, dx) in zip(counts.tolist(), _DIRECTIONS)
    ]
    rate = float(np.mean(rates))
    return 2.0 / (math.pi * rate) if rate > 0 else math.inf


def orientation(image, sigma: float = WINDOW_SIGMA):
    """Dominant local orientation and its coherence from the structure tensor.

    The plane is first upsampled twice (linear interpolation): the central
    differences of the structure tensor cannot see a pattern at the Nyquist
    frequency (1-pixel walls), its double can. The tensor of
    ``skimage.feature.structure_tensor`` with a window of ``sigma`` original
    pixels is then sampled back on the original grid. Returns
    ``(angle, coherence, strength)``: the angle (radians, modulo pi) of the
    local gradient direction, the coherence ``((l1 - l2) / (l1 + l2))**2`` in
    [0, 1] of the eigenvalues ``l1 >= l2``, and ``l1 + l2``.

    The upsampling is ``scipy.ndimage.zoom(plane, 2, order=1, grid_mode=True,
    mode="nearest")``; only the tensor's samples on the original grid are
    computed, in float32 (relative error about 1e-7), on the plane times a
    power of two: the angle and the coherence of a plane of any magnitude
    are those of a plane of tones, and the strength is divided back by the
    power's square (infinite, or 0, where it leaves float64's range).

    Parameters
    ----------
    image : array_like
        A 2-D plane of real numbers, at least 3 x 3.
    sigma : float, optional
        The window's Gaussian sigma, in original pixels, within the bounds
        of :data:`SIGMA`.

    Returns
    -------
    angle, coherence, strength : ndarray
        float64 planes shaped as ``image``.

    Raises
    ------
    TypeError, ValueError
        For an ``image`` that is not such a plane or a ``sigma`` out of bounds.
    """
    sigma = SIGMA.validate(sigma)
    plane = _float_plane(_plane(image))
    largest = float(np.max(np.abs(plane), where=np.isfinite(plane), initial=0.0))
    scale = _float32_scale(largest)
    if scale != 1.0:
        # scaled in float64 first: exact, where the kernel's interpolation of subnormal
        # values would round them to a few bits
        plane = plane * scale
    outputs = tuple(np.empty(plane.shape, dtype=np.float32) for _ in range(4))
    _orientation_maps(plane, 1.0, sigma, _numba_kernels().TENSOR_COMPONENTS, None, None, outputs)
    # the angle and the coherence do not depend on the scale: taken before it is undone
    jrr, jrc, jcc = (component.astype(np.float64) for component in outputs[:3])
    trace = jrr + jcc
    difference = np.sqrt((jrr - jcc) ** 2 + 4 * jrc**2)
    coherence = np.divide(difference, trace, out=np.zeros_like(trace), where=trace > 0) ** 2
    # a window of one pixel makes a rank-one tensor, whose float32 rounding can put the
    # ratio a few ulps above 1
    np.minimum(coherence, 1.0, out=coherence)
    angle = 0.5 * np.arctan2(2 * jrc, jrr - jcc)
    with np.errstate(over="ignore", under="ignore"):  # beyond float64's range: inf or 0
        trace = trace / scale / scale
    return angle, coherence, trace


def orientation_coherence(image) -> float:
    """How parallel the walls are: mean structure-tensor coherence on the wall map.

    The coherence of :func:`orientation` of the fine-scale component,
    averaged over the pixels of :func:`wall_map` with the tensor's strength
    as weight: near 1 for long parallel walls (a fingerprint texture), lower
    for a maze of short turning walls. NaN where there are no walls.

    The tensor's window is :func:`orientation`'s decimated (the doubled
    grid's products filtered 1-2-1, then a Gaussian of the same variance on
    the original grid): the value moves by less than 3e-4 (relative) from
    the doubled grid's on the study images.
    """
    return _orientation_coherence(_maps_of(image))


def _orientation_coherence(maps: _Maps) -> float:
    if maps.cover() < MIN_COVER or not maps.finite:
        return math.nan  # NaN or infinity in h: the weighted sum is NaN
    row_starts, strength, coherent, _, _ = maps.wall_orientation()
    sums = maps._row_sums(2)
    maps._bands(_numba_kernels().wall_weighted_sums, row_starts, strength, coherent, sums)
    numerator = math.fsum(sums[:, 0])
    denominator = math.fsum(sums[:, 1])
    return numerator / denominator if denominator > 0 else math.nan


def contour_alignment(original, rendered, *, contour_sigma: float = CONTOUR_SIGMA) -> float:
    """How well the rendered walls run along the contours of the input.

    The weighted mean, over the walls of ``rendered`` (:func:`wall_map`), of
    ``cos**2`` of the angle between the local orientation of the walls and
    that of the input's contours (structure tensor at ``contour_sigma``),
    weighted by both coherences and strengths. 1: walls parallel to the
    contours; 0.5: no relation; 0: walls across the contours. NaN where walls
    cover less than ``MIN_COVER`` of the image or the input has no contours.

    Both tensors are decimated (see :func:`orientation_coherence`; a
    ``contour_sigma`` below ``_DECIMATED_SIGMA`` = 1 pixel takes the doubled
    grid's): the value moves by less than 1.5e-3 (relative) from the
    doubled grid's on the study images.

    ``contour_sigma`` (pixels) is checked first, against the bounds of
    :data:`SIGMA`: a TypeError or ValueError names it.
    """
    contour_sigma = CONTOUR_SIGMA_PARAMETER.validate(contour_sigma)
    before = _plane(original, "original")
    after = _plane(rendered, "rendered")
    _same_shape(before, after)
    maps = _maps_of(after, "rendered")
    if maps.cover() < MIN_COVER:
        return math.nan  # before the contours are computed for nothing
    return _contour_alignment(_Maps(_kernel_plane(before)), maps, contour_sigma)


def _contour_alignment(before: _Maps, after: _Maps, contour_sigma: float = CONTOUR_SIGMA) -> float:
    if after.cover() < MIN_COVER or not (after.finite and before.finite):
        return math.nan  # NaN or infinity in either image: the weighted sum is NaN
    walls, _, _ = after.walls()
    row_starts, _, wall_coherent, wall_cos, wall_sin = after.wall_orientation()
    contour_rr, contour_rc, contour_cc = before.contours(contour_sigma, walls)
    sums = after._row_sums(2)
    after._bands(
        _numba_kernels().alignment_sums,
        walls,
        row_starts,
        wall_coherent,
        wall_cos,
        wall_sin,
        contour_rr,
        contour_rc,
        contour_cc,
        sums,
    )
    numerator = math.fsum(sums[:, 0])
    total = math.fsum(sums[:, 1])
    if not total > 0:
        return math.nan
    return numerator / total


def edge_enhancement(original, rendered) -> float:
    """Correlation of the texture a rendering adds with the edges of the input.

    Pearson correlation between the fine-scale energy added locally,
    ``G_2 * h_rendered**2 - G_2 * h_original**2``, and the Sobel gradient
    magnitude of the input. Near 1 when the rendering draws texture on the
    input's edges (the edge-detector look of the paper's Fig. 4), near 0 when
    it adds texture everywhere alike (noise), negative when it removes
    texture from the edges (blur), 0 when nothing changed.
    """
    before = _plane(original, "original")
    after = _plane(rendered, "rendered")
    _same_shape(before, after)
    original_maps = _Maps(_kernel_plane(before), walls=False)  # the energy with the edges
    return _edge_enhancement(original_maps, _Maps(_kernel_plane(after)))


def _edge_enhancement(before: _Maps, after: _Maps) -> float:
    # the energies first: their passes give the sums behind ``finite`` (no ``h`` kept)
    energy_after, total_after = after.energy()
    energy_before, total_before = before.energy()
    if not (after.finite and before.finite):
        return math.nan  # NaN or infinity in either image: so is the correlation
    edges, edges_mean, edges_constant = before.edges()
    added_mean = (total_after - total_before) / edges.size
    sums = after._row_sums(5)
    after._bands(
        _numba_kernels().edge_sums,
        energy_after,
        energy_before,
        edges,
        added_mean,
        edges_mean,
        sums,
    )
    cross = math.fsum(sums[:, 0])
    spread = math.fsum(sums[:, 1])
    edges_spread = math.fsum(sums[:, 4])
    added_constant = bool(sums[:, 2].min() == sums[:, 3].max())
    if added_constant or edges_constant:
        return 0.0
    correlation = cross / math.sqrt(spread * edges_spread)
    return min(1.0, max(-1.0, correlation)) if not math.isnan(correlation) else math.nan


# --- every metric at once -------------------------------------------------------------------


class Comparison:
    """The metrics of renderings of one original, its own maps computed once.

    The passes of a stack are renderings of the same input: the original's
    fine-scale energy, Sobel edges and contour orientation are computed on
    first use and kept for the renderings that follow (the contours only
    where the walls of some rendering need them), and the arrays of a
    rendering's maps serve the next one. Thread-safe (several threads may
    describe renderings at once); the original is copied, so the caller may
    change its array afterwards.

    Parameters
    ----------
    original : array_like
        The input plane: 2-D, real dtype, at least 3 x 3, on the tone scale
        of the renderings, or mapped there by ``tone_limits``.
    tone_limits : (float, float), optional
        The values that the rendering mapped to tones 0 and 255 (its
        ``Result.tone_limits``, or the ``tone_limits`` it was given): the
        original and every rendering are measured on that tone scale
        (``ToneScale.to_tones``, values outside clipped), where the metrics'
        bounds lie (:data:`ENERGY_FLOOR` is in tones). None: the planes are
        tones already (a uint8 image rendered on the paper's 0-255 scale).
    workers : int, optional
        Threads the heavy maps are split between (bands of rows): None for
        every core, else within the bounds of ``labyrinth(workers=...)``
        (``core.parameters.WORKERS``). The results do not depend on it.

    Examples
    --------
    >>> from skimage import data
    >>> from napari_labyrinth import labyrinth_stack
    >>> image = data.camera()
    >>> stack = labyrinth_stack(image, passes=2)
    >>> comparison = Comparison(image)
    >>> rows = [comparison.describe(rendered) for rendered in stack[1:]]
    >>> list(rows[0]) == list(METRICS)
    True
    """

    def __init__(self, original, *, tone_limits: Any = None, workers: int | None = None) -> None:
        workers = _validate_workers(workers)
        array = _plane(original, "original")
        self._scale = None if tone_limits is None else resolve_tone_scale(array, tone_limits)
        array = self._tones(array)
        self._pool = _SHARED_POOL
        plane = self._pool.take(array.shape, _kernel_dtype(array.dtype))
        _copy_in_bands(plane, array, workers)
        # the renderings' walls only; the maps' arrays go back to the pool with the object
        self._maps = _Maps(plane, workers, self._pool, walls=False)
        self._maps._taken.append(plane)
        weakref.finalize(self, self._pool.give_later, self._maps._taken)
        self.workers = workers

    @property
    def shape(self) -> tuple[int, int]:
        return self._maps.plane.shape

    def describe_steps(self, rendered) -> Iterator[tuple[str, float]]:
        """Yield ``(name, value)`` for each metric of ``rendered``, in the order of :data:`METRICS`.

        ``rendered`` is checked and copied by the call; each metric's work
        is done when the generator is asked for it, so a caller that stops
        iterating (or closes the generator) between two metrics skips the
        work of the rest. No thread works after a step (a helper that starts
        late ends without work, see ``_in_bands``; the timer that frees the
        arrays kept for the next maps, ``_Pool``, only waits).

        Examples
        --------
        >>> from skimage import data
        >>> from napari_labyrinth import labyrinth
        >>> image = data.camera()
        >>> for name, value in Comparison(image).describe_steps(labyrinth(image)):
        ...     if name == "labyrinth_cover":
        ...         break  # the other metrics are not computed
        """
        return self._steps(self._rendering_maps(rendered))

    def _tones(self, plane: np.ndarray) -> np.ndarray:
        """``plane`` on the tone scale of ``tone_limits`` (itself without them)."""
        return plane if self._scale is None else self._scale.to_tones(plane)

    def _rendering_maps(self, rendered) -> _Maps:
        """The maps of ``rendered`` (checked, on the tone scale, copied into an array of the
        pool)."""
        after_array = self._tones(_plane(rendered, "rendered"))
        _same_shape(self._maps.plane, after_array)
        plane = self._pool.take(after_array.shape, _kernel_dtype(after_array.dtype))
        _copy_in_bands(plane, after_array, self.workers)
        after = _Maps(plane, self.workers, self._pool)
        after._taken.append(plane)
        return after

    def _steps(self, after: _Maps) -> Iterator[tuple[str, float]]:
        before = self._maps
        try:
            yield "texture_added", _texture_added(before, after)
            yield "labyrinth_cover", after.cover()
            yield "wall_width", _wall_width(after)
            yield "orientation_coherence", _orientation_coherence(after)
            after.give_back_fine()  # the contours take its bytes
            yield "contour_alignment", _contour_alignment(before, after)
            yield "edge_enhancement", _edge_enhancement(before, after)
        finally:
            after.release()  # its arrays serve the next rendering

    def describe(self, rendered) -> dict[str, float]:
        """Every metric of ``rendered``, as a dict of floats in the order of :data:`METRICS`."""
        return dict(self.describe_steps(rendered))

    def edge_enhancement(self, rendered) -> float:
        """:func:`edge_enhancement` of ``rendered`` alone (the value ``describe`` gives),
        without the work of the other metrics."""
        after = self._rendering_maps(rendered)
        try:
            return _edge_enhancement(self._maps, after)
        finally:
            after.release()


def describe_steps(
    original, rendered, *, tone_limits: Any = None, workers: int | None = None
) -> Iterator[tuple[str, float]]:
    """Yield ``(name, value)`` for each metric of a rendering of ``original``, one at a time.

    The same values, in the same order, as :func:`describe`; a caller that
    stops iterating (or closes the generator) between two metrics skips the
    work of the others (see :meth:`Comparison.describe_steps`). The maps of
    the last ``original`` are kept, by content, for the next renderings of
    it: a stack's passes compute them once. :class:`Comparison` does the
    same without comparing the original each time. ``tone_limits`` and
    ``workers`` as :class:`Comparison` takes them.
    """
    limits = None if tone_limits is None else validate_tone_limits(tone_limits)
    comparison = _comparison_of(original, _validate_workers(workers), limits)
    return comparison.describe_steps(rendered)


def describe(
    original, rendered, *, tone_limits: Any = None, workers: int | None = None
) -> dict[str, float]:
    """Every metric of a rendering of ``original``, as a dict of floats.

    The keys are :data:`METRICS`, in that order. The metrics share the maps
    they have in common, and the maps of the last ``original`` are kept for
    the next renderings of it (see :func:`describe_steps`). ``tone_limits``:
    the tone scale the planes are measured on, as for :class:`Comparison`
    (for an image other than uint8, the rendering's ``Result.tone_limits``);
    ``workers``: threads, as for :class:`Comparison`; the results do not
    depend on it.
    """
    return dict(describe_steps(original, rendered, tone_limits=tone_limits, workers=workers))


def _comparison_of(original, workers, tone_limits) -> Comparison:
    """The :class:`Comparison` of ``original``, reused while its content (and the tone
    limits) are the same."""

    def make(array):
        comparison = Comparison(array, tone_limits=tone_limits, workers=workers)
        # its copy of the original, unless it holds the original's tones
        return (comparison._maps.plane if tone_limits is None else array.copy()), comparison

    return _ORIGINALS.get((workers, tone_limits), _plane(original, "original"), make)
