"""The algorithm's parameters: one table, one validated immutable set per rendering.

Each field of :class:`LabyrinthParameters` carries its :class:`Parameter`
entry, written once: type, the paper's value, bounds or choices, label,
equation and a one-line doc. Validation, the presets, the command line's flags
and ``--set``/``--sweep`` parsing, the widget's form and tooltips, the
metadata record and the kernel/oracle test grid are derived from it.

Every point where the paper leaves a choice open is a named option, with the
literal reading of the printed text as its ``paper`` value; see
``docs/algorithm.md`` for the mapping of each option to the paper's words.
"""

from __future__ import annotations

import dataclasses
import math
import numbers
import re
from collections.abc import Mapping
from types import MappingProxyType
from typing import Any

import numpy as np

from .codes import DIAGNOSTIC_FIELDS, OPTION_CODES

__all__ = [
    "AUTO",
    "DIAGNOSTIC_FIELDS",
    "FLOAT_DECIMALS",
    "PARAMETERS",
    "PARAMETER_NAMES",
    "PLANE_OFFSET",
    "SEED",
    "SWEEPABLE",
    "WORKERS",
    "LabyrinthParameters",
    "Parameter",
    "equal_tone_ranges",
    "make_parameters",
]

#: Default lower limit L_inf^1 of the first tone range ("a low value different
#: from zero", Sec. 2); the last range ends at 255.
LOWEST_TONE = 10.0

#: Decimals a real parameter is typed and shown with (the widget's fields). A value
#: chosen from the image is rounded to them (``find_window``'s grid of V), so that
#: the value a form shows is the value run and recorded.
FLOAT_DECIMALS = 4

#: The value of a parameter with ``automatic=True`` that asks for it to be
#: chosen from the image (``napari_labyrinth.find_window`` for V).
AUTO = "auto"

#: Words a boolean may be typed as.
_BOOLEAN_WORDS = {"true": True, "yes": True, "1": True, "false": False, "no": False, "0": False}

#: The kinds of value a parameter takes.
KINDS = ("float", "int", "choice", "bool", "tone_ranges", "tones", "seed")


def format_value(value: Any) -> str:
    """A parameter value in words (layer names, help): ``0.04``, ``true``, ``inside``;
    tone range limits as they are typed, ``0,10,91.67,173.3,255`` (numbers to 4 digits)."""
    if isinstance(value, (bool, np.bool_)):
        return str(bool(value)).lower()
    if isinstance(value, (float, np.floating)):
        return f"{float(value):.4g}"
    if isinstance(value, (tuple, list, np.ndarray)) and np.ndim(value) == 1:
        return ",".join(format_value(item) for item in value)
    return str(value)


