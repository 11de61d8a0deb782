"""The algorithm's parameters: one validated, immutable set per rendering.

Every point where the paper leaves a choice open is a named option here, with
the literal reading of the printed text as the ``"paper"`` preset's value; see
``docs/algorithm.md`` for the mapping of each option to the paper's words.
"""

from __future__ import annotations

import dataclasses
import math
import numbers
from typing import Any

import numpy as np

#: Default lower limit L_inf^1 of the first tone range ("a low value different
#: from zero", Sec. 2); the last range ends at 255.
LOWEST_TONE = 10.0

#: Largest accepted ``max_tries``: bounds the time a pass can take.
MAX_TRIES_LIMIT = 10_000

BORDERS = ("inside", "mirror", "nearest", "wrap")
VARIANCE_RATIOS = ("sqrt(V/N)/M", "sqrt(V)/M")
VARIANCE_ACTIONS = ("leave", "push_in_range", "push_full_scale")
CONDITION_ORDERS = ("mean_first", "variance_first")
ON_EXHAUSTED = ("keep", "last_draw")
SCANS = ("raster", "serpentine", "checkerboard")

#: What a pass did with each pixel; the kernel counts them in this order.
DIAGNOSTIC_FIELDS = (
    "kept_by_mean",  # Eq. 2 held: g kept
    "left_by_variance",  # Eq. 4 held: g left as it is (no push succeeded)
    "pushed",  # Eq. 4 held: a draw further from M replaced g (the push readings)
    "redrawn",  # a draw of Eq. 3 satisfied Eq. 2 and replaced g
    "out_of_tries",  # max_tries draws, none satisfied Eq. 2
    "skipped",  # g not finite, or no finite neighbour
)


@dataclasses.dataclass(frozen=True)
class LabyrinthParameters:
    """A complete, validated set of parameters for one rendering.

    Attributes
    ----------
    mean_threshold : float
        t of Eq. 2: g is kept when ``|g - M| / M <= t``.
    variance_threshold : float
        V of Eq. 4: g is left as it is when the variance ratio exceeds V.
    tone_ranges : tuple of float
        Range limits ``L_inf^1 < L_sup^1 = L_inf^2 < ... < L_sup^n`` on the
        0-255 scale (n + 1 values for n ranges).
    tones : tuple of (float, float)
        ``(T_inf^i, T_sup^i)`` of Eq. 3 for each range.
    max_tries : int
        Draws of Eq. 3 before the pixel is given up.
    passes : int
        Passes over the image (the paper's Fig. 4 iterates the algorithm).
    border : {"inside", "mirror", "nearest", "wrap"}
        Which neighbours a border pixel has. ``"inside"``: only those inside
        the image, N is their number; the others complete the 8 neighbours
        as ``scipy.ndimage`` modes of the same names do.
    variance_ratio : {"sqrt(V/N)/M", "sqrt(V)/M"}
        The ratio R2 of Eq. 4: as printed, or with the standard deviation.
    variance_action : {"leave", "push_in_range", "push_full_scale"}
        What Eq. 4 does to a pixel where it holds. ``"leave"``: as printed,
        the substitution is not applied. The pushes read Eq. 4 as "a
        condition ... able to strongly enhance the local variance": tones are
        drawn on g's side of M until one lies further from M than g
        (relative to M), and it replaces g. ``"push_in_range"`` draws them in
        g's tone range (Eq. 3), ``"push_full_scale"`` between M and the end
        of the tone scale.
    condition_order : {"mean_first", "variance_first"}
        Which condition decides first: Eq. 2 (as printed: Eq. 4 only for
        pixels that fail Eq. 2) or Eq. 4 (it acts on every pixel where it
        holds, even those close to their mean).
    on_exhausted : {"keep", "last_draw"}
        What a pixel becomes when no draw satisfied Eq. 2.
    include_centre : bool
        Whether the pixel itself joins its M and V (Eq. 1 sums over the
        neighbours only).
    scan : {"raster", "serpentine", "checkerboard"}
        Order of the in-place scan from the top-left corner: every row left
        to right, or odd rows right to left, or (not the paper's order) the
        four checkerboard colours of (y mod 2, x mod 2) one after the other,
        each in raster order. No two pixels of a colour are neighbours, so
        a colour can be split among threads: one large plane then uses
        every core, with the same result for any number of threads.
    """

    mean_threshold: float
    variance_threshold: float
    tone_ranges: tuple[float, ...]
    tones: tuple[tuple[float, float], ...]
    max_tries: int
    passes: int
    border: str
    variance_ratio: str
    variance_action: str
    condition_order: str
    on_exhausted: str
    include_centre: bool
    scan: str

    def as_dict(self) -> dict[str, Any]:
        """Plain-Python dict (JSON-serialisable) of every parameter."""
        out = dataclasses.asdict(self)
        out["tone_ranges"] = list(self.tone_ranges)
        out["tones"] = [list(pair) for pair in self.tones]
        return out


