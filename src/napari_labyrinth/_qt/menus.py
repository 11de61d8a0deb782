"""The Layers ▸ Filter commands: the one widget of a viewer, and runs with its settings.

Every command goes through :func:`show_widget`, which brings up the widget
already docked in the viewer (opened from the Plugins menu or from here) and
opens it only when there is none, so a viewer never holds two copies and a
run from the menu uses the preset, passes and seed the user set.
"""

from __future__ import annotations

from napari.layers import Image
from napari.utils.notifications import show_error
from napari.viewer import Viewer
from qtpy import sip

from .widget import LabyrinthWidget

#: Name of the plugin and of its widget in the manifest (napari.yaml).
PLUGIN_NAME = "napari-labyrinth"
WIDGET_NAME = "Labyrinthine tiling"


def show_widget(viewer: Viewer) -> LabyrinthWidget:
    """The viewer's widget, brought to the front; docked first if the viewer has none."""
    for widget in list(LabyrinthWidget.instances):
        if not sip.isdeleted(widget) and widget.viewer is viewer:
            dock = widget.parent()
            while dock is not None and not hasattr(dock, "raise_"):
                dock = dock.parent()
            widget.show()
            if dock is not None:
                dock.show()
                dock.raise_()
            return widget
    _, widget = viewer.window.add_plugin_dock_widget(PLUGIN_NAME, WIDGET_NAME)
    return widget


def _run_on_selected_layer(viewer: Viewer, mode: str) -> None:
    layer = viewer.layers.selection.active
    if not isinstance(layer, Image):
        show_error("Labyrinthine tiling: select an image layer first.")
        return
    widget = show_widget(viewer)
    widget.reset_choices()
    widget.image_layer.value = layer
    widget.mode.value = mode
    widget.run()


def open_widget(viewer: Viewer) -> None:
    """Show the widget (the one already docked, if any)."""
    show_widget(viewer)


def render_selected_layer(viewer: Viewer) -> None:
    """Render the selected image layer with the widget's current settings.

    Opens the widget (if needed) so that the progress, Cancel and the
    parameters stay at hand.
    """
    _run_on_selected_layer(viewer, "single")


def stack_selected_layer(viewer: Viewer) -> None:
    """Render every pass of the selected image layer into one stack (Fig. 4)."""
    _run_on_selected_layer(viewer, "stack")
