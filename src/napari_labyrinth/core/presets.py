"""Named parameter sets.

- ``"labyrinth"`` (the default) draws a labyrinthine tiling that follows the
  contours of the image. It departs from the printed text in two places,
  chosen by the study in ``docs/study/``: where Eq. 4 holds the pixel is
  *pushed* away from its local mean, with a draw in its own tone range
  (Eq. 3), instead of being left alone (the paper's "a condition ... able to
  strongly enhance the local variance"), and Eq. 4 is tested before Eq. 2.
  R2 = sqrt(V/N)/M is kept as printed. On that scale the walls follow the
  contours best for V from about 0.03 to 0.05 on every test image (below,
  they flood smooth and dark regions; above, they fade), hence V = 0.04;
  4 passes let the walls grow from the contours into a maze. Tones below
  the paper's L_inf^1 (a low non-zero tone, Sec. 2) get a tone range of
  their own, ``[0, L_inf^1]``, instead of joining the first: a pixel of a
  near-black region, where noise makes the ratios of Eq. 2 and 4 huge, is
  then pushed or redrawn within the black range rather than up to the
  first range's tones, so dark backgrounds keep a faint grain instead of
  bright dots and the walls stay on the edges (``docs/study/``: edge
  enhancement 0.68 -> 0.78 on a dark-field image, 0.70 -> 0.76 on a 16-bit
  fluorescence plane, unchanged or higher on the other images).
  Not in the paper either: the noise gate (``noise_gate = 2``) leaves
  alone the pixels whose neighbours vary no more than twice the image's
  own noise, so that a black field stays clean (75-96 % of a black
  field's pixels changed without it, at most 1.5 % with it, and the
  labyrinth's cover on the study's images is unchanged or higher:
  ``docs/study/noise-gate.md``).
- ``"paper"`` is the literal reading of Sparavigna & Montrucchio's printed
  text: t = 12 % (Eq. 2), V = 50 % (Eq. 4) with R2 = sqrt(V/N)/M, three
  about-equal tone ranges from a low non-zero tone to 255 with T = L (Eq. 3).
  Read literally, it smooths edges rather than drawing a labyrinth.

No "edges" preset: the paper's Fig. 4 turns into an edge map with passes;
no reading we measured does (the study's edge scores stay flat with passes),
so no preset claims that look.

See ``docs/algorithm.md`` for the options and ``docs/study/README.md`` for
the measurements behind the choices.
"""

from __future__ import annotations

from types import MappingProxyType
from typing import Any

from .parameters import (
    AUTO,
    DEFAULT_SEED,
    PARAMETER_NAMES,
    PARAMETERS,
    SEED,
    SWEEPABLE,
    LabyrinthParameters,
    equal_tone_ranges,
    is_auto,
    make_parameters,
)

#: The literal reading: every parameter at its paper value.
_PAPER = {name: parameter.paper for name, parameter in PARAMETERS.items()}
#: The labyrinth preset's tone ranges: the paper's three from L_inf^1 to 255,
#: and below them a black range of their own.
BLACK_RANGE_TONES = (0.0, *equal_tone_ranges(3))

#: The labyrinth preset's noise gate k: pixels whose neighbourhood varies no more than
#: twice the image's noise are left alone (``docs/study/noise-gate.md``).
NOISE_GATE = 2.0

_LABYRINTH = dict(
    _PAPER,
    tone_ranges=BLACK_RANGE_TONES,
    variance_threshold=0.04,
    variance_action="push_in_range",
    condition_order="variance_first",
    passes=4,
    noise_gate=NOISE_GATE,
)

PRESETS = MappingProxyType(
    {
        "labyrinth": MappingProxyType(_LABYRINTH),
        "paper": MappingProxyType(_PAPER),
    }
)

#: The preset used when none is named: the one that draws the labyrinth.
DEFAULT_PRESET = "labyrinth"

#: Default sweep of the variance threshold around a preset's value: the paper's
#: Fig. 3 shows V = 47 %, 50 % and 53 %.
FIG3_FACTORS = (0.94, 1.0, 1.06)


def preset_values(name: str) -> dict[str, Any]:
    """The parameters of preset ``name`` as a new dict.

    Raises
    ------
    ValueError
        If ``name`` is not a known preset.
    """
    try:
        return dict(PRESETS[name])
    except (KeyError, TypeError):
        raise ValueError(
            f"preset must be one of {', '.join(map(repr, PRESETS))}; got {name!r}"
        ) from None


