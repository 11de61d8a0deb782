"""Ctrl-C, and SIGTERM, that nothing in the command can lose.

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

SIGTERM (what ``kill``, ``timeout``, batch schedulers and service managers
send) would end the process at once, leaving a half-written temporary behind;
while a command runs it is handled as Ctrl-C is, and the command exits with
code 143 (128 + 15).
"""

from __future__ import annotations

import contextlib
import signal
import threading
from collections.abc import Iterator

__all__ = ["interrupting_signal", "interrupts_recorded", "raise_if_interrupted"]

#: The signal that interrupted the command, or None.
_interrupted: int | None = None

#: The signals handled, each with the handler it is taken over from (Python's own).
_HANDLED = {signal.SIGINT: signal.default_int_handler, signal.SIGTERM: signal.SIG_DFL}


def _record_and_raise(signum, frame) -> None:
    global _interrupted
    _interrupted = signum
    raise KeyboardInterrupt


@contextlib.contextmanager
def interrupts_recorded() -> Iterator[None]:
    """Record every SIGINT and SIGTERM while the block runs (see the module's docstring).

    Nothing is installed outside the main thread, nor for a signal whose
    handler is not Python's default (ignored, as SIGINT in a shell's
    background job, or handled by the program that calls
    :func:`napari_labyrinth.cli.main`).
    """
    global _interrupted
    _interrupted = None
    taken = []
    if threading.current_thread() is threading.main_thread():
        taken = [s for s, default in _HANDLED.items() if signal.getsignal(s) is default]
    for signum in taken:
        signal.signal(signum, _record_and_raise)
    try:
        yield
    finally:
        for signum in taken:
            signal.signal(signum, _HANDLED[signum])
        _interrupted = None


def raise_if_interrupted() -> None:
    """Raise ``KeyboardInterrupt`` if SIGINT or SIGTERM arrived since the command began.

    Raises
    ------
    KeyboardInterrupt
        If one did, even if the first ``KeyboardInterrupt`` was lost.
    """
    if _interrupted is not None:
        raise KeyboardInterrupt


def interrupting_signal() -> int:
    """The signal that interrupted the command: SIGTERM if it was, else SIGINT (Ctrl-C,
    or a ``KeyboardInterrupt`` raised without a signal)."""
    return signal.SIGTERM if _interrupted == signal.SIGTERM else signal.SIGINT
