"""Fixtures of the viewer tests: a viewer, the widget as napari opens it, a slowed API."""

from __future__ import annotations

import time

import pytest

#: Seconds each plane and pass takes under the ``slow_api`` fixture.
SLOW_STEP = 0.02


@pytest.fixture
def viewer(make_napari_viewer):
    return make_napari_viewer()


@pytest.fixture
def widget(viewer):
    """The widget as napari opens it from the manifest (Plugins menu)."""
    _, widget = viewer.window.add_plugin_dock_widget("napari-labyrinth", "Labyrinthine tiling")
    return widget


@pytest.fixture
def slow_api(monkeypatch):
    """Make every plane and pass of the API take at least ``SLOW_STEP`` seconds.

    Runs of small test images finish in milliseconds, before a test could
    watch or cancel them; slowed down, they leave time to do both.
    """

    def slowed(function):
        def wrapper(image, *, progress=None, **options):
            if progress is None:  # lazy (dask) calls take no progress callback
                return function(image, **options)

            def slow_progress(done, total):
                time.sleep(SLOW_STEP)
                progress(done, total)

            return function(image, progress=slow_progress, **options)

        return wrapper

    from napari_labyrinth import api

    for name in ("labyrinth", "labyrinth_stack", "labyrinth_sweep"):
        monkeypatch.setattr(api, name, slowed(getattr(api, name)))


@pytest.fixture
def shown_errors(monkeypatch):
    messages = []
    import napari_labyrinth._qt.menus as menus_module
    import napari_labyrinth._qt.widget as widget_module

    for module in (widget_module, menus_module):
        monkeypatch.setattr(module, "show_error", messages.append)
    return messages