@dataclasses.dataclass(frozen=True)
class Parameter:
    """One entry of the parameter table.

    Attributes
    ----------
    name : str
        The keyword (``variance_threshold``).
    kind : {"float", "int", "choice", "bool", "tone_ranges", "tones", "seed"}
        What values it takes; says how it is validated and parsed from text.
    paper : object
        Its value in the literal reading of the paper (the ``"paper"`` preset).
    label : str
        Short label for forms (``"variance threshold V"``).
    equation : str
        The paper's equation it belongs to (``"Eq. 4"``), or its section.
    doc : str
        One line: what it means.
    low, high : int or float
        Inclusive bounds of a number (of the count, for ``tone_ranges``):
        every number has both, so that no value can reach an allocation,
        the kernel's integer types or a compilation unchecked.
    choices : tuple of str, optional
        The options of a ``"choice"``.
    reading : bool
        A point the paper leaves open (the widget's advanced section).
    symbol : str, optional
        The paper's letter, in layer names (``"V"``).
    automatic : bool
        Whether the value may be ``AUTO``: chosen from the image before the
        rendering (never by :func:`make_parameters`, which needs a number).
    """

    name: str
    kind: str
    paper: Any
    label: str
    equation: str
    doc: str
    low: float | None = None
    high: float | None = None
    choices: tuple[str, ...] | None = None
    reading: bool = False
    symbol: str | None = None
    automatic: bool = False

    @property
    def type_text(self) -> str:
        """The type as numpydoc writes it in a Parameters section."""
        if self.kind == "choice":
            return "{" + ", ".join(f'"{choice}"' for choice in self.choices) + "}"
        if self.automatic:
            return f'{self.kind} or "{AUTO}"'
        return {
            "float": "float",
            "int": "int",
            "seed": "int",
            "bool": "bool",
            "tone_ranges": "int or sequence of float",
            "tones": "sequence of (float, float)",
        }[self.kind]

    @property
    def bounds_text(self) -> str:
        """The allowed values in words, for messages and help."""
        if self.kind == "choice":
            return "one of " + ", ".join(map(repr, self.choices))
        if self.kind == "bool":
            return "True or False"
        if self.low is not None and self.high is not None:
            return f"between {_bound_text(self.low)} and {_bound_text(self.high)}"
        if self.low is not None:
            return f">= {_bound_text(self.low)}"
        return "any value"

    @property
    def tooltip(self) -> str:
        """The doc line with the equation and the paper's value, for forms and help."""
        paper = "" if self.paper is None else f" Paper: {format_value(self.paper)}."
        where = f"{self.symbol} of {self.equation}" if self.symbol else self.equation
        return f"{where}: {self.doc}.{paper}"

    def validate(self, value: Any) -> Any:
        """``value`` checked and normalised; TypeError or ValueError naming the parameter."""
        return _VALIDATORS[self.kind](self, value)

    def parse(self, text: str) -> Any:
        """A value typed as text (command line, widget), converted and checked.

        The value keeps the form it was given in (a ``tone_ranges`` count
        stays a count), as a caller would pass it to the API.

        Raises
        ------
        ValueError
            Naming the parameter and what it expects.
        """
        text = text.strip()
        if self.automatic and text.lower() == AUTO:
            return AUTO
        if self.kind == "tones":
            raise ValueError(
                f"{self.name} cannot be given as text: set tone_ranges (its tones follow), "
                "or pass tones to the Python API"
            )
        try:
            if self.kind in ("int", "seed") or (self.kind == "tone_ranges" and "," not in text):
                value: Any = int(text)
            elif self.kind == "tone_ranges":
                value = [float(part) for part in text.split(",")]
            elif self.kind == "float":
                value = float(text)
            elif self.kind == "bool":
                value = _BOOLEAN_WORDS[text.lower()]
            else:
                value = text
        except (ValueError, KeyError):
            raise ValueError(f"{self.name} must be {self.expected}; got {text!r}") from None
        try:
            self.validate(value)
        except TypeError as exc:
            raise ValueError(str(exc)) from None
        return tuple(value) if isinstance(value, list) else value

    def parse_values(self, text: str) -> list[Any]:
        """Values typed as text, separated by commas, semicolons or spaces, each as :meth:`parse`.

        ``"0.47, 0.50;0.53"`` gives ``[0.47, 0.5, 0.53]``. Spaces alone
        separate values; a comma or semicolon (with any spaces around it)
        separates two values, so two of them in a row, or one at either end,
        leave a value empty, which is refused (``"0.03,,0.05"``), not skipped.
        A decimal comma is refused, not read as two values: a comma between
        digits in a text with no decimal point (``"0,04"``), or a value of this
        parameter with a leading zero (``"04"``). There is no range syntax: a
        value such as ``"0.03:0.05"`` is refused as not a value, with a hint.

        Raises
        ------
        ValueError
            Naming the parameter: no value, an empty value, a value :meth:`parse`
            refuses, or a decimal comma.
        """
        stripped = text.strip()
        items = _VALUE_SEPARATORS.split(stripped)
        values = [item for item in items if item]
        if not values:
            raise ValueError(
                f"type at least one value of {self.name} to sweep, e.g. {self._example}"
            )
        if self.kind == "float" and (
            ("." not in text and _DIGIT_COMMA_DIGIT.search(text))
            or any(_LEADING_ZERO.match(item) for item in values)
        ):
            read = " and ".join(
                [", ".join(values[:-1]), values[-1]] if len(values) > 1 else values
            )
            raise ValueError(
                f"{self.name}: {stripped!r} has a decimal comma (it would be read as the "
                f"values {read}): write decimals with a point and separate the values with "
                f"commas or spaces, e.g. {self._example}"
            )
        if "" in items:
            raise ValueError(self._empty_value_message(stripped, items))
        parsed = []
        for item in items:
            try:
                parsed.append(self.parse(item))
            except ValueError as exc:
                if _RANGE.search(item):
                    raise ValueError(
                        f"{exc}: a sweep has no range syntax; list its values one by one, "
                        f"e.g. {self._example}"
                    ) from None
                raise
        return parsed

    def _empty_value_message(self, text: str, items: list[str]) -> str:
        """Why ``text``, split into ``items`` of which one is empty, is refused: which value."""
        index = items.index("")
        before = next((item for item in reversed(items[:index]) if item), None)
        after = next((item for item in items[index + 1 :] if item), None)
        if before is None:
            where = f"before {after}"
        elif after is None:
            where = f"after {before}"
        else:
            where = f"between {before} and {after}"
        return (
            f"{self.name}: value {index + 1} of {text!r} is empty ({where}): separate the "
            f"values with one comma each, e.g. {self._example}"
        )

    @property
    def _example(self) -> str:
        """Values of this parameter as one would type them."""
        if self.kind == "float":
            return "0.47, 0.50, 0.53"
        if self.kind == "choice":
            return ", ".join(self.choices)
        if self.kind == "bool":
            return "false, true"
        return "1, 2, 3"

    @property
    def expected(self) -> str:
        """What a text value must be, in words."""
        return {
            "float": "a number",
            "int": "a whole number",
            "seed": "a whole number",
            "bool": "true or false",
            "tone_ranges": "a count of ranges or comma-separated limits",
            "tones": "pairs of tones",
        }.get(self.kind) or " or ".join(self.choices)


