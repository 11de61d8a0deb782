"""The ``napari-labyrinth`` command: its parser and :func:`main`.

::

    napari-labyrinth render INPUT... -o OUTPUT [options]
    napari-labyrinth reproduce OUTPUT [--input INPUT]
    napari-labyrinth demo [-o DIR] [--overwrite]
    napari-labyrinth --version

:func:`build_parser` assembles the commands' arguments (the render options
from :mod:`~napari_labyrinth.cli.options`); :func:`main` parses them, runs the
command (:mod:`~napari_labyrinth.cli.render`,
:mod:`~napari_labyrinth.cli.reproduce`, :mod:`~napari_labyrinth.cli.demo`) and
turns what it raises into an exit code (:mod:`~napari_labyrinth.cli._common`).
"""

from __future__ import annotations

import argparse
import signal
import sys
from collections.abc import Sequence

from .. import __version__
from ..core.presets import DEFAULT_PRESET
from ._common import (
    EXIT_FAILED,
    EXIT_INTERRUPTED,
    EXIT_TERMINATED,
    EXIT_USAGE,
    PROG,
    Failed,
    Refused,
    UsageError,
    interrupting_signal,
    interrupts_recorded,
    print_error,
    raise_if_interrupted,
)
from .options import (
    DEMO_STACK_PASSES,
    SCHEDULER_TIMEOUT,
    add_parameter_arguments,
    scheduler_address,
    seconds,
)

__all__ = ["build_parser", "main"]


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


def _run(args: argparse.Namespace) -> int:
    """Run the command the arguments name; its module is imported only now."""
    if args.command == "render":
        from .render import render_command as command  # reason: keeps --help fast (io, dask)
    elif args.command == "reproduce":
        from .reproduce import reproduce_command as command  # reason: keeps --help fast
    else:
        from .demo import demo_command as command  # reason: keeps --help fast
    return command(args)


def build_parser() -> argparse.ArgumentParser:
    """The parser of ``napari-labyrinth`` and its ``render``, ``reproduce`` and ``demo``
    commands."""
    parser = argparse.ArgumentParser(
        prog=PROG,
        description=("Render images with the labyrinthine tiling of Sparavigna & Montrucchio."),
    )
    parser.add_argument("--version", action="version", version=f"{PROG} {__version__}")
    parser.set_defaults(command=None)
    commands = parser.add_subparsers(title="commands", metavar="COMMAND")

    render = commands.add_parser(
        "render",
        help="render image files",
        description=(
            "Render image files (TIFF, PNG, JPEG, BMP), zarr stores and, through bioio "
            '(pip install "napari-labyrinth[formats]"), the formats of microscopes (CZI, '
            "ND2, LIF, ...). Parameters not "
            f"given come from the preset (default {DEFAULT_PRESET!r}). The result keeps "
            "the input's shape and dtype; stacks and sweeps are written as TIFF or zarr. "
            "Colour, OME axes and pixel sizes are read from the file and written back; "
            "outputs are lossless (JPEG only with --lossy) and record how they were made "
            "(see 'reproduce'). zarr stores and TIFF stacks over 1 GiB are rendered block "
            "by block, in bounded memory."
        ),
    )
    render.set_defaults(command="render")
    render.add_argument(
        "inputs",
        nargs="+",
        metavar="INPUT",
        help="image file(s) or .zarr store(s) (store.zarr/NAME: an array of a group)",
    )
    render.add_argument(
        "-o",
        "--output",
        required=True,
        metavar="OUTPUT",
        help=(
            "output file or .zarr store (one input; format from its suffix) or directory "
            "(created if missing), where each result is named <stem>_labyrinth<suffix>"
        ),
    )
    add_parameter_arguments(render)
    render.add_argument(
        "--scene",
        metavar="SCENE",
        help=(
            "the scene of a file of several (CZI, LIF, ND2... read through bioio): its index "
            "or its name (default the first)"
        ),
    )
    render.add_argument(
        "--scheduler",
        type=scheduler_address,
        metavar="ADDRESS",
        help=(
            "render on a dask.distributed cluster: the scheduler's address "
            "(tcp://host:8786), its scheduler file, or local:N to start N worker "
            "processes on this machine; workers need napari-labyrinth and must see the "
            "input and .zarr output paths"
        ),
    )
    render.add_argument(
        "--scheduler-timeout",
        type=seconds,
        metavar="SECONDS",
        help=(
            "how long to wait for the --scheduler to answer before failing "
            f"(default {SCHEDULER_TIMEOUT:g})"
        ),
    )
    render.add_argument(
        "--overwrite", action="store_true", help="replace existing files, inputs included"
    )
    render.add_argument(
        "--lossy",
        action="store_true",
        help=(
            "allow a lossy output format (.jpg): JPEG compression blurs the pixel-scale "
            "texture; without it a .jpg output is refused, and a directory batch writes "
            "JPEG inputs as PNG"
        ),
    )

    reproduce = commands.add_parser(
        "reproduce",
        help="render an output again from its provenance record and compare bit for bit",
        description=(
            "Read the provenance record an output of 'render' carries (TIFF description or "
            "OME annotation, PNG text chunk, zarr attributes), check that the input is the "
            "file that was rendered (SHA-256), render it again with the recorded call and "
            "compare the result with the output bit for bit. Exit code 0 if identical, 1 if "
            "not."
        ),
    )
    reproduce.set_defaults(command="reproduce")
    reproduce.add_argument(
        "output", metavar="OUTPUT", help="a file or .zarr store written by render"
    )
    reproduce.add_argument(
        "--input",
        metavar="INPUT",
        help=(
            "the input file (default: the recorded name, relative to the current directory, "
            "then to OUTPUT's directory)"
        ),
    )

    demo = commands.add_parser(
        "demo",
        help="render the built-in samples into a directory",
        description=(
            "Render the synthetic nematic Schlieren texture and the camera photograph "
            "with the default preset; write each input, its rendering, a "
            f"{DEMO_STACK_PASSES}-pass stack (TIFF) and a side-by-side comparison, and "
            "print the path of every file written."
        ),
    )
    demo.set_defaults(command="demo")
    demo.add_argument(
        "-o",
        "--output",
        default="labyrinth-demo",
        metavar="DIR",
        help="output directory (default: labyrinth-demo)",
    )
    demo.add_argument("--overwrite", action="store_true", help="replace existing files")
    return parser
