"""Named parameter sets.

``"paper"`` is the literal reading of Sparavigna & Montrucchio's printed text:
t = 12 % (Eq. 2), V = 50 % (Eq. 4) with R2 = sqrt(V/N)/M as printed, three
about-equal tone ranges from a low non-zero tone to 255 with T = L (Eq. 3).
Read literally, it smooths edges rather than drawing a labyrinth (see
``docs/algorithm.md``).
"""

from __future__ import annotations

from types import MappingProxyType
from typing import Any

from .parameters import PARAMETER_NAMES

PRESETS = MappingProxyType(
    {
        "paper": MappingProxyType(
            {
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
        ),
    }
)

DEFAULT_PRESET = "paper"

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
