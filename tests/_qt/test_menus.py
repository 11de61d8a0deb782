"""The Layers > Filter commands and the samples, in a viewer."""

from __future__ import annotations

import pytest

pytest.importorskip("napari")
pytest.importorskip("pytestqt")

from napari_labyrinth._qt.menus import render_selected_layer, stack_selected_layer
from napari_labyrinth._qt.widget import LabyrinthWidget

from .helpers import RUN_TIMEOUT_MS, noise


def _widgets_in(viewer):
    return viewer.window._qt_window.findChildren(LabyrinthWidget)


def test_menu_command_renders_the_selected_layer(qtbot, viewer):
    from napari._app_model import get_app_model

    menu = get_app_model().menus.get_menu("napari/layers/filter")
    commands = {item.command.id for item in menu if hasattr(item, "command")}
    assert {
        "napari-labyrinth.show_widget",
        "napari-labyrinth.render_selected_layer",
        "napari-labyrinth.stack_selected_layer",
    } <= commands

    layer = viewer.add_image(noise((32, 32)), name="cell")
    viewer.layers.selection.active = layer
    render_selected_layer(viewer)
    widget = viewer.window.dock_widgets["Labyrinthine tiling (napari-labyrinth)"]
    qtbot.waitUntil(lambda: widget.worker is None, timeout=RUN_TIMEOUT_MS)
    assert viewer.layers[-1].name == "cell · labyrinth"


@pytest.mark.parametrize("command", ["show_widget", "render_selected_layer"])
def test_the_filter_menu_uses_the_open_widget_and_its_settings(qtbot, viewer, widget, command):
    from napari._app_model import get_app_model

    layer = viewer.add_image(noise((32, 32)), name="cell")
    viewer.layers.selection.active = layer
    widget.preset.value = "paper"
    widget.fields["passes"].value = 2
    widget.seed.value = 7
    get_app_model().commands.execute_command(f"napari-labyrinth.{command}").result()
    assert _widgets_in(viewer) == [widget]  # never a second dock
    qtbot.waitUntil(lambda: widget.worker is None, timeout=RUN_TIMEOUT_MS)
    if command == "render_selected_layer":
        record = viewer.layers[-1].metadata["napari_labyrinth"]
        assert (record["preset"], record["parameters"]["passes"], record["seed"]) == (
            "paper",
            2,
            7,
        )


def test_the_filter_menu_opens_one_widget_when_none_is_open(qtbot, viewer):
    layer = viewer.add_image(noise((32, 32)), name="cell")
    viewer.layers.selection.active = layer
    stack_selected_layer(viewer)
    stack_selected_layer(viewer)
    (widget,) = _widgets_in(viewer)
    qtbot.waitUntil(lambda: widget.worker is None, timeout=RUN_TIMEOUT_MS)


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
