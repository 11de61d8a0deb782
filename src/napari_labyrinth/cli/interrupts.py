"""Ctrl-C that nothing in the command can lose.

Python raises ``KeyboardInterrupt`` wherever the main thread is when SIGINT
arrives. If that is inside a finaliser (a ``__del__`` or a weakref callback,
which the garbage collector runs at any allocation), Python prints
"Exception ignored in ..." and drops the exception: the command would go on,
publish its output and exit 0 as if never interrupted.

While a command runs, :func:`interrupts_recorded` installs a handler that
records the interrupt before raising it. :func:`raise_if_interrupted` raises
it again at the next checkpoint (after each pass or block, and when the
command returns), so an interrupted run always leaves no output being
written and exits with code 130.
"""

from __future__ import annotations

import contextlib
import signal
import threading
from collections.abc import Iterator

__all__ = ["interrupts_recorded", "raise_if_interrupted"]

_interrupted = False


def _record_and_raise(signum, frame) -> None:
    global _interrupted
    _interrupted = True
    raise KeyboardInterrupt


@contextlib.contextmanager
def interrupts_recorded() -> Iterator[None]:
    """Record every SIGINT while the block runs (see the module's docstring).

    Nothing is installed outside the main thread, nor when SIGINT is not
    Python's default handler (ignored, as in a shell's background job, or
    handled by the program that calls :func:`napari_labyrinth.cli.main`).
    """
    global _interrupted
    _interrupted = False
    if (
        threading.current_thread() is not threading.main_thread()
        or signal.getsignal(signal.SIGINT) is not signal.default_int_handler
    ):
        yield
        return
    signal.signal(signal.SIGINT, _record_and_raise)
    try:
        yield
    finally:
        signal.signal(signal.SIGINT, signal.default_int_handler)
        _interrupted = False


def raise_if_interrupted() -> None:
    """Raise ``KeyboardInterrupt`` if SIGINT arrived since the command began.

    Raises
    ------
    KeyboardInterrupt
        If it did, even if the first ``KeyboardInterrupt`` was lost.
    """
    if _interrupted:
        raise KeyboardInterrupt