def resolve_parameters(preset: str = DEFAULT_PRESET, **overrides: Any) -> LabyrinthParameters:
    """Parameters of ``preset`` with every non-None override applied, validated.

    Setting ``tone_ranges`` without ``tones`` resets the tones to T = L.
    A call whose arguments are plain values (see :func:`_call_key`) is
    resolved once: the same call again returns the same (immutable) set.

    Raises
    ------
    TypeError, ValueError
        Naming the parameter, for an unknown name or a bad value.
    """
    key = _call_key(preset, overrides)
    if key is not None:
        resolved = _RESOLVED.get(key)
        if resolved is None:
            resolved = _resolve(preset, overrides)
            if len(_RESOLVED) >= _RESOLVED_CALLS:
                _RESOLVED.clear()
            _RESOLVED[key] = resolved
        return resolved
    return _resolve(preset, overrides)


#: Distinct calls whose parameters ``resolve_parameters`` keeps (then it starts afresh).
_RESOLVED_CALLS = 256

#: The parameters of the calls resolved so far, by :func:`_call_key`.
_RESOLVED: dict[tuple, LabyrinthParameters] = {}

#: Types of the values a call may be remembered by: compared by value, immutable.
_PLAIN_TYPES = (str, int, float, bool, type(None))


def _call_key(preset: Any, overrides: dict[str, Any]) -> tuple | None:
    """A key that equals another only for a call that resolves to the same parameters;
    None if a value is not of ``_PLAIN_TYPES`` (or a tuple of them).

    Each value is keyed with its type: ``1``, ``1.0`` and ``True`` are equal in
    Python but not as parameters (``passes=True`` is refused).
    """
    key = [_plain(preset)]
    for name, value in overrides.items():
        key.append((name, _plain(value)))
        if key[-1][1] is None:
            return None
    return None if key[0] is None else tuple(key)


def _plain(value: Any) -> tuple | None:
    """``(type, value)`` of a value of ``_PLAIN_TYPES`` or a tuple of such values (its
    items keyed alike), else None."""
    kind = type(value)
    if kind in _PLAIN_TYPES:
        return kind, value
    if kind is tuple:
        items = tuple(_plain(item) for item in value)
        return None if None in items else (kind, items)
    return None


def _resolve(preset: Any, overrides: dict[str, Any]) -> LabyrinthParameters:
    """:func:`resolve_parameters` without remembering the call."""
    values = preset_values(preset)
    given = {name: value for name, value in overrides.items() if value is not None}
    unknown = set(given) - set(PARAMETER_NAMES)
    if unknown:
        raise TypeError(f"unknown parameter(s): {', '.join(sorted(unknown))}")
    if "tone_ranges" in given and "tones" not in given:
        values["tones"] = None
    values.update(given)
    return make_parameters(**values)


def resolve_sweep(
    preset: str,
    overrides: dict[str, Any],
    seed: Any,
    parameter: str,
    values: Any = None,
) -> list[tuple[LabyrinthParameters, int]]:
    """The (parameters, seed) of every rendering of a sweep of ``parameter``, validated.

    ``seed`` is the seed given beside the sweep, or None (then ``DEFAULT_SEED``);
    a seed given to a sweep of seeds is refused, as any swept parameter given
    beside its sweep. ``values=None`` sweeps ``variance_threshold`` over the preset's V times
    ``FIG3_FACTORS`` (the paper's Fig. 3); every other parameter needs values.

    Raises
    ------
    TypeError, ValueError
        Naming the parameter or the value at fault.
    """
    if not isinstance(parameter, str) or parameter not in SWEEPABLE:
        raise ValueError(f"parameter must be one of {', '.join(SWEEPABLE)}; got {parameter!r}")
    given = seed if parameter == "seed" else overrides.get(parameter)
    if given is not None:
        raise TypeError(f"{parameter} is swept; do not also pass it as a keyword")
    if values is None and parameter == "variance_threshold":
        centre = resolve_parameters(preset, **overrides).variance_threshold
        values = [round(centre * factor, 6) for factor in FIG3_FACTORS]
    if isinstance(values, (str, bytes)) or not hasattr(values, "__len__") or len(values) == 0:
        raise ValueError(f"values must be a non-empty sequence, got {values!r}")
    if any(is_auto(value) for value in values):
        raise ValueError(
            f"{parameter} values of a sweep are numbers, not {AUTO!r} (which chooses one "
            f"value from the image): sweep numbers, or render once with {parameter}={AUTO!r}"
        )
    if parameter == "seed":
        parameters = resolve_parameters(preset, **overrides)
        return [(parameters, SEED.validate(value)) for value in values]
    seed = SEED.validate(DEFAULT_SEED if seed is None else seed)
    return [
        (resolve_parameters(preset, **dict(overrides, **{parameter: value})), seed)
        for value in values
    ]
