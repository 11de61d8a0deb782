"""Transitional alias of :mod:`napari_labyrinth.core.parameters` (removed once every caller moved)."""

from .core.codes import OPTION_CODES as _OPTION_CODES
from .core.parameters import *  # noqa: F403
from .core.parameters import PARAMETERS as _PARAMETERS

BORDERS, VARIANCE_RATIOS, VARIANCE_ACTIONS, CONDITION_ORDERS, ON_EXHAUSTED, SCANS = (
    tuple(_OPTION_CODES[name])
    for name in (
        "border",
        "variance_ratio",
        "variance_action",
        "condition_order",
        "on_exhausted",
        "scan",
    )
)
MAX_TRIES_LIMIT = _PARAMETERS["max_tries"].high
