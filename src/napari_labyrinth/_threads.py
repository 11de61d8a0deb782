"""Thread primitives: helper threads that start without waiting, waits Ctrl-C cannot cut short.

``threading.Thread.start()`` waits until the new thread runs, for long when its
core is busy. Work split among threads that the caller
joins (it takes a share itself) need not wait for that: :func:`start_helper`
starts a thread and returns at once, with a lock released when the thread's
work is done; :func:`run_shares` runs the shares of such work, the caller's
among them, and waits for them all.

Python raises ``KeyboardInterrupt`` (Ctrl-C, or SIGTERM as the command line
handles it) wherever the main thread waits, and an interrupted wait does not
stop what it waited for: a thread still writing into a file that the caller
then removes makes it again. :func:`wait_through_interrupts` waits on, and
hands the interruption back to be raised once what it waited for is over.
"""

from __future__ import annotations

import _thread
import threading
import time
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


def run_shares(share: Callable[[int], Any], count: int) -> None:
    """``share(k)`` for every ``k < count``: ``share(0)`` on this thread, the others on
    helpers (:func:`start_helper`) at the same time; returns when all have returned.

    Raises
    ------
    BaseException
        The first exception a share raised (once every share has ended).
    """
    if count <= 1:
        share(0)
        return
    failed: list[BaseException] = []

    def helper(k):
        try:
            share(k)
        except BaseException as error:  # noqa: BLE001 - raised in the caller's thread
            failed.append(error)

    done = [start_helper(helper, k) for k in range(1, count)]
    try:
        share(0)
    finally:
        for lock in done:
            lock.acquire()
    if failed:
        raise failed[0]


def wait_through_interrupts(
    event: threading.Event, timeout: float | None = None
) -> tuple[bool, BaseException | None]:
    """Wait until ``event`` is set, or ``timeout`` seconds have passed, through interruptions.

    Parameters
    ----------
    event : threading.Event
        Set by the thread waited for when it is done.
    timeout : float, optional
        The most seconds to wait; None waits as long as it takes.

    Returns
    -------
    set : bool
        Whether ``event`` was set (False: the wait timed out).
    interruption : BaseException or None
        The first exception raised in the waiting thread meanwhile (a
        ``KeyboardInterrupt``, from a signal's handler), for the caller to raise
        once it has done what the wait was for; None if there was none.
    """
    deadline = None if timeout is None else time.monotonic() + timeout
    interruption = None
    while True:
        # the whole loop in the try: an interruption between two waits is taken too
        try:
            while not event.is_set():
                remaining = None if deadline is None else deadline - time.monotonic()
                if remaining is not None and remaining <= 0:
                    break
                # an Event, not Thread.join: interrupted, join can take a running thread as
                # ended (Python 3.11)
                event.wait(remaining)
            return event.is_set(), interruption
        except BaseException as error:  # noqa: BLE001 - handed back to the caller
            interruption = interruption or error
