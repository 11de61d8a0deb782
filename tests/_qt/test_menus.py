"""The Plugins, Layers > Filter and File > Open Sample items, clicked in a viewer's menu bar."""

from __future__ import annotations

import pytest

pytest.importorskip("napari")
pytest.importorskip("pytestqt")
npe2 = pytest.importorskip("npe2")

from napari.layers import Image

from napari_labyrinth.widget.layer_kwargs import METADATA_KEY

from .helpers import (
    RUN_TIMEOUT_MS,
    docked_widget,
    labyrinth_docks,
    menu_action,
    noise,
    trigger_menu_item,
)

PLUGIN = "napari-labyrinth"
MANIFEST = npe2.PluginManifest.from_distribution(PLUGIN)
TITLES = {command.id.split(".")[-1]: command.title for command in MANIFEST.contributions.commands}

PLUGINS_ITEM = ("Plugins", MANIFEST.contributions.widgets[0].display_name)
FILTER = ("Layers", "Filter")
OPEN_ITEM = (*FILTER, TITLES["show_widget"])
RENDER_ITEM = (*FILTER, TITLES["render_selected_layer"])
STACK_ITEM = (*FILTER, TITLES["stack_selected_layer"])
MODES = {RENDER_ITEM: "single", STACK_ITEM: "stack"}


def _images(viewer):
    """Two image layers, the second selected; returns the first."""
    cell = viewer.add_image(noise((32, 32), seed=0), name="cell")
    viewer.add_image(noise((32, 32), seed=1), name="other")
    return cell


def _wait_for_result(qtbot, viewer, widget):
    """The provenance record of the one result layer, once the widget's run has ended."""

    def results():
        return [layer for layer in viewer.layers if METADATA_KEY in layer.metadata]

    qtbot.waitUntil(lambda: widget.worker is None and bool(results()), timeout=RUN_TIMEOUT_MS)
    (result,) = results()
    return result.metadata[METADATA_KEY]


def test_the_filter_menu_offers_the_render_items_for_a_selected_image(viewer):
    assert menu_action(viewer, OPEN_ITEM).isEnabled()
    viewer.add_points([[1, 1]])
    assert not menu_action(viewer, RENDER_ITEM).isEnabled()
    assert not menu_action(viewer, STACK_ITEM).isEnabled()
    viewer.layers.selection.active = viewer.add_image(noise((8, 8)))
    assert menu_action(viewer, RENDER_ITEM).isEnabled()
    assert menu_action(viewer, STACK_ITEM).isEnabled()


@pytest.mark.parametrize("item", [RENDER_ITEM, STACK_ITEM], ids=["render", "stack"])
def test_a_filter_item_renders_with_the_widget_opened_from_the_plugins_menu(qtbot, viewer, item):
    cell = _images(viewer)
    trigger_menu_item(viewer, PLUGINS_ITEM)
    widget = docked_widget(viewer)
    widget.preset.value = "paper"
    widget.fields["passes"].value = 2
    widget.seed.value = 7
    viewer.layers.selection.active = cell

    trigger_menu_item(viewer, item)

    assert [dock.widget() for dock in labyrinth_docks(viewer)] == [widget]
    record = _wait_for_result(qtbot, viewer, widget)
    assert (record["mode"], record["input"]["name"]) == (MODES[item], "cell")
    assert (record["preset"], record["parameters"]["passes"], record["seed"]) == ("paper", 2, 7)


@pytest.fixture
def shown_viewer(make_napari_viewer):
    """A viewer on screen: napari's Plugins item shows or hides a dock by its visibility."""
    return make_napari_viewer(show=True)


def test_the_open_item_brings_back_the_hidden_widget_of_the_plugins_menu(qtbot, shown_viewer):
    viewer = shown_viewer
    trigger_menu_item(viewer, PLUGINS_ITEM)
    widget = docked_widget(viewer)
    (dock,) = labyrinth_docks(viewer)
    qtbot.waitUntil(dock.isVisible)  # the main window lays a new dock out in a turn of its own
    trigger_menu_item(viewer, PLUGINS_ITEM)  # napari's Plugins item hides an open dock
    assert not dock.isVisible()

    trigger_menu_item(viewer, OPEN_ITEM)

    assert labyrinth_docks(viewer) == [dock]
    assert dock.isVisible() and widget.isVisible()


def test_a_filter_item_with_no_widget_open_opens_the_one_of_the_plugins_menu(qtbot, shown_viewer):
    viewer = shown_viewer
    viewer.layers.selection.active = _images(viewer)
    trigger_menu_item(viewer, STACK_ITEM)
    widget = docked_widget(viewer)
    record = _wait_for_result(qtbot, viewer, widget)
    assert (record["mode"], record["input"]["name"]) == ("stack", "cell")

    trigger_menu_item(viewer, OPEN_ITEM)
    assert docked_widget(viewer) is widget
    (dock,) = labyrinth_docks(viewer)
    assert dock.isVisible()
    trigger_menu_item(viewer, PLUGINS_ITEM)  # the Plugins item knows it as its own: hides it
    assert labyrinth_docks(viewer) == [dock]
    assert not dock.isVisible()


@pytest.mark.parametrize(
    "key, name, shape, rgb",
    [
        ("nematic_schlieren", "nematic Schlieren", (512, 512), False),
        ("cholesteric_fingerprint", "cholesteric fingerprint", (512, 512), False),
        ("cell", "cell", (660, 550), False),
        ("immunohistochemistry", "immunohistochemistry", (512, 512, 3), True),
    ],
)
def test_each_sample_of_the_file_menu_opens_its_image(viewer, key, name, shape, rgb):
    (sample,) = [sample for sample in MANIFEST.contributions.sample_data if sample.key == key]

    trigger_menu_item(viewer, ("File", "Open Sample", MANIFEST.display_name, sample.display_name))

    (layer,) = viewer.layers
    assert isinstance(layer, Image)
    assert (layer.name, layer.data.shape, layer.rgb) == (name, shape, rgb)
