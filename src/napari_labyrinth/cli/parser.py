"""The arguments of ``napari-labyrinth``: the parser, the value parsers and the API options.

Every flag that becomes a keyword argument of the API is added by
``_add_parameter_arguments`` and gathered by ``render_options``; the values
of ``--set`` and ``--sweep`` are read by ``_parse_value``. Nothing heavy is
imported here, so ``--help`` answers at once.
"""

from __future__ import annotations

import argparse
import math
import os
from typing import Any

from . import PROG, UsageError, one_line
from .demo import DEMO_STACK_PASSES


def build_parser() -> argparse.ArgumentParser:
    """The parser of ``napari-labyrinth`` and its ``render`` and ``demo`` commands."""
    from .. import __version__
    from ..presets import DEFAULT_PRESET

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
            "Render image files (TIFF, PNG, JPEG, BMP) and zarr stores. Parameters not "
            f"given come from the preset (default {DEFAULT_PRESET!r}). The result keeps "
            "the input's shape and dtype; stacks and sweeps are written as TIFF or zarr. "
            "zarr stores and TIFF stacks over 1 GiB are rendered block by block, in "
            "bounded memory."
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
    _add_parameter_arguments(render)
    render.add_argument(
        "--scheduler",
        type=_scheduler_address,
        metavar="ADDRESS",
        help=(
            "render on a dask.distributed cluster: the scheduler's address "
            "(tcp://host:8786), its scheduler file, or local:N to start N worker "
            "processes on this machine; workers need napari-labyrinth and must see the "
            "input and .zarr output paths"
        ),
    )
    render.add_argument(
        "--overwrite", action="store_true", help="replace existing files, inputs included"
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


def _add_parameter_arguments(render: argparse.ArgumentParser) -> None:
    """Every flag of ``render`` that becomes a keyword argument of the API, in help order.

    The preset, the algorithm's parameters (four flags of their own, the
    others through ``--set``), the seed, the tone limits, the channel axis,
    and ``--stack`` or ``--sweep``. ``render_options`` gathers them.
    """
    from ..presets import DEFAULT_PRESET, PRESETS

    render.add_argument(
        "--preset", choices=sorted(PRESETS), help=f"parameter set (default {DEFAULT_PRESET})"
    )
    render.add_argument(
        "--passes", type=int, metavar="N", help="passes over the image (--stack: default 4)"
    )
    render.add_argument("--seed", type=_seed, metavar="S", help="random seed (default 0)")
    render.add_argument(
        "--mean-threshold", type=float, metavar="T", help="t of Eq. 2 (paper: 0.12)"
    )
    render.add_argument(
        "--variance-threshold", type=float, metavar="V", help="V of Eq. 4 (paper: 0.50)"
    )
    render.add_argument(
        "--max-tries", type=int, metavar="K", help="draws of Eq. 3 per pixel (paper preset: 10)"
    )
    render.add_argument(
        "--tone-limits",
        nargs=2,
        type=float,
        metavar=("LOW", "HIGH"),
        help=(
            "values mapped to tones 0 and 255 (default: 0 255 for uint8, else the 0.5th "
            "and 99.5th percentiles, which takes extra reads of a lazily rendered input)"
        ),
    )
    render.add_argument(
        "--channel-axis",
        type=int,
        metavar="A",
        help=(
            "axis of colour channels (default: -1 for RGB(A) PNG/JPEG/BMP files, none for TIFF)"
        ),
    )
    render.add_argument(
        "--set",
        action="append",
        type=_assignment,
        dest="assignments",
        metavar="PARAM=VALUE",
        help=(
            "any other parameter of the algorithm, e.g. --set border=mirror "
            "--set scan=serpentine (repeatable)"
        ),
    )
    variants = render.add_mutually_exclusive_group()
    variants.add_argument(
        "--stack",
        action="store_true",
        help="write the input and the image after every pass: shape (N+1, ...), as TIFF",
    )
    variants.add_argument(
        "--sweep",
        type=_sweep,
        metavar="PARAM=V1,V2,...",
        help=(
            "render once per value of one parameter (e.g. variance_threshold=0.47,0.5,0.53 "
            "or seed=1,2,3): shape (len(values), ...), as TIFF"
        ),
    )


# -- values ---------------------------------------------------------------------------------------


def _seed(text: str) -> int:
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"not an integer: {text!r}") from None
    if not 0 <= value < 2**64:
        raise argparse.ArgumentTypeError(f"must be between 0 and 2**64 - 1, got {value}")
    return value


