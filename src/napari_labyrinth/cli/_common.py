"""What every command of ``napari-labyrinth`` shares: exit codes, errors, output, interrupts.

- Exit codes, and the exceptions the commands raise for them:
  :class:`UsageError` (2), :class:`Refused` and :class:`Failed` (1).
- One line per error (:func:`describe`, :func:`print_error`), output lines
  that a closed stdout does not stop (:func:`print_output`), and paths
  (:func:`make_directory`, :func:`path_key`).
- Ctrl-C and SIGTERM that nothing in the command can lose
  (:func:`interrupts_recorded`, :func:`raise_if_interrupted`).

Interrupts
----------
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
import os
import signal
import sys
import threading
from collections.abc import Iterator
from pathlib import Path

__all__ = [
    "EXIT_FAILED",
    "EXIT_INTERRUPTED",
    "EXIT_OK",
    "EXIT_TERMINATED",
    "EXIT_USAGE",
    "PROG",
    "Failed",
    "Refused",
    "UsageError",
    "cannot_write",
    "describe",
    "interrupting_signal",
    "interrupts_recorded",
    "make_directory",
    "one_line",
    "path_key",
    "print_error",
    "print_output",
    "raise_if_interrupted",
]

PROG = "napari-labyrinth"

#: Exit codes (interrupted: 128 + SIGINT, terminated: 128 + SIGTERM).
EXIT_OK, EXIT_FAILED, EXIT_USAGE, EXIT_INTERRUPTED, EXIT_TERMINATED = 0, 1, 2, 130, 143


class UsageError(Exception):
    """A bad combination of arguments: one line on stderr, exit code 2."""


class Refused(Exception):
    """Files that would be overwritten without --overwrite: exit code 1."""


class Failed(Exception):
    """Nothing could be rendered (e.g. no dask scheduler): one line, exit code 1."""


# -- errors and output ----------------------------------------------------------------------------


def make_directory(directory: Path) -> None:
    """Create ``directory`` and its parents, or raise a ``UsageError`` that says why not."""
    try:
        directory.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        reason = describe(exc, directory)
        raise UsageError(f"{directory}: cannot create the directory: {reason}") from None


def path_key(path: Path) -> str:
    """A comparable name for a path (absolute, symbolic links resolved, case as on disk)."""
    return os.path.normcase(os.path.realpath(path))


def describe(exc: BaseException, path: Path | str) -> str:
    """One line for an error about ``path``, without repeating the path."""
    from ..io import ImageFileError  # reason: io imports the file libraries; not for --help

    if isinstance(exc, ImageFileError):
        if path_key(Path(exc.path)) != path_key(Path(path)):  # about another file: the output
            return one_line(f"{exc.path}: {exc.reason}")
        return one_line(exc.reason)
    if isinstance(exc, OSError) and exc.strerror:
        text = exc.strerror
        if exc.filename is not None and path_key(Path(exc.filename)) != path_key(Path(path)):
            text += f": {exc.filename}"
        return one_line(text)
    text = one_line(str(exc)) or type(exc).__name__
    prefix = f"{path}: "
    return text.removeprefix(prefix)


def cannot_write(exc: BaseException, output: Path | str) -> str | None:
    """``cannot write OUTPUT: reason`` for an ``OSError`` of writing ``output``, or None.

    The writers of :mod:`napari_labyrinth.io` raise such an error naming the
    destination, never its hidden temporary; it is about the output, not the input.
    """
    if not isinstance(exc, OSError) or not exc.strerror or exc.filename is None:
        return None
    if not isinstance(exc.filename, (str, bytes, os.PathLike)):  # a file descriptor
        return None
    if path_key(Path(os.fsdecode(exc.filename))) != path_key(Path(output)):
        return None
    return one_line(f"cannot write {output}: {exc.strerror}")


def one_line(text: str) -> str:
    """``text`` with every run of white space (newlines included) made one space."""
    return " ".join(text.split())


def print_error(message: str) -> None:
    """``napari-labyrinth: error: message`` on stderr."""
    print(f"{PROG}: error: {message}", file=sys.stderr, flush=True)


_stdout_lost = False


def print_output(line: str) -> None:
    """``line`` on stdout (an output's path, a check's verdict).

    The outputs are files: a stdout closed or full (``| head``, ``>
    /dev/full``) stops nothing. The first failed write says so on stderr;
    stdout then goes to the null device, lines after it included.
    """
    global _stdout_lost
    if _stdout_lost:
        return
    try:
        print(line, flush=True)
    except OSError as exc:  # BrokenPipeError, ENOSPC
        _stdout_lost = True
        null = os.open(os.devnull, os.O_WRONLY)
        os.dup2(null, sys.stdout.fileno())  # what is still buffered is dropped there
        os.close(null)
        print(
            f"{PROG}: standard output cannot be written ({exc.strerror or exc}): "
            "the lines after this are not printed",
            file=sys.stderr,
            flush=True,
        )


# -- interrupts -----------------------------------------------------------------------------------


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
