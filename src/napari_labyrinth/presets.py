"""Transitional alias of :mod:`napari_labyrinth.core.presets` (removed once every caller moved)."""

from .core.presets import *  # noqa: F403
from .core.presets import DEFAULT_PRESET, PRESETS, preset_values  # noqa: F401
