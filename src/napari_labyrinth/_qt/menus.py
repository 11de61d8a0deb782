"""The Layers ▸ Filter commands: the one widget of a viewer, and runs with its settings.

Every command goes through :func:`show_widget`, which brings up the widget
already docked in the viewer (opened from the Plugins menu or from here) and
opens it only when there is none, so a viewer never holds two copies and a
run from the menu uses the preset, passes and seed the user set.
"""

from __future__ import annotations

from napari.layers import Image
from napari.plugins import menu_item_template
from napari.utils.notifications import show_error
from napari.viewer import Viewer
from qtpy.QtWidgets import QDockWidget

from .widget import LabyrinthWidget

#: Name of the plugin and of its widget in the manifest (napari.yaml).
PLUGIN_NAME = "napari-labyrinth"
WIDGET_NAME = "Labyrinthine tiling"
#: The manifest's display name of the plugin.
PLUGIN_DISPLAY_NAME = "Labyrinthine tiling"
#: The name napari's Plugins menu gives the widget's dock, and looks the dock up by to toggle
#: it: a dock opened here under this name is the one the Plugins menu shows and hides.
DOCK_NAME = menu_item_template.format(PLUGIN_DISPLAY_NAME, WIDGET_NAME)


def show_widget(viewer: Viewer) -> LabyrinthWidget:
    """The viewer's widget, brought to the front; docked first if the viewer has none.

    Parameters
    ----------
    viewer : napari.Viewer
        The viewer, or the proxy of it napari hands a plugin's command: a proxy is
        another object than the viewer the docked widget holds, so the widget is found
        among the docks of the viewer's window, never by comparing viewers.

    Returns
    -------
    LabyrinthWidget
    """
    widget = docked_widget(viewer)
    if widget is None:
        widget = LabyrinthWidget(viewer)
        viewer.window.add_dock_widget(widget, name=DOCK_NAME)
    dock = widget.parent()
    while dock is not None and not isinstance(dock, QDockWidget):
        dock = dock.parent()
    widget.show()
    if dock is not None:
        dock.show()
        dock.raise_()
    return widget


def docked_widget(viewer: Viewer) -> LabyrinthWidget | None:
    """The widget docked in the viewer's window, whatever opened it; None if there is none."""
    for docked in _docked_widgets(viewer.window):
        if isinstance(docked, QDockWidget):
            docked = docked.widget()
        if isinstance(docked, LabyrinthWidget):
            return docked
    return None


def _docked_widgets(window) -> list:
    """What the window's docks hold: the widgets, or (napari 0.5) the docks themselves."""
    if hasattr(window, "dock_widgets"):  # the public mapping: name -> the widget in the dock
        return list(window.dock_widgets.values())
    # napari 0.5 has only the private mapping, name -> dock: read on the window itself, as
    # the proxy of it napari hands a plugin warns on private names
    window = getattr(window, "__wrapped__", window)
    return list(window._dock_widgets.values())


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
