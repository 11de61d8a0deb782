"""Python's full garbage collections held off while the plugin renders.

A full collection (generation 2) of Python's cyclic garbage collector walks
every object the process holds, with the GIL held. In a napari viewer that is
some 240,000 objects before this plugin loads and about 340,000 after its first
run (numba, dask, scikit-image): a tenth of a second or more on two cores
(docs/architecture.md, "The event loop during a run"). Python starts
one by itself whenever enough objects have survived the younger collections,
in whichever thread happens to allocate; during a run that is the rendering
thread as often as the main one, and either way the event loop stalls for the
whole collection.

While a run is on, :func:`hold_full_collections` raises the threshold of the
oldest generation so that no full collection starts by itself. The two
younger generations are collected as usual, so the short-lived cycles a run
makes are still freed; only cycles among long-lived objects wait, at most as
long as the run. When the last hold is released the threshold is restored,
and a full collection that fell due during the run is made there and then:
left to the collector's own schedule, it came at its next check, which in an
idle viewer is the user's next action (the first step of a scroll froze for
its 170 ms, ``docs/performance.md``). Nothing is frozen, so nothing can leak.
A threshold somebody else changed in the meantime is left as they set it.

Qt-free: the holds are plain function calls; the widget ties them to its runs.
"""

from __future__ import annotations

import gc
import threading
from collections.abc import Callable

#: The oldest generation's threshold while a hold is on: more collections of the
#: middle generation than any run makes (its default is 10).
HELD_THRESHOLD = 2**31 - 1

_holds = 0
_restore: tuple[int, int, int] | None = None
_lock = threading.Lock()  # a worker's signal may be delivered in its own thread


def hold_full_collections() -> Callable[[], None]:
    """Keep Python from starting a full garbage collection until the hold is released.

    Holds nest (a preview and a run may overlap): the threshold is restored when
    the last one is released.

    Returns
    -------
    release : callable
        Ends this hold; calling it again does nothing.
    """
    global _holds, _restore
    with _lock:
        if _holds == 0:
            threshold = gc.get_threshold()
            if threshold[2] != HELD_THRESHOLD:
                _restore = threshold
                gc.set_threshold(threshold[0], threshold[1], HELD_THRESHOLD)
        _holds += 1
    released = False

    def release() -> None:
        nonlocal released
        global _holds, _restore
        due = False
        with _lock:
            if released:
                return
            released = True
            _holds -= 1
            if _holds == 0 and _restore is not None:
                if gc.get_threshold() == (_restore[0], _restore[1], HELD_THRESHOLD):
                    gc.set_threshold(*_restore)
                    due = full_collection_due()
                _restore = None
        if due:
            gc.collect()  # now, at the end of the run, not in the user's next action

    return release


def hold_while_running(worker) -> None:
    """Hold full collections from ``worker``'s start to its end.

    ``worker`` is a napari thread worker (its ``started`` and ``finished``
    signals); ``finished`` comes after ``returned``, so the hold covers the
    showing of its result too.
    """
    releases: list[Callable[[], None]] = []
    worker.started.connect(lambda: releases.append(hold_full_collections()))
    worker.finished.connect(lambda: releases and releases.pop()())


def full_collection_due() -> bool:
    """Whether Python's collector would start a full collection at its next check: more
    collections of the middle generation since the last full one than the oldest
    generation's threshold (``gc.get_count``, ``gc.get_threshold``)."""
    return gc.get_count()[2] > gc.get_threshold()[2]


def holds() -> int:
    """The number of holds on now."""
    return _holds