#: What separates two values of a sweep typed as text: one comma or semicolon with any
#: spaces around it, or spaces alone. Two commas in a row leave an empty value between them.
_VALUE_SEPARATORS = re.compile(r"\s*[,;]\s*|\s+")
#: A value typed as a range (``0.03:0.05``, ``0.03..0.05``, ``1-4``), which a sweep does not read.
_RANGE = re.compile(r":|\.\.|\d-[\d.]")
#: A comma between digits: a decimal comma where the text has no decimal point.
_DIGIT_COMMA_DIGIT = re.compile(r"\d,\d")
#: A number with a leading zero (``04``): what is left of ``0,04`` split at its comma.
_LEADING_ZERO = re.compile(r"[+-]?0\d")


def _bound_text(value: float) -> str:
    """A bound in words: ``2**63 - 1`` for the largest 64-bit integer, ``1e+06``, ``0.5``."""
    if value == _INT64_MAX:
        return "2**63 - 1"
    return f"{value:g}"


#: Largest signed 64-bit integer: the kernel's plane index and the widget's spin
#: boxes hold no more, so the seed and the plane offset stop there.
_INT64_MAX = 2**63 - 1

#: Largest value of a threshold: far beyond any useful one (Eq. 2 and 4 compare
#: ratios of tones on the 0-255 scale), small enough for every form and float32.
_THRESHOLD_MAX = 1e6


def _entry(**spec: Any) -> Any:
    """A dataclass field carrying its table entry (the name is filled in below)."""
    return dataclasses.field(metadata={"parameter": Parameter(name="", **spec)})


def _choices(name: str) -> tuple[str, ...]:
    return tuple(OPTION_CODES[name])


