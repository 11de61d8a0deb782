"""Named parameter sets.

- ``"labyrinth"`` (the default) draws the labyrinthine tiling that follows the
  contours of the image. It departs from the printed text in two places,
  chosen by the study in ``docs/study/``: where Eq. 4 holds the pixel is
  *pushed* away from its local mean instead of left alone (the paper's "a
  condition ... able to strongly enhance the local variance"), and Eq. 4 is
  tested before Eq. 2. R2 = sqrt(V/N)/M is kept as printed; on that scale
  the labyrinth appears for V between about 0.04 and 0.12 (below, it floods
  dark and smooth regions; above, it fades), hence V = 0.08. The walls grow
  from the contours pass after pass; 4 passes connect them into a maze.
- ``"edges"``: the same reading at V = 0.10 over 8 passes: the walls stay on
  the contours and thicken with passes, the edge-detector look of Fig. 4.
- ``"paper"`` is the literal reading of Sparavigna & Montrucchio's printed
  text: t = 12 % (Eq. 2), V = 50 % (Eq. 4) with R2 = sqrt(V/N)/M, three
  about-equal tone ranges from a low non-zero tone to 255 with T = L (Eq. 3).
  Read literally, it smooths edges rather than drawing a labyrinth.

See ``docs/algorithm.md`` for the options and ``docs/study/README.md`` for
the measurements behind the choices.
"""

from __future__ import annotations

from types import MappingProxyType
from typing import Any

from .parameters import PARAMETER_NAMES

_PAPER = {
    "mean_threshold": 0.12,
    "variance_threshold": 0.50,
    "tone_ranges": 3,
    "tones": None,
    "max_tries": 10,
    "passes": 1,
    "border": "inside",
    "variance_ratio": "sqrt(V/N)/M",
    "variance_action": "leave",
    "condition_order": "mean_first",
    "on_exhausted": "keep",
    "include_centre": False,
    "scan": "raster",
}
_LABYRINTH = dict(
    _PAPER,
    variance_threshold=0.08,
    variance_action="push",
    condition_order="variance_first",
    passes=4,
)

PRESETS = MappingProxyType(
    {
        "labyrinth": MappingProxyType(_LABYRINTH),
        "edges": MappingProxyType(dict(_LABYRINTH, variance_threshold=0.10, passes=8)),
        "paper": MappingProxyType(_PAPER),
    }
)

#: The preset used when none is named: the one that draws the labyrinth.
DEFAULT_PRESET = "labyrinth"

assert all(set(p) == set(PARAMETER_NAMES) for p in PRESETS.values())


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
