"""How many threads a plane's tiles may take: the cores that run no other task now.

The tiles of one pass wait on each other, so a tile thread on a core shared
with a busy task holds up the rest; :func:`idle_cores` counts the cores free
of other tasks (Linux's ``/proc/loadavg``, read twice a moment apart).
"""

from __future__ import annotations

import collections
import os
import time


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