@dataclasses.dataclass(frozen=True)
class LabyrinthParameters:
    mean_threshold: float = _entry(
        kind="float",
        paper=0.12,
        low=0.0,
        high=_THRESHOLD_MAX,
        label="mean threshold t",
        symbol="t",
        equation="Eq. 2",
        doc="g is kept when |g - M| / M <= t, M being the mean of its 8 neighbours",
    )
    variance_threshold: float = _entry(
        kind="float",
        paper=0.50,
        low=0.0,
        high=_THRESHOLD_MAX,
        label="variance threshold V",
        symbol="V",
        equation="Eq. 4",
        doc=(
            "where the variance ratio R2 exceeds V, g is left as it is (or pushed away "
            "from M); the labyrinth appears only in a narrow range of V (Fig. 3); "
            "'auto' measures that range on the image and takes its best V"
        ),
        automatic=True,
    )
    tone_ranges: tuple[float, ...] = _entry(
        kind="tone_ranges",
        paper=3,
        low=1,
        high=255,
        label="tone ranges",
        equation="Eq. 3",
        doc=(
            "A count of equal tone ranges from a low non-zero tone (10) to 255, or the "
            "limits L_inf^1 < L_sup^1 = L_inf^2 < ... <= 255; g* is drawn in the range of g"
        ),
    )
    tones: tuple[tuple[float, float], ...] = _entry(
        kind="tones",
        paper=None,
        label="tones",
        equation="Eq. 3",
        doc="(T_inf^i, T_sup^i) of each range; None: T = L (setting tone_ranges resets them)",
    )
    max_tries: int = _entry(
        kind="int",
        paper=10,
        low=0,
        high=10_000,
        label="max tries",
        equation="Eq. 3",
        doc="Draws of Eq. 3 per pixel before giving up (the paper gives no number)",
    )
    passes: int = _entry(
        kind="int",
        paper=1,
        low=0,
        high=1000,
        label="passes",
        equation="Fig. 4",
        doc="Passes over the image; Fig. 4 iterates the algorithm to enhance edges",
    )
    border: str = _entry(
        kind="choice",
        paper="inside",
        choices=_choices("border"),
        reading=True,
        label="border",
        equation="Eq. 1",
        doc=(
            "Neighbours of border pixels: only those inside the image (N is their number), "
            "or completed as the scipy.ndimage modes of the same names"
        ),
    )
    variance_ratio: str = _entry(
        kind="choice",
        paper="sqrt(V/N)/M",
        choices=_choices("variance_ratio"),
        reading=True,
        label="variance ratio",
        equation="Eq. 4",
        doc="R2: sqrt(V/N)/M as printed, or sqrt(V)/M (the coefficient of variation)",
    )
    variance_action: str = _entry(
        kind="choice",
        paper="leave",
        choices=_choices("variance_action"),
        reading=True,
        label="variance action",
        equation="Eq. 4",
        doc=(
            "Where Eq. 4 holds: leave g as printed, or push it further from M with draws on "
            "its side of M, in its tone range or up to the end of the tone scale"
        ),
    )
    condition_order: str = _entry(
        kind="choice",
        paper="mean_first",
        choices=_choices("condition_order"),
        reading=True,
        label="condition order",
        equation="Eq. 2, 4",
        doc="Which condition decides first: Eq. 2 (as printed) or Eq. 4",
    )
    on_exhausted: str = _entry(
        kind="choice",
        paper="keep",
        choices=_choices("on_exhausted"),
        reading=True,
        label="on exhausted",
        equation="Eq. 3",
        doc="What a pixel becomes when no draw satisfies Eq. 2: it keeps g, or the last draw",
    )
    include_centre: bool = _entry(
        kind="bool",
        paper=False,
        reading=True,
        label="include centre",
        equation="Eq. 1",
        doc="Whether the pixel joins its own M and V (Eq. 1 sums over the neighbours only)",
    )
    scan: str = _entry(
        kind="choice",
        paper="raster",
        choices=_choices("scan"),
        reading=True,
        label="scan",
        equation="Sec. 2",
        doc=(
            "Order of the in-place update from the top-left corner: rows left to right, odd "
            "rows right to left, or (not the paper's order) the four checkerboard colours "
            "in turn, which lets one plane use every core"
        ),
    )
    noise_gate: float = _entry(
        kind="float",
        paper=0.0,
        low=0.0,
        high=100.0,
        reading=True,
        label="noise gate k",
        equation="not in the paper",
        doc=(
            "A pixel Eq. 2 does not keep first is left alone where V of Eq. 1 is at most "
            "(k sigma)^2, sigma the plane's own noise (Immerkaer's estimate, or its dark "
            "field's if larger): black backgrounds stay clean; 0 turns the gate off"
        ),
    )

    def as_dict(self) -> dict[str, Any]:
        """Plain-Python dict (JSON-serialisable) of every parameter."""
        out = dataclasses.asdict(self)
        out["tone_ranges"] = list(self.tone_ranges)
        out["tones"] = [list(pair) for pair in self.tones]
        return out


#: The table: every parameter of the algorithm, in the order of the fields.
PARAMETERS: Mapping[str, Parameter] = MappingProxyType(
    {
        field.name: dataclasses.replace(field.metadata["parameter"], name=field.name)
        for field in dataclasses.fields(LabyrinthParameters)
    }
)

#: Parameter names a preset or a caller may set.
PARAMETER_NAMES = tuple(PARAMETERS)

#: The seed of the random draws when none is given.
DEFAULT_SEED = 0

#: The seed of the random draws: not a parameter of the algorithm, but set beside them.
SEED = Parameter(
    name="seed",
    kind="seed",
    paper=None,
    low=0,
    high=_INT64_MAX,
    label="seed",
    equation="Eq. 3",
    doc=(
        "Seed of the random draws R: the result is a pure function of the image, the "
        "parameters and the seed"
    ),
)

