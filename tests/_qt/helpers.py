"""Helpers of the viewer tests: test images, a run through the widget, its reproduction, and
the window's menus as a user opens them (napari 0.5 to 0.9; PyQt5, PyQt6, PySide6)."""

from __future__ import annotations

import inspect
import json
import re

import numpy as np

import napari_labyrinth
from napari_labyrinth.widget.layer_kwargs import METADATA_KEY

#: A guard against a hung run, not a time limit: the first run of a session compiles numba's
#: kernels (the metrics' take ~20 s of CPU, 40 s on a loaded 2-core machine).
RUN_TIMEOUT_MS = 180_000


def noise(shape, dtype=np.uint8, seed=0):
    rng = np.random.default_rng(seed)
    if np.dtype(dtype).kind == "f":
        return rng.random(shape).astype(dtype)
    return rng.integers(0, 256, shape).astype(dtype)


def run(qtbot, widget):
    """Start a run and wait until its worker has finished."""
    worker = widget.run()
    assert worker is not None, widget.status.value
    qtbot.waitUntil(lambda: widget.worker is None, timeout=RUN_TIMEOUT_MS)
    return worker


def reproduce(layer, source):
    """Render again through the API from what the result layer's metadata records."""
    record = json.loads(json.dumps(layer.metadata[METADATA_KEY]))  # survives JSON
    if record["source_index"] is not None:
        source = source[tuple(record["source_index"])]
    result = getattr(napari_labyrinth, record["function"])(source, **record["arguments"])
    return np.asarray(result)


def result_data(layer):
    """The rendered data of a result layer, without the size-1 axes that place a plane."""
    record = layer.metadata[METADATA_KEY]
    data = np.asarray(layer.data)
    if record["source_index"] is not None:
        extra = 0 if record["mode"] == "single" else 1
        data = data.reshape(data.shape[:extra] + data.shape[extra + len(record["source_index"]) :])
    return data


#: A title napari gives a plugin's item in some menus: the command's, then the plugin's name.
_TITLE_WITH_PLUGIN = re.compile(r"^(?P<title>.*) \([^()]*\)$")


def menu_action(viewer, path: tuple[str, ...]):
    """The action of the viewer window's menu bar at ``path``, as a user reaches it.

    Parameters
    ----------
    viewer : napari.Viewer
    path : tuple of str
        The titles of the menus down to the item, as shown (``&`` mnemonics are ignored),
        e.g. ``("Layers", "Filter", "Labyrinthine tiling of the selected image")``. napari
        follows a plugin command's title with the plugin's name in parentheses in some menus
        and versions; the title alone names such an item too.

    Returns
    -------
    QAction
        The item; each menu on the way was told it is about to show, as when the user opens
        it, which makes napari update its items' enabled state (the manifest's ``when``).

    Raises
    ------
    LookupError
        No item, or more than one, has a title of ``path``.
    """
    menu = viewer.window._qt_window.menuBar()
    for depth, title in enumerate(path):
        action = _action_titled(menu, title, path[: depth + 1])
        if depth == len(path) - 1:
            return action
        menu = action.menu()
        if menu is None:
            raise LookupError(f"{' > '.join(path[: depth + 1])} is not a menu")
        menu.aboutToShow.emit()
    raise LookupError("an empty menu path")


def trigger_menu_item(viewer, path: tuple[str, ...]) -> None:
    """Click the item at ``path`` of the viewer's menu bar (see :func:`menu_action`)."""
    action = menu_action(viewer, path)
    assert action.isEnabled(), f"{' > '.join(path)} is disabled"
    action.trigger()


def _action_titled(menu, title: str, path: tuple[str, ...]):
    shown = [(action, _without_mnemonics(action.text())) for action in menu.actions()]
    found = [action for action, text in shown if text == title]
    if not found:
        found = [
            action
            for action, text in shown
            if (match := _TITLE_WITH_PLUGIN.match(text)) and match["title"] == title
        ]
    if len(found) != 1:
        offered = [text for _, text in shown if text]
        raise LookupError(f"{len(found)} items {' > '.join(path)!r} among {offered}")
    return found[0]


def _without_mnemonics(text: str) -> str:
    return text.replace("&&", "\0").replace("&", "").replace("\0", "&")


def labyrinth_docks(viewer) -> list:
    """The docks of the viewer's window that hold the widget, whatever opened them."""
    from qtpy.QtWidgets import QDockWidget

    from napari_labyrinth._qt.widget import LabyrinthWidget

    docks = viewer.window._qt_window.findChildren(QDockWidget)
    return [dock for dock in docks if isinstance(dock.widget(), LabyrinthWidget)]


def docked_widget(viewer):
    """The one widget docked in the viewer's window (fails if there are more, or none)."""
    (dock,) = labyrinth_docks(viewer)
    return dock.widget()


def grid_squares(viewer) -> dict:
    """The (row, column) of the grid where each visible layer is drawn, by layer name.

    As napari lays the grid out: up to 0.6.1 each layer is translated by whole scenes (read
    here in a grid of at most 2 x 2), from 0.6.2 on the canvas draws the layers of each square
    of ``iter_viewboxes`` in a viewbox of its own (hidden layers take no square from 0.9 on).
    """
    grid = viewer.canvas.grid if hasattr(viewer, "canvas") else viewer.grid
    layers = list(viewer.layers)
    if not grid.enabled:
        return {layer.name: (0, 0) for layer in layers if layer.visible}
    if not hasattr(grid, "iter_viewboxes"):
        return {
            layer.name: tuple(int(shift > 0) for shift in layer._translate_grid[-2:])
            for layer in layers
            if layer.visible
        }
    counted = (
        len(layers) if "nlayers" in inspect.signature(grid.iter_viewboxes).parameters else layers
    )
    return {
        layers[index].name: tuple(square)
        for square, indices in grid.iter_viewboxes(counted)
        for index in indices
        if layers[index].visible
    }
