"""What the metrics keep between calls: the value computed for the last plane's content
(:class:`_LastPlane`), and the arrays of maps that are done, for the next maps of the same
shape (:class:`_Pool`)."""

from __future__ import annotations

import collections
import threading
from collections.abc import Callable
from typing import Any

import numpy as np


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