#: The random stream index of an image's first plane in a larger stack it was taken
#: from (a rendering option, beside the parameters); with the planes after it, it must
#: stay within the kernel's 64-bit plane index.
PLANE_OFFSET = Parameter(
    name="plane_offset",
    kind="int",
    paper=0,
    low=0,
    high=_INT64_MAX,
    label="plane offset",
    equation="Eq. 3",
    doc=(
        "Flat index of the image's first plane in a larger stack: plane k draws the "
        "random stream of plane plane_offset + k"
    ),
)

#: Threads of a run (a rendering option): at least one, at most a generous multiple
#: of any machine's cores (each thread holds a plane's work arrays).
WORKERS = Parameter(
    name="workers",
    kind="int",
    paper=None,
    low=1,
    high=1024,
    label="workers",
    equation="Sec. 2",
    doc="Threads that render planes (or a checkerboard plane's bands) at once",
)

#: What a sweep may vary: every parameter that has a value in one word, and the seed.
SWEEPABLE: Mapping[str, Parameter] = MappingProxyType(
    {name: p for name, p in PARAMETERS.items() if p.kind != "tones"} | {"seed": SEED}
)


def _attributes_section() -> str:
    lines = []
    for parameter in PARAMETERS.values():
        lines.append(f"    {parameter.name} : {parameter.type_text}")
        lines.append(f"        {parameter.tooltip}")
    return "\n".join(lines)


LabyrinthParameters.__doc__ = f"""A complete, validated set of parameters for one rendering.

    Build one with :func:`make_parameters` (or ``napari_labyrinth.resolve_parameters``,
    which starts from a preset). ``tone_ranges`` holds the n + 1 limits of the
    n ranges and ``tones`` one ``(T_inf, T_sup)`` pair per range.

    Attributes
    ----------
{_attributes_section()}
    """


def equal_tone_ranges(count: int) -> tuple[float, ...]:
    """Limits of ``count`` equal tone ranges from ``LOWEST_TONE`` to 255 (Sec. 2)."""
    return tuple(float(v) for v in np.linspace(LOWEST_TONE, 255.0, count + 1))


def is_auto(value: Any) -> bool:
    """Whether ``value`` asks for a parameter to be chosen from the image."""
    return isinstance(value, str) and value == AUTO


def without_auto(values: Mapping[str, Any]) -> dict[str, Any]:
    """``values`` without the parameters set to ``AUTO`` (to validate the others first)."""
    return {
        name: value
        for name, value in values.items()
        if not (name in PARAMETERS and PARAMETERS[name].automatic and is_auto(value))
    }


def make_parameters(**values: Any) -> LabyrinthParameters:
    """Validate ``values`` and build a :class:`LabyrinthParameters`.

    ``tone_ranges`` may be a count of equal ranges or the sequence of limits;
    ``tones=None`` means T = L (Eq. 3). Raises ValueError or TypeError naming
    the offending parameter.
    """
    unknown = set(values) - set(PARAMETER_NAMES)
    if unknown:
        raise TypeError(f"unknown parameter(s): {', '.join(sorted(unknown))}")
    missing = set(PARAMETER_NAMES) - set(values) - {"tones"}
    if missing:
        raise TypeError(f"missing parameter(s): {', '.join(sorted(missing))}")
    checked = {
        name: parameter.validate(values[name])
        for name, parameter in PARAMETERS.items()
        if parameter.kind != "tones"
    }
    checked["tones"] = _tones(values.get("tones"), checked["tone_ranges"])
    return LabyrinthParameters(**checked)


def _is_integer(value: Any) -> bool:
    return isinstance(value, numbers.Integral) and not isinstance(value, (bool, np.bool_))


def _is_real(value: Any) -> bool:
    return isinstance(value, numbers.Real) and not isinstance(value, (bool, np.bool_))


def as_float(value: numbers.Real) -> float:
    """``float(value)`` of a real number; one beyond float64 (a huge ``int`` or ``Fraction``)
    is an infinity of its sign, which every finite bound refuses by name."""
    try:
        return float(value)
    except OverflowError:
        return math.inf if value > 0 else -math.inf


