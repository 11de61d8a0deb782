"""The Layers ▸ Filter commands: render the selected image layer with the widget's settings."""

from __future__ import annotations

from napari.layers import Image
from napari.utils.notifications import show_error
from napari.viewer import Viewer

#: Name of the plugin and of its widget in the manifest (napari.yaml).
PLUGIN_NAME = "napari-labyrinth"
WIDGET_NAME = "Labyrinthine tiling"


def _run_on_selected_layer(viewer: Viewer, mode: str) -> None:
    layer = viewer.layers.selection.active
    if not isinstance(layer, Image):
        show_error("Labyrinthine tiling: select an image layer first.")
        return
    _, widget = viewer.window.add_plugin_dock_widget(PLUGIN_NAME, WIDGET_NAME)
    widget.reset_choices()
    widget.image_layer.value = layer
    widget.mode.value = mode
    widget.run()


def render_selected_layer(viewer: Viewer) -> None:
    """Render the selected image layer with the widget's current settings.

    Opens the widget (if needed) so that the progress, Cancel and the
    parameters stay at hand.
    """
    _run_on_selected_layer(viewer, "single")


def stack_selected_layer(viewer: Viewer) -> None:
    """Render every pass of the selected image layer into one stack (Fig. 4)."""
    _run_on_selected_layer(viewer, "stack")
