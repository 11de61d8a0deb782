"""The ``napari-labyrinth`` command: render image files, or write a demo.

::

    napari-labyrinth render INPUT... -o OUTPUT [options]
    napari-labyrinth reproduce OUTPUT [--input INPUT]
    napari-labyrinth demo [-o DIR] [--overwrite]
    napari-labyrinth --version

Heavy modules (numba, tifffile, imageio, tqdm, scikit-image, dask) are
imported only when a command needs them, so ``--help`` answers at once.
Nothing here imports napari or Qt: the command runs without a display.

zarr stores and large TIFF stacks are rendered lazily, block by block (see
``io.open_image`` and ``io.write_array``), locally or on a
``dask.distributed`` cluster (``--scheduler``).

This module holds ``main``, the exit codes and what the commands share;
``parser`` builds the arguments, ``render``, ``reproduce`` and ``demo`` run
the commands.
"""

from __future__ import annotations

import os
import signal
import sys
from collections.abc import Sequence
from pathlib import Path

from .interrupts import interrupting_signal, interrupts_recorded, raise_if_interrupted

__all__ = [
    "EXIT_FAILED",
    "EXIT_INTERRUPTED",
    "EXIT_OK",
    "EXIT_TERMINATED",
    "EXIT_USAGE",
    "PROG",
    "main",
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


def main(argv: Sequence[str] | None = None) -> int:
    """Run the ``napari-labyrinth`` command.

    Parameters
    ----------
    argv : sequence of str, optional
        The arguments after the program name; ``sys.argv[1:]`` by default.

    Returns
    -------
    int
        Exit code: 0 on success, 1 if a file failed or an existing file was
        not overwritten, 2 for a usage or parameter error, 130 on Ctrl-C, 143
        on SIGTERM.
    """
    from .parser import build_parser

    parser = build_parser()
    try:
        args = parser.parse_args(argv)
    except SystemExit as exc:  # --help, --version and usage errors
        return exc.code if isinstance(exc.code, int) else (0 if exc.code is None else 1)
    if args.command is None:
        parser.print_help(sys.stderr)
        return EXIT_USAGE
    with interrupts_recorded():
        try:
            code = _run(args)
            raise_if_interrupted()  # an interrupt a finaliser swallowed still counts
            return code
        except UsageError as exc:
            print_error(str(exc))
            return EXIT_USAGE
        except Refused as exc:
            for line in exc.args:
                print_error(line)
            return EXIT_FAILED
        except Failed as exc:
            print_error(str(exc))
            return EXIT_FAILED
        except KeyboardInterrupt:
            if interrupting_signal() == signal.SIGTERM:
                print_error("terminated")
                return EXIT_TERMINATED
            print_error("interrupted")
            return EXIT_INTERRUPTED


def _run(args) -> int:
    """Run the command the arguments name (its module is imported only now)."""
    if args.command == "render":
        from .render import render_command as command
    elif args.command == "reproduce":
        from .reproduce import reproduce_command as command
    else:
        from .demo import demo_command as command
    return command(args)


# -- shared by the commands -----------------------------------------------------------------------


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
    from ..io import ImageFileError

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
