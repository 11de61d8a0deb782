"""The result of a run on a lazy input: planes rendered in the background into a store on disk.

A lazy (dask) input layer may be larger than memory, and napari must not
render its result's planes on its main thread as the user scrolls. The run
renders the plane on screen (:mod:`~napari_labyrinth.widget.run`) and hands
back a :class:`LazyResult`: a :class:`~.plane_store.PlaneStore` holding that
plane, which the result layer reads, and a :class:`~.plane_order.PlaneOrder`
of the others. :meth:`LazyResult.renders` renders them one by one, in that
order, each exactly as the API renders it (the plane alone, with its
``plane_offset``: the same random stream as within the whole stack; on
every core but one, left to the viewer), and
yields the index of each plane written; a thread worker drives it
(:mod:`napari_labyrinth._qt.plane_queue`), or a script drives it to its end
with :meth:`LazyResult.render_all`.
"""

from __future__ import annotations

import os
from collections.abc import Callable, Generator, Sequence
from typing import Any

import numpy as np

from .. import api
from ..core.planes import first_plane_index
from .plan import RenderPlan
from .plane_order import PlaneOrder
from .plane_store import PlaneStore

__all__ = ["LazyResult", "background_workers", "render_plane"]


def _never() -> bool:
    return False


def background_workers() -> int:
    """Threads of a plane rendered in the background: every core but one, which is left to
    the viewer (its main thread draws the planes as the user scrolls)."""
    cores = len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else os.cpu_count()
    return max(1, (cores or 1) - 1)


def render_plane(
    plan: RenderPlan,
    index: Sequence[int],
    should_stop: Callable[[], bool] = _never,
    workers: int | None = None,
) -> np.ndarray | None:
    """The rendering of the input plane at ``index`` of a lazy plan's source, as the API
    renders it within the whole stack; None if ``should_stop`` said so between two passes.

    A stack's passes or a sweep's renderings come first, as in the result. ``workers``:
    the API's threads (default: every core).
    """
    index = tuple(int(i) for i in index)
    source = plan.lazy_source
    plane = np.asarray(source[index])  # loads this plane only
    arguments = dict(plan.arguments, workers=workers)  # the result does not depend on them
    arguments["plane_offset"] = first_plane_index(
        source.shape, index, arguments.get("channel_axis")
    )
    steps = api.labyrinth_steps(plane, plan.mode, **arguments)
    try:
        for event in steps:
            if isinstance(event, api.Result):
                return np.asarray(event.image)
            if should_stop():
                return None
    finally:
        steps.close()
    raise AssertionError("labyrinth_steps ended without a result")  # pragma: no cover


class LazyResult:
    """A lazy plan's result: a store on disk the layer reads, and the planes still to render.

    Parameters
    ----------
    plan : RenderPlan
        A plan with a ``lazy_source``.
    visible : ndarray
        The rendering of the plane on screen (``plan.visible_index``), written at once.
    directory : path, optional
        Where the store goes (default: the system's temporary directory).

    Attributes
    ----------
    plan : RenderPlan
    store : PlaneStore
    order : PlaneOrder
    axis : int
        Axis of the result where the input's leading axes start (1 after a stack's passes
        or a sweep's renderings, else 0).
    """

    def __init__(self, plan: RenderPlan, visible: np.ndarray, directory: Any = None) -> None:
        self.plan = plan
        self.axis = 0 if plan.mode == "single" else 1
        leading = tuple(plan.lazy_source.shape[: len(plan.visible_index)])
        visible = np.asarray(visible)
        shape = visible.shape[: self.axis] + leading + visible.shape[self.axis :]
        self.store = PlaneStore(shape, visible.dtype, visible.ndim - self.axis, directory)
        try:
            self.store.write(plan.visible_index, visible, self.axis)
        except BaseException:
            self.store.remove()
            raise
        self.order = PlaneOrder(leading, plan.visible_index, done=[plan.visible_index])

    @property
    def data(self):
        """The array the result layer shows (planes not rendered yet read as zeros)."""
        return self.store.array

    def renders(
        self, should_stop: Callable[[], bool] = _never
    ) -> Generator[tuple[int, ...], None, None]:
        """Render the planes left, in :attr:`order`; yield each index once it is written.

        Stops when every plane is rendered, when the order is cancelled, or
        between two passes when ``should_stop`` says so (the plane being rendered
        then goes back to the order).
        """
        while (index := self.order.take()) is not None:
            try:
                planes = (
                    None
                    if should_stop()
                    else render_plane(self.plan, index, should_stop, background_workers())
                )
                if planes is not None:
                    self.store.write(index, planes, self.axis)
            except BaseException:
                self.order.give_back(index)
                raise
            if planes is None:
                self.order.give_back(index)
                return
            self.order.finish(index)
            yield index

    def render_all(self) -> None:
        """Render every plane left (a script's or a test's way, without a viewer)."""
        for _ in self.renders():
            pass

    @property
    def complete(self) -> bool:
        """Whether every plane is rendered."""
        return self.order.done_count == self.order.total

    def stop(self) -> None:
        """Render no more planes (the one being rendered still ends, unless the caller's
        ``should_stop`` stops it)."""
        self.order.cancel()

    def remove(self) -> None:
        """Stop, and remove the store (the layer reading it is gone)."""
        self.stop()
        self.store.remove()
