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
  4 passes let the walls grow from the contours into a maze.
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
    variance_threshold=0.04,
    variance_action="push_in_range",
    condition_order="variance_first",
    passes=4,
)

PRESETS = MappingProxyType(
    {
        "labyrinth": MappingProxyType(_LABYRINTH),
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
