"""Fixtures of the viewer tests: a viewer, the widget as napari opens it, shown errors."""

from __future__ import annotations

import pytest


@pytest.fixture
def viewer(make_napari_viewer):
    return make_napari_viewer()


@pytest.fixture
def widget(viewer):
    """The widget as napari opens it from the manifest (Plugins menu)."""
    _, widget = viewer.window.add_plugin_dock_widget("napari-labyrinth", "Labyrinthine tiling")
    return widget


@pytest.fixture
def shown_errors(monkeypatch):
    messages = []
    import napari_labyrinth._qt.menus as menus_module
    import napari_labyrinth._qt.widget as widget_module

    for module in (widget_module, menus_module):
        monkeypatch.setattr(module, "show_error", messages.append)
    return messages
