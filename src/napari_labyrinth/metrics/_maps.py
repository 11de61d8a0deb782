"""The maps of a plane, an original's or a rendering's, each computed on first use and
kept: the fine-scale component ``h`` and its sums, the energy, the Sobel edges, the wall
map, the local mean at the walls, the walls' orientation and the contours (:class:`_Maps`);
and the maps of the last plane given to a single metric (:func:`_maps_of`)."""

from __future__ import annotations

import math
import threading
from collections.abc import Callable
from typing import Any, NamedTuple

import numpy as np

from ._bands import _in_bands
from ._caches import _LastPlane, _Pool
from ._definitions import ALONG_THRESHOLD, ALTERNATION_THRESHOLD, ENERGY_FLOOR, WINDOW_SIGMA
from ._lazy_kernels import _numba_kernels, _weights
from ._planes import _float32_scale, _kernel_plane, _plane
from ._tensor import _tensor, _tensor_tiles, _tile_counts, _wall_orientation


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
        """``_kernels.fine_scale_band`` on every row: the maps of the arrays of the
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
        (``_kernels.tensor._derive``): the one metric that reads the
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


#: Maps of the last plane given to the single metrics, by content (a plane's maps take
#: about 30 to 40 bytes a pixel: one is kept).
_RENDERED = _LastPlane()


def _maps_of(image, name: str = "image") -> _Maps:
    """The (cached) maps of a plane given to one of the single metrics."""

    def make(array):
        maps = _Maps(_kernel_plane(array, copy=True))
        return maps.plane, maps

    return _RENDERED.get(None, _plane(image, name), make)
