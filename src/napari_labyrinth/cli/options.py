"""The options of ``napari-labyrinth``'s commands: flags from the parameter table, their values.

Every flag that becomes a keyword argument of the API is added by
:func:`add_parameter_arguments` (one per parameter of the table that takes
one word, ``--set NAME=VALUE`` for any of them, ``--sweep NAME=V1,V2,...``)
and gathered by :func:`render_options`, which parses the values with the
table so that a bad one gets the table's one-line message. The value parsers
of the other flags (:func:`scheduler_address`, :func:`seconds`) and the
defaults the help texts name are here too. Nothing heavy is imported here, so
``--help`` answers at once.
"""

from __future__ import annotations

import argparse
import os
from typing import Any

from ..core.colour import COLOUR_MODES
from ..core.parameters import AUTO, PARAMETERS, SWEEPABLE, format_value, without_auto
from ..core.presets import DEFAULT_PRESET, PRESETS, resolve_parameters, resolve_sweep
from ..core.tone_scale import validate_tone_limits
from ._common import UsageError, one_line

__all__ = [
    "DEMO_STACK_PASSES",
    "SCHEDULER_TIMEOUT",
    "add_parameter_arguments",
    "parameter_help",
    "render_options",
    "scheduler_address",
    "seconds",
]

#: Seconds to wait for a dask scheduler given by --scheduler (--scheduler-timeout).
SCHEDULER_TIMEOUT = 10.0

#: Passes of the stack ``napari-labyrinth demo`` writes.
DEMO_STACK_PASSES = 4


def add_parameter_arguments(render: argparse.ArgumentParser) -> None:
    """Every flag of ``render`` that becomes a keyword argument of the API, in help order.

    The preset, one flag per parameter of the table that takes one word
    (``--set`` takes any of them as ``NAME=VALUE``), the seed, the tone
    limits, the channel axis and how channels are rendered, and ``--stack`` or
    ``--sweep``. Values are kept
    as text here and parsed by ``render_options``, so that a bad value gets
    the table's one-line message.
    """
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


def scheduler_address(text: str) -> str | int:
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


def seconds(text: str) -> float:
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
    name, texts = args.sweep
    if name not in SWEEPABLE:
        raise UsageError(f"--sweep: unknown parameter {name!r}; use one of {', '.join(SWEEPABLE)}")
    if name in given or (name == "seed" and args.seed is not None):
        raise UsageError(f"--sweep varies {name}; do not also give it a value")
    return name, SWEEPABLE[name].parse_values(texts)
