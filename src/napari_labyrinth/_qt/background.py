"""A run's steps driven in a thread of their own, at a lower scheduling priority than the GUI's.

While a run renders, its threads keep every core busy. Each repaint of the
viewer's window then waits for the CPU: the main thread's own share is small
(about 2 ms for a repaint of the progress bar), but under software OpenGL
(Xvfb, remote desktops) the window is composed by the OpenGL driver's
threads and sent to the X server, another process, and the main thread waits
for both. With the rendering threads at the same priority, that wait grew
from about 13 ms to 20–30 ms a repaint on a 2-core machine, and now and then
to over 100 ms (a stalled event loop). A thread at a lower priority gives way
to them and still takes every cycle they leave idle: the run takes as long
as before on an otherwise idle machine.

Linux keeps a priority (nice value) per thread and a thread starts with its
creator's, so the threads the run starts (the engine's planes and tiles) get
the lower priority too. An ordinary user cannot raise a priority again once
lowered, which is why the run gets a thread of its own, ended with it,
rather than lowering napari's pooled worker thread, which would stay low for
whatever napari or another plugin runs on it later. Elsewhere than on Linux
the priority is left as it is.

Qt-free: the widget's napari worker drives :meth:`StepsInThread.steps`.
"""

from __future__ import annotations

import contextlib
import os
import queue
import sys
import threading
from collections.abc import Generator
from typing import Any

#: How much lower than the GUI's the priority of a run's threads is: a nice increment
#: (0–19). At +5 a thread weighs a third of a thread of normal priority when both want
#: the same core: enough for the repaints, and a run still gets a fair share of a machine
#: busy with other work. Much lower would risk the opposite stall: a run's thread that
#: holds the GIL for a moment, then waits long for a core, keeps the main thread waiting.
NICENESS = 5

#: Name of a run's own thread (the engine's threads are named alike).
THREAD_NAME = "napari-labyrinth-run"

_STEP, _DONE, _FAILED, _STOPPED = range(4)


def lower_priority(niceness: int = NICENESS) -> bool:
    """Lower the calling thread's scheduling priority by ``niceness`` (Linux only).

    Returns
    -------
    bool
        Whether the priority was lowered (False elsewhere than on Linux, or if
        the system refused).
    """
    if niceness <= 0 or not sys.platform.startswith("linux"):
        return False
    thread = threading.get_native_id()  # on Linux, PRIO_PROCESS of a thread id: that thread
    try:
        current = os.getpriority(os.PRIO_PROCESS, thread)
        os.setpriority(os.PRIO_PROCESS, thread, min(19, current + niceness))
    except OSError:
        return False
    return True


class StepsInThread:
    """Drive a generator of steps in a thread of its own, at a lower priority.

    Parameters
    ----------
    steps : generator
        The run: yields its steps, returns its outcome.
    niceness : int, optional
        How much lower the thread's priority is (see :func:`lower_priority`);
        by default :data:`NICENESS`.

    Notes
    -----
    :meth:`steps` starts the thread and hands on, in the caller's thread,
    each step the run yields and the value it returns; an exception the run
    raises is raised there. :meth:`stop` (or closing :meth:`steps` early)
    makes the thread close the run after the step it is in, in its own
    thread: the caller never waits for a step to end.
    """

    def __init__(self, steps: Generator[Any, None, Any], niceness: int | None = None) -> None:
        self._run = steps
        self._niceness = NICENESS if niceness is None else niceness
        self._handed: queue.SimpleQueue = queue.SimpleQueue()
        self._stop = threading.Event()
        self.thread = threading.Thread(target=self._drive, name=THREAD_NAME, daemon=True)

    def steps(self) -> Generator[Any, None, Any]:
        """The run's steps, then (as the generator's value) what it returned."""
        self.thread.start()
        try:
            while True:
                kind, value = self._handed.get()
                if kind == _STEP:
                    yield value
                elif kind == _DONE:
                    return value
                elif kind == _FAILED:
                    raise value
                else:
                    return None
        finally:  # done, or closed early: a run still going stops at its next step
            self._stop.set()

    def stop(self) -> None:
        """Close the run after its current step; returns at once."""
        self._stop.set()

    def _drive(self) -> None:
        lower_priority(self._niceness)
        try:
            while not self._stop.is_set():
                self._handed.put((_STEP, next(self._run)))
        except StopIteration as done:
            self._handed.put((_DONE, done.value))
            return
        except BaseException as error:  # noqa: BLE001 - raised in the caller's thread
            self._handed.put((_FAILED, error))
            return
        with contextlib.suppress(Exception):  # stopping: what the run says on closing is moot
            self._run.close()
        self._handed.put((_STOPPED, None))
