"""The arguments of ``napari-labyrinth``: the parser, the value parsers and the API options.

Every flag that becomes a keyword argument of the API is added by
``_add_parameter_arguments`` and gathered by ``render_options``; the values
of ``--set`` and ``--sweep`` are read by ``_parse_value``. Nothing heavy is
imported here, so ``--help`` answers at once.
"""

from __future__ import annotations

import argparse
import os
from typing import Any

from ..core.parameters import AUTO
from . import PROG, UsageError, one_line
from .demo import DEMO_STACK_PASSES


def build_parser() -> argparse.ArgumentParser:
    """The parser of ``napari-labyrinth`` and its ``render`` and ``demo`` commands."""
    from .. import __version__
    from ..core.presets import DEFAULT_PRESET
    from .render import SCHEDULER_TIMEOUT

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
        "--scheduler-timeout",
        type=_seconds,
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


def _add_parameter_arguments(render: argparse.ArgumentParser) -> None:
    """Every flag of ``render`` that becomes a keyword argument of the API, in help order.

    The preset, one flag per parameter of the table that takes one word
    (``--set`` takes any of them as ``NAME=VALUE``), the seed, the tone
    limits, the channel axis and how channels are rendered, and ``--stack`` or
    ``--sweep``. Values are kept
    as text here and parsed by ``render_options``, so that a bad value gets
    the table's one-line message.
    """
    from ..core.colour import COLOUR_MODES
    from ..core.parameters import SWEEPABLE
    from ..core.presets import DEFAULT_PRESET, PRESETS

    render.add_argument(
        "--preset", choices=sorted(PRESETS), help=f"parameter set (default {DEFAULT_PRESET})"
    )
    for name, parameter in SWEEPABLE.items():
        render.add_argument(
            _flag(name),
            dest=name,
            metavar=_metavar(parameter),
            help=parameter_help(name).replace("%", "%%"),
        )
    render.add_argument(
        "--tone-limits",
        nargs=2,
        type=float,
        metavar=("LOW", "HIGH"),
        help=(
            "values mapped to tones 0 and 255 (default: 0 255 for uint8, else the 0.5th "
            "and 99.5th percentiles, which takes extra reads of a lazily rendered input); "
            "values outside them are clipped to them where a pixel changes"
        ),
    )
    render.add_argument(
        "--channel-axis",
        type=_channel_axis,
        metavar="A|none",
        help=(
            "axis of colour channels, or none (every axis but the last two holds planes); "
            "default: what the file says (TIFF photometric RGB, the colour type of "
            "PNG/JPEG/BMP files; none for OME channels and files without colour metadata)"
        ),
    )
    render.add_argument(
        "--colour",
        choices=tuple(COLOUR_MODES),
        help=(
            "how channels are rendered: "
            + "; ".join(f"{name}: {text}" for name, text in COLOUR_MODES.items())
        ),
    )
    render.add_argument(
        "--set",
        action="append",
        type=_assignment,
        dest="assignments",
        metavar="PARAM=VALUE",
        help="any parameter, as NAME=VALUE (repeatable), e.g. --set border=mirror",
    )
    variants = render.add_mutually_exclusive_group()
    variants.add_argument(
        "--stack",
        action="store_true",
        help=(
            "write the input and the image after every pass: shape (N+1, ...) with N = "
            "--passes (default 4), as TIFF or zarr"
        ),
    )
    centre = PRESETS[DEFAULT_PRESET]["variance_threshold"]
    variants.add_argument(
        "--sweep",
        type=_assignment,
        metavar="PARAM=V1,V2,...",
        help=(
            "render once per value of one parameter (e.g. variance_threshold="
            f"{centre * 0.75:g},{centre:g},{centre * 1.25:g} or seed=1,2,3): shape "
            "(len(values), ...), as TIFF or zarr"
        ),
    )


def parameter_help(name: str) -> str:
    """A parameter's help: the table's doc line, its default under the default preset, and
    the paper's value (the seed has no paper value)."""
    from ..core.parameters import PARAMETERS, SWEEPABLE, format_value
    from ..core.presets import DEFAULT_PRESET, PRESETS

    parameter = SWEEPABLE[name]
    where = parameter.equation
    if parameter.symbol:
        where = f"{parameter.symbol} of {where}"
    if name not in PARAMETERS:  # the seed
        return f"{where}: {parameter.doc} (default 0)"
    default = format_value(PRESETS[DEFAULT_PRESET][name])
    paper = format_value(parameter.paper)
    return (
        f"{where}: {parameter.doc} "
        f"(default {default} with the {DEFAULT_PRESET} preset; paper {paper})"
    )


