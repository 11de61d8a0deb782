"""The Layers > Filter commands and the samples, in a viewer."""

from __future__ import annotations

import pytest

pytest.importorskip("napari")
pytest.importorskip("pytestqt")

from napari_labyrinth._qt.menus import render_selected_layer

from .helpers import RUN_TIMEOUT_MS, noise


def test_menu_command_renders_the_selected_layer(qtbot, viewer):
    from napari._app_model import get_app_model

    menu = get_app_model().menus.get_menu("napari/layers/filter")
    commands = {item.command.id for item in menu if hasattr(item, "command")}
    assert {
        "napari-labyrinth.open_widget",
        "napari-labyrinth.render_selected_layer",
        "napari-labyrinth.stack_selected_layer",
    } <= commands

    layer = viewer.add_image(noise((32, 32)), name="cell")
    viewer.layers.selection.active = layer
    render_selected_layer(viewer)
    widget = viewer.window.dock_widgets["Labyrinthine tiling (napari-labyrinth)"]
    qtbot.waitUntil(lambda: widget.worker is None, timeout=RUN_TIMEOUT_MS)
    assert viewer.layers[-1].name.startswith("cell · labyrinth")


@pytest.mark.parametrize(
    "key, shape, rgb",
    [
        ("nematic_schlieren", (512, 512), False),
        ("cholesteric_fingerprint", (512, 512), False),
        ("cell", (660, 550), False),
        ("immunohistochemistry", (512, 512, 3), True),
    ],
)
def test_samples_open_in_the_viewer(viewer, key, shape, rgb):
    layers = viewer.open_sample("napari-labyrinth", key)
    (layer,) = layers
    assert layer.data.shape == shape
    assert layer.rgb == rgb
