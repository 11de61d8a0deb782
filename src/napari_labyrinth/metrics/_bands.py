"""Running a kernel over a plane on threads, a band of rows at a time.

The bands get smaller towards the end and the threads take them one at a
time (:func:`_in_bands`); the kernels' results do not depend on the bands.
``workers`` says how many threads (None: every core).
"""

from __future__ import annotations

import os
import threading
from collections.abc import Callable
from typing import Any

import numpy as np

from .._threads import start_helper
from ..core.parameters import WORKERS

#: Rows per band below which a plane is not split into more bands.
_MIN_BAND_ROWS = 64
#: A band takes ``1 / (_SHARES_PER_WORKER * workers)`` of the rows left (``_guided_edges``).
_SHARES_PER_WORKER = 2


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
    busy: a thread's start waits for it to run, the longer the busier the
    other core) finds the bands taken and ends without work.
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
        # not waited for: a helper that has no thread, or starts late, finds the bands taken
        start_helper(work)
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
    work varies with the walls in it (a core then idles at the end of a wall
    pass); here the threads end within
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
