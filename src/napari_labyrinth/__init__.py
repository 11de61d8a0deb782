"""Labyrinthine tiling of images (Sparavigna & Montrucchio): library, CLI and napari plugin."""

from importlib.metadata import PackageNotFoundError, version

from .api import (
    Progress,
    Result,
    labyrinth,
    labyrinth_stack,
    labyrinth_steps,
    labyrinth_sweep,
    resolve_parameters,
)
from .core.parameters import DIAGNOSTIC_FIELDS, PARAMETERS, LabyrinthParameters
from .core.presets import PRESETS
from .window import Window, find_window

try:
    __version__ = version("napari-labyrinth")
except PackageNotFoundError:  # running from a source tree that is not installed
    __version__ = "0+unknown"

__all__ = [
    "DIAGNOSTIC_FIELDS",
    "PARAMETERS",
    "PRESETS",
    "LabyrinthParameters",
    "Progress",
    "Result",
    "Window",
    "__version__",
    "find_window",
    "labyrinth",
    "labyrinth_stack",
    "labyrinth_steps",
    "labyrinth_sweep",
    "resolve_parameters",
]