#: Parameter names a preset or a caller may set.
PARAMETER_NAMES = tuple(field.name for field in dataclasses.fields(LabyrinthParameters))


def equal_tone_ranges(count: int) -> tuple[float, ...]:
    """Limits of ``count`` equal tone ranges from ``LOWEST_TONE`` to 255 (Sec. 2)."""
    return tuple(float(v) for v in np.linspace(LOWEST_TONE, 255.0, count + 1))


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
    tone_ranges = _tone_ranges(values["tone_ranges"])
    return LabyrinthParameters(
        mean_threshold=_non_negative_float("mean_threshold", values["mean_threshold"]),
        variance_threshold=_non_negative_float("variance_threshold", values["variance_threshold"]),
        tone_ranges=tone_ranges,
        tones=_tones(values.get("tones"), tone_ranges),
        max_tries=_integer("max_tries", values["max_tries"], 0, MAX_TRIES_LIMIT),
        passes=_integer("passes", values["passes"], 0, None),
        border=_choice("border", values["border"], BORDERS),
        variance_ratio=_choice("variance_ratio", values["variance_ratio"], VARIANCE_RATIOS),
        variance_action=_choice("variance_action", values["variance_action"], VARIANCE_ACTIONS),
        condition_order=_choice("condition_order", values["condition_order"], CONDITION_ORDERS),
        on_exhausted=_choice("on_exhausted", values["on_exhausted"], ON_EXHAUSTED),
        include_centre=_boolean("include_centre", values["include_centre"]),
        scan=_choice("scan", values["scan"], SCANS),
    )


def _is_real(value: Any) -> bool:
    return isinstance(value, numbers.Real) and not isinstance(value, (bool, np.bool_))


def _non_negative_float(name: str, value: Any) -> float:
    if not _is_real(value):
        raise TypeError(f"{name} must be a real number, got {value!r}")
    value = float(value)
    if not math.isfinite(value) or value < 0:
        raise ValueError(f"{name} must be finite and >= 0, got {value!r}")
    return value


def _integer(name: str, value: Any, low: int, high: int | None) -> int:
    if not isinstance(value, numbers.Integral) or isinstance(value, (bool, np.bool_)):
        raise TypeError(f"{name} must be an integer, got {value!r}")
    value = int(value)
    if value < low or (high is not None and value > high):
        bound = f">= {low}" if high is None else f"between {low} and {high}"
        raise ValueError(f"{name} must be {bound}, got {value}")
    return value


def _boolean(name: str, value: Any) -> bool:
    if not isinstance(value, (bool, np.bool_)):
        raise TypeError(f"{name} must be True or False, got {value!r}")
    return bool(value)


def _choice(name: str, value: Any, options: tuple[str, ...]) -> str:
    if value not in options:
        raise ValueError(f"{name} must be one of {', '.join(map(repr, options))}; got {value!r}")
    return value


def _tone(name: str, value: Any) -> float:
    if not _is_real(value):
        raise TypeError(f"{name} must hold real numbers, got {value!r}")
    value = float(value)
    if not (0.0 <= value <= 255.0):
        raise ValueError(f"{name} must lie on the 0-255 tone scale, got {value!r}")
    return value


def _tone_ranges(value: Any) -> tuple[float, ...]:
    if isinstance(value, numbers.Integral) and not isinstance(value, (bool, np.bool_)):
        if not 1 <= value <= 255:
            raise ValueError(f"tone_ranges as a count must be between 1 and 255, got {value}")
        return equal_tone_ranges(int(value))
    if isinstance(value, (str, bytes)) or not hasattr(value, "__len__"):
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
    if isinstance(value, (str, bytes)) or not hasattr(value, "__len__"):
        raise TypeError(f"tones must be a sequence of (T_inf, T_sup) pairs, got {value!r}")
    if len(value) != len(limits) - 1:
        raise ValueError(
            f"tones needs one (T_inf, T_sup) pair per tone range: "
            f"{len(limits) - 1} range(s), got {len(value)} pair(s)"
        )
    pairs = []
    for pair in value:
        if isinstance(pair, (str, bytes)) or not hasattr(pair, "__len__") or len(pair) != 2:
            raise ValueError(f"tones must be (T_inf, T_sup) pairs, got {pair!r}")
        low, high = _tone("tones", pair[0]), _tone("tones", pair[1])
        if high < low:
            raise ValueError(f"tones pair must have T_inf <= T_sup, got {list(pair)}")
        pairs.append((low, high))
    return tuple(pairs)
