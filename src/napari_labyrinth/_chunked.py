"""Transitional alias of :mod:`napari_labyrinth.lazy` (removed once every caller moved)."""

from .lazy import *  # noqa: F403
from .lazy import ComputeError, computing, default_tone_limits, is_lazy, run_blocks  # noqa: F401
