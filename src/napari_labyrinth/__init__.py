"""Labyrinthine tiling of images (Sparavigna & Montrucchio): library, CLI and napari plugin."""

from importlib.metadata import PackageNotFoundError, version

from .api import labyrinth, labyrinth_stack, labyrinth_sweep, resolve_parameters
from .parameters import DIAGNOSTIC_FIELDS, LabyrinthParameters
from .presets import PRESETS

try:
    __version__ = version("napari-labyrinth")
except PackageNotFoundError:  # running from a source tree that is not installed
    __version__ = "0+unknown"

__all__ = [
    "DIAGNOSTIC_FIELDS",
    "PRESETS",
    "LabyrinthParameters",
    "__version__",
    "labyrinth",
    "labyrinth_stack",
    "labyrinth_sweep",
    "resolve_parameters",
]