def _channel_axis(text: str) -> int | str:
    """``--channel-axis``: an integer, or ``none`` (no colour axis, whatever the file says)."""
    if text.strip().lower() == "none":
        return "none"
    try:
        return int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected an integer or none, got {text!r}") from None


def _flag(name: str) -> str:
    return "--" + name.replace("_", "-")


def _metavar(parameter) -> str:
    if parameter.automatic:
        return f"{parameter.symbol or 'X'}|{AUTO}"
    if parameter.kind == "choice":
        return "{" + ",".join(parameter.choices) + "}"
    return {
        "float": parameter.symbol or "X",
        "int": "N",
        "seed": "S",
        "bool": "{true,false}",
        "tone_ranges": "N|L0,L1,...",
    }[parameter.kind]


# -- values ---------------------------------------------------------------------------------------


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


def _seconds(text: str) -> float:
    """A positive, finite number of seconds (up to a day)."""
    try:
        seconds = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a number of seconds, got {text!r}") from None
    if not 0 < seconds <= 86400:
        raise argparse.ArgumentTypeError(f"expected 0 < SECONDS <= 86400, got {text}")
    return seconds


def _assignment(text: str) -> tuple[str, str]:
    """``NAME=VALUE`` (``--set``) or ``NAME=V1,V2,...`` (``--sweep``): the name and the text.

    The name may use ``-`` for ``_``; neither side may be empty. The value is
    parsed by ``render_options``, which knows the parameter's type.
    """
    name, sep, value = text.partition("=")
    name = name.strip().replace("-", "_")
    if not sep or not name or not value.strip():
        raise argparse.ArgumentTypeError(f"expected NAME=VALUE, got {text!r}")
    return name, value.strip()


# -- options for the API --------------------------------------------------------------------------


def render_options(args: argparse.Namespace) -> dict[str, Any]:
    """Keyword arguments for :func:`napari_labyrinth.labyrinth_steps`, validated up front.

    Parameter values come from their own flags and from ``--set``, parsed by
    the parameter table; ``--sweep`` adds ``parameter`` and ``values``.

    Raises
    ------
    UsageError
        One line naming the parameter and what it expects.
    """
    from ..core.parameters import without_auto
    from ..core.presets import DEFAULT_PRESET, resolve_parameters, resolve_sweep
    from ..core.tone_scale import validate_tone_limits

    preset = args.preset or DEFAULT_PRESET
    try:
        options = _parameter_values(args)
        seed = options.pop("seed", None)
        if args.sweep is not None:
            name, values = _sweep_values(args, options)
            resolve_sweep(preset, without_auto(options), seed, name, values)
            options.update(parameter=name, values=values)
        else:
            resolve_parameters(preset, **without_auto(options))  # "auto": chosen per image
    except (ValueError, TypeError) as exc:
        raise UsageError(one_line(str(exc))) from None
    if args.preset is not None:
        options["preset"] = args.preset
    if args.colour is not None:
        options["colour"] = args.colour
    if seed is not None:
        options["seed"] = seed
    if args.tone_limits is not None:
        try:
            options["tone_limits"] = validate_tone_limits(args.tone_limits)
        except ValueError:
            low, high = args.tone_limits
            raise UsageError(
                f"--tone-limits must be finite with LOW < HIGH, got {low} {high}"
            ) from None
    return options


def _parameter_values(args: argparse.Namespace) -> dict[str, Any]:
    """The parameters and the seed given by their flags or ``--set``, parsed by the table."""
    from ..core.parameters import PARAMETERS, SWEEPABLE

    given = [(name, getattr(args, name)) for name in SWEEPABLE if getattr(args, name) is not None]
    for name, text in args.assignments or ():
        if name not in PARAMETERS:
            raise UsageError(
                f"--set: unknown parameter {name!r}; use one of {', '.join(PARAMETERS)}"
            )
        given.append((name, text))
    values: dict[str, Any] = {}
    for name, text in given:
        if name in values:
            raise UsageError(f"{name} is given twice")
        values[name] = (PARAMETERS.get(name) or SWEEPABLE[name]).parse(text)
    return values


def _sweep_values(args: argparse.Namespace, given: dict[str, Any]) -> tuple[str, list[Any]]:
    """``--sweep``'s parameter and its values, parsed by the table."""
    from ..core.parameters import SWEEPABLE

    name, texts = args.sweep
    if name not in SWEEPABLE:
        raise UsageError(f"--sweep: unknown parameter {name!r}; use one of {', '.join(SWEEPABLE)}")
    if name in given or (name == "seed" and args.seed is not None):
        raise UsageError(f"--sweep varies {name}; do not also give it a value")
    return name, SWEEPABLE[name].parse_values(texts)
