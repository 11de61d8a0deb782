"""Helper threads that start without waiting: the package's one thread primitive.

``threading.Thread.start()`` waits until the new thread runs, for long when its
core is busy. Work split among threads that the caller
joins (it takes a share itself) need not wait for that: :func:`start_helper`
starts a thread and returns at once, with a lock released when the thread's
work is done.
"""

from __future__ import annotations

import _thread
import threading
from collections.abc import Callable
from typing import Any


def start_helper(work: Callable[..., Any], *arguments: Any) -> threading.Lock:
    """Start ``work(*arguments)`` on a new thread without waiting for it to run.

    Parameters
    ----------
    work : callable
        What the thread runs. Its return value is dropped; an exception it
        raises ends the thread (catch it in ``work`` to hand it to the caller).
    *arguments
        The arguments of ``work``.

    Returns
    -------
    threading.Lock
        Held until ``work`` has returned: acquire it to wait for that. Where no
        thread can be had it is released at once and ``work`` never runs: the
        caller's own share of the work must then take the helper's.
    """
    done = threading.Lock()
    done.acquire()

    def run():
        try:
            work(*arguments)
        finally:
            done.release()

    try:
        _thread.start_new_thread(run, ())
    except RuntimeError:  # no thread to be had: the caller takes the helper's work
        done.release()
    return done