def _float(parameter: Parameter, value: Any) -> float:
    if parameter.automatic and is_auto(value):
        raise ValueError(
            f"{parameter.name}={AUTO!r} is chosen from the image: pass the image to "
            "labyrinth() or find_window() rather than building parameters without it"
        )
    value = scalar(value)
    if not _is_real(value):
        also = f" or {AUTO!r}" if parameter.automatic else ""
        raise TypeError(f"{parameter.name} must be a real number{also}, got {value!r}")
    number = as_float(value)
    in_bounds = (parameter.low is None or number >= parameter.low) and (
        parameter.high is None or number <= parameter.high
    )
    if not math.isfinite(number) or not in_bounds:
        raise ValueError(
            f"{parameter.name} must be finite and {parameter.bounds_text}, got {value!r}"
        )
    return number


def _integer(parameter: Parameter, value: Any) -> int:
    value = scalar(value)
    if not _is_integer(value):
        raise TypeError(f"{parameter.name} must be an integer, got {value!r}")
    value = int(value)
    if (parameter.low is not None and value < parameter.low) or (
        parameter.high is not None and value > parameter.high
    ):
        raise ValueError(f"{parameter.name} must be {parameter.bounds_text}, got {value}")
    return value


def _boolean(parameter: Parameter, value: Any) -> bool:
    if not isinstance(value, (bool, np.bool_)):
        raise TypeError(f"{parameter.name} must be True or False, got {value!r}")
    return bool(value)


def _choice(parameter: Parameter, value: Any) -> str:
    if not isinstance(value, str) or value not in parameter.choices:
        raise ValueError(f"{parameter.name} must be {parameter.bounds_text}; got {value!r}")
    return value


def _tone(name: str, value: Any) -> float:
    if not _is_real(value):
        raise TypeError(f"{name} must hold real numbers, got {value!r}")
    number = as_float(value)
    if not (0.0 <= number <= 255.0):
        raise ValueError(f"{name} must lie on the 0-255 tone scale, got {value!r}")
    return number


def _is_sequence(value: Any) -> bool:
    """Whether ``value`` is a sequence of values (a 0-d array, a string or a number is not,
    nor a set or a mapping: their order is not the caller's)."""
    if isinstance(value, (str, bytes, set, frozenset, Mapping)):
        return False
    try:
        len(value)
    except TypeError:  # numbers, 0-d arrays
        return False
    return True


def scalar(value: Any) -> Any:
    """The number a 0-d array holds; any other value as it is."""
    if isinstance(value, np.ndarray) and value.ndim == 0:
        return value[()]
    return value


def _tone_ranges(parameter: Parameter, value: Any) -> tuple[float, ...]:
    value = scalar(value)
    if _is_integer(value):
        if not parameter.low <= value <= parameter.high:
            raise ValueError(
                f"tone_ranges as a count must be {parameter.bounds_text}, got {value}"
            )
        return equal_tone_ranges(int(value))
    if not _is_sequence(value):
        raise TypeError(
            f"tone_ranges must be a count of ranges or a sequence of limits, got {value!r}"
        )
    limits = tuple(_tone("tone_ranges", v) for v in value)
    if len(limits) < 2:
        raise ValueError("tone_ranges needs at least two limits (one range)")
    if any(b <= a for a, b in zip(limits, limits[1:])):
        raise ValueError(f"tone_ranges must be strictly increasing, got {list(limits)}")
    return limits


def _tones(value: Any, limits: tuple[float, ...]) -> tuple[tuple[float, float], ...]:
    if value is None:
        return tuple(zip(limits[:-1], limits[1:]))
    if not _is_sequence(value):
        raise TypeError(f"tones must be a sequence of (T_inf, T_sup) pairs, got {value!r}")
    if len(value) != len(limits) - 1:
        raise ValueError(
            f"tones needs one (T_inf, T_sup) pair per tone range: "
            f"{len(limits) - 1} range(s), got {len(value)} pair(s)"
        )
    pairs = []
    for pair in value:
        if not _is_sequence(pair) or len(pair) != 2:
            raise ValueError(f"tones must be (T_inf, T_sup) pairs, got {pair!r}")
        low, high = _tone("tones", pair[0]), _tone("tones", pair[1])
        if high < low:
            raise ValueError(f"tones pair must have T_inf <= T_sup, got {list(pair)}")
        pairs.append((low, high))
    return tuple(pairs)


def _unvalidated_tones(parameter: Parameter, value: Any) -> Any:
    return value  # checked against the tone ranges in make_parameters


_VALIDATORS = {
    "float": _float,
    "int": _integer,
    "seed": _integer,
    "bool": _boolean,
    "choice": _choice,
    "tone_ranges": _tone_ranges,
    "tones": _unvalidated_tones,
}
assert set(_VALIDATORS) == set(KINDS)
