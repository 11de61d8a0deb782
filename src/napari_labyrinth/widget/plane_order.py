"""The order in which the planes of a lazy result render: where the user looks first.

A lazy input's result is rendered plane by plane in the background
(:mod:`~napari_labyrinth.widget.lazy_result`). :class:`PlaneOrder` hands the
planes out: the plane on screen first, then its neighbours outward (at equal
distance, the one ahead in the direction the user last moved first), then
the rest. A move of the slider re-prioritises what is left; a plane is handed
out once, never twice; a cancel hands out nothing more. It is shared by the
main thread (which moves the focus) and the rendering thread (which takes
planes), under a lock, and cheap for the main thread: a move only records the
new focus, the order is worked out by the next :meth:`PlaneOrder.take`.
"""

from __future__ import annotations

import threading
from collections.abc import Iterable, Sequence

import numpy as np

__all__ = ["PlaneOrder"]


class PlaneOrder:
    """The planes of the leading axes ``shape`` in the order they should render.

    Parameters
    ----------
    shape : sequence of int
        Shape of the leading axes (the planes are indexed by tuples of that length).
    focus : sequence of int
        The plane on screen.
    done : iterable of tuple of int, optional
        Planes already rendered (never handed out).
    """

    def __init__(
        self,
        shape: Sequence[int],
        focus: Sequence[int],
        done: Iterable[Sequence[int]] = (),
    ) -> None:
        self.shape = tuple(int(n) for n in shape)
        self._lock = threading.Lock()
        self._focus = self._checked(focus)
        self._direction = 1  # the way the user last moved: +1 ahead, -1 back
        self._done: set[tuple[int, ...]] = {self._checked(index) for index in done}
        self._taken: set[tuple[int, ...]] = set()
        self._queue: list[tuple[int, ...]] | None = None  # worked out on the next take
        self._cancelled = False

    @property
    def total(self) -> int:
        """Number of planes."""
        return int(np.prod(self.shape, dtype=np.int64))

    @property
    def done_count(self) -> int:
        """Number of planes rendered."""
        with self._lock:
            return len(self._done)

    @property
    def focus(self) -> tuple[int, ...]:
        """The plane on screen."""
        return self._focus

    @property
    def cancelled(self) -> bool:
        """Whether :meth:`cancel` was called."""
        return self._cancelled

    def is_done(self, index: Sequence[int]) -> bool:
        """Whether the plane at ``index`` is rendered."""
        with self._lock:
            return tuple(index) in self._done

    def move_focus(self, index: Sequence[int]) -> None:
        """The user now looks at the plane ``index``: it and its neighbours come first."""
        index = self._checked(index)
        with self._lock:
            if index == self._focus:
                return
            step = sum(new - old for new, old in zip(index, self._focus))
            if step:
                self._direction = 1 if step > 0 else -1
            self._focus = index
            self._queue = None

    def take(self) -> tuple[int, ...] | None:
        """The next plane to render (it is then no one else's), or None: all handed out, or
        cancelled."""
        with self._lock:
            if self._cancelled:
                return None
            if self._queue is None:
                self._queue = self._ordered_rest()
            while self._queue:
                index = self._queue.pop()
                if index not in self._done and index not in self._taken:
                    self._taken.add(index)
                    return index
            return None

    def finish(self, index: Sequence[int]) -> None:
        """The plane ``index`` (handed out by :meth:`take`) is rendered."""
        index = tuple(index)
        with self._lock:
            self._taken.discard(index)
            self._done.add(index)

    def give_back(self, index: Sequence[int]) -> None:
        """The plane ``index`` was handed out but not rendered (its rendering stopped)."""
        index = tuple(index)
        with self._lock:
            self._taken.discard(index)
            self._queue = None

    def cancel(self) -> None:
        """Hand out no more planes."""
        with self._lock:
            self._cancelled = True
            self._queue = []

    def _checked(self, index: Sequence[int]) -> tuple[int, ...]:
        index = tuple(int(i) for i in index)
        if len(index) != len(self.shape) or not all(0 <= i < n for i, n in zip(index, self.shape)):
            raise ValueError(f"plane index {index} is outside planes of shape {self.shape}")
        return index

    def _ordered_rest(self) -> list[tuple[int, ...]]:
        """The planes neither rendered nor handed out, the first to render last (a stack to
        pop from): by distance from the focus (the sum of the steps along each axis), at
        equal distance the one ahead of the focus first, then in index order."""
        if not self.shape:
            indices = np.zeros((1, 0), dtype=np.int64)
        else:
            grids = np.indices(self.shape).reshape(len(self.shape), -1)
            indices = grids.T
        offsets = indices - np.asarray(self._focus, dtype=np.int64)
        distance = np.abs(offsets).sum(axis=1)
        behind = (offsets.sum(axis=1) * self._direction < 0).astype(np.int64)
        flat = np.arange(len(indices))
        order = np.lexsort((flat, behind, distance))  # the last key sorts first
        skipped = self._done | self._taken
        rest = [tuple(int(i) for i in indices[k]) for k in order]
        return [index for index in reversed(rest) if index not in skipped]