def _scheduler_address(text: str) -> str | int:
    """A scheduler address, or the number of local workers of ``local[:N]``."""
    text = text.strip()
    name, sep, count = text.partition(":")
    if name != "local":
        if not text:
            raise argparse.ArgumentTypeError("empty address")
        return text
    if not sep:
        return os.cpu_count() or 1
    try:
        workers = int(count)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected local:N, got {text!r}") from None
    if not 1 <= workers <= 1024:
        raise argparse.ArgumentTypeError(f"local:N needs 1 <= N <= 1024, got {workers}")
    return workers


def _sweep(text: str) -> tuple[str, list[Any]]:
    """``--sweep PARAM=V1,V2,...``: the parameter's name and its values."""
    name, values = _split_assignment(text, "PARAM=V1,V2,...")
    return name, [_parse_value(v.strip()) for v in values.split(",")]


def _assignment(text: str) -> tuple[str, Any]:
    """``--set PARAM=VALUE``: the parameter's name and its value."""
    name, value = _split_assignment(text, "PARAM=VALUE")
    return name, _parse_value(value.strip())


def _split_assignment(text: str, form: str) -> tuple[str, str]:
    """The name (``-`` read as ``_``) and the text after ``=``; neither may be empty."""
    name, sep, value = text.partition("=")
    name = name.strip().replace("-", "_")
    if not sep or not name or not value.strip():
        raise argparse.ArgumentTypeError(f"expected {form}, got {text!r}")
    return name, value


def _parse_value(text: str) -> Any:
    """A sweep value: int, float, bool or (for choices such as border) the text."""
    for convert in (int, float):
        try:
            return convert(text)
        except ValueError:
            pass
    if text.lower() in ("true", "false"):
        return text.lower() == "true"
    return text


# -- options for the API --------------------------------------------------------------------------


def render_options(args: argparse.Namespace) -> dict[str, Any]:
    """Keyword arguments for the API from the command line, validated up front."""
    from ..api import resolve_parameters
    from ..parameters import PARAMETER_NAMES
    from ..presets import DEFAULT_PRESET

    parameters = {
        "passes": args.passes,
        "mean_threshold": args.mean_threshold,
        "variance_threshold": args.variance_threshold,
        "max_tries": args.max_tries,
    }
    parameters = {name: value for name, value in parameters.items() if value is not None}
    for name, value in args.assignments or ():
        if name not in PARAMETER_NAMES:
            raise UsageError(
                f"--set: unknown parameter {name!r}; use one of {', '.join(PARAMETER_NAMES)}"
            )
        if name in parameters:
            raise UsageError(f"{name} is given twice")
        parameters[name] = value
    options: dict[str, Any] = dict(parameters)
    if args.preset is not None:
        options["preset"] = args.preset
    if args.seed is not None:
        options["seed"] = args.seed
    if args.tone_limits is not None:
        low, high = args.tone_limits
        if not (math.isfinite(low) and math.isfinite(high) and low < high):
            raise UsageError(f"--tone-limits must be finite with LOW < HIGH, got {low} {high}")
        options["tone_limits"] = (low, high)

    preset = args.preset or DEFAULT_PRESET
    try:
        resolve_parameters(preset, **parameters)
        if args.sweep is not None:
            _check_sweep(args.sweep, preset, parameters, options)
    except (ValueError, TypeError) as exc:
        raise UsageError(one_line(str(exc))) from None
    return options


def _check_sweep(
    sweep: tuple[str, list[Any]],
    preset: str,
    parameters: dict[str, Any],
    options: dict[str, Any],
) -> None:
    from ..api import resolve_parameters
    from ..parameters import PARAMETER_NAMES

    name, values = sweep
    names = PARAMETER_NAMES + ("seed",)
    if name not in names:
        raise ValueError(f"--sweep: unknown parameter {name!r}; use one of {', '.join(names)}")
    if name in options:
        raise ValueError(f"--sweep varies {name}; do not also give it a value")
    for value in values:
        if name == "seed":
            if isinstance(value, bool) or not isinstance(value, int) or not 0 <= value < 2**64:
                raise ValueError(f"--sweep: seed values must be integers >= 0, got {value!r}")
        else:
            resolve_parameters(preset, **parameters, **{name: value})
