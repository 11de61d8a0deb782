"""A multiscale layer in a viewer on screen: the preview follows the level the zoom shows, Run
adds a multiscale result whose full level is the API's result, bit for bit."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

pytest.importorskip("napari")
pytest.importorskip("pytestqt")

from napari_labyrinth import api, labyrinth
from napari_labyrinth._qt.preview import viewer_camera
from napari_labyrinth.io._pyramid import halved
from napari_labyrinth.widget.layer_kwargs import METADATA_KEY

from .helpers import RUN_TIMEOUT_MS, docked_widget, noise, run, trigger_menu_item
from .test_menus import PLUGINS_ITEM

LIMITS = (0.0, 65535.0)
SCALE, TRANSLATE = (0.5, 0.5), (10.0, -20.0)


def pyramid(full: np.ndarray, count: int = 3) -> list[np.ndarray]:
    levels = [full]
    for _ in range(count - 1):
        levels.append(halved(levels[-1], (-2, -1)))
    return levels


@pytest.fixture
def shown_viewer(make_napari_viewer):
    """A viewer on screen: napari picks a multiscale layer's level when its canvas draws."""
    return make_napari_viewer(show=True)


def open_widget(viewer):
    trigger_menu_item(viewer, PLUGINS_ITEM)
    return docked_widget(viewer)


def zoom_to_level(qtbot, viewer, layer, level: int) -> None:
    """Zoom until napari shows ``level`` (one screen pixel: ``4 ** level / 2`` data pixels)."""
    viewer_camera(viewer).zoom = 2.0 / 4**level / SCALE[0]
    qtbot.waitUntil(lambda: layer.data_level == level, timeout=5000)


def add_placed_pyramid(viewer, seed: int, **kwargs):
    """A 3-level 256² multiscale layer 'cam', scaled and translated; its levels and layer."""
    levels = pyramid(noise((256, 256), np.uint16, seed=seed))
    layer = viewer.add_image(
        levels,
        name="cam",
        multiscale=True,
        contrast_limits=LIMITS,
        scale=SCALE,
        translate=TRANSLATE,
        **kwargs,
    )
    return levels, layer


def test_the_preview_renders_the_level_the_zoom_shows(qtbot, shown_viewer):
    viewer = shown_viewer
    levels, cam = add_placed_pyramid(viewer, seed=1)
    widget = open_widget(viewer)
    widget.image_layer.value = cam
    widget.fields["passes"].value = 1
    zoom_to_level(qtbot, viewer, cam, 2)
    widget.preview_toggle.value = True
    qtbot.waitUntil(
        lambda: widget.preview.layer is not None and not widget.preview.busy,
        timeout=RUN_TIMEOUT_MS,
    )
    preview = widget.preview.layer
    assert not preview.multiscale and preview.data.shape == (64, 64)
    np.testing.assert_array_equal(preview.data, labyrinth(levels[2], passes=1, tone_limits=LIMITS))
    np.testing.assert_array_equal(preview.scale, np.multiply(SCALE, 4))
    np.testing.assert_array_equal(preview.translate, TRANSLATE)
    assert preview.metadata[METADATA_KEY]["source_level"] == 2

    zoom_to_level(qtbot, viewer, cam, 0)  # zoomed in: the full level
    qtbot.waitUntil(
        lambda: (
            (layer := widget.preview.layer) is not None
            and layer.data.shape == (256, 256)
            and not widget.preview.busy
        ),
        timeout=RUN_TIMEOUT_MS,
    )
    preview = widget.preview.layer
    np.testing.assert_array_equal(preview.data, labyrinth(levels[0], passes=1, tone_limits=LIMITS))
    np.testing.assert_array_equal(preview.scale, SCALE)
    np.testing.assert_array_equal(preview.translate, TRANSLATE)
    widget.preview_toggle.value = False


def test_run_adds_a_multiscale_result_whose_full_level_is_the_api_s(qtbot, shown_viewer):
    viewer = shown_viewer
    levels, cam = add_placed_pyramid(
        viewer,
        seed=2,
        colormap="magma",
        metadata={"acquired": "today"},
    )
    widget = open_widget(viewer)
    widget.image_layer.value = cam
    widget.fields["passes"].value = 2
    zoom_to_level(qtbot, viewer, cam, 2)  # a run renders the full level whatever is shown
    run(qtbot, widget)
    result = viewer.layers["cam · labyrinth"]
    assert result.multiscale and widget.last_result is result
    full = api.labyrinth(levels[0], passes=2, tone_limits=LIMITS)
    np.testing.assert_array_equal(np.asarray(result.data[0]), full)  # bit for bit
    assert [tuple(level.shape) for level in result.data] == [(256, 256), (128, 128), (64, 64)]
    np.testing.assert_array_equal(np.asarray(result.data[1]), halved(full, (0, 1)))
    np.testing.assert_array_equal(result.scale, SCALE)
    np.testing.assert_array_equal(result.translate, TRANSLATE)
    assert result.colormap.name == "magma"
    record = result.metadata[METADATA_KEY]
    assert record["source_level"] == 0 and record["levels"] == 3
    assert record["band_by_band"] is True  # its levels are on disk
    first_store = store_of(result)
    assert sorted(path.name for path in first_store.iterdir()) == ["0", "1", "2"]
    assert widget.status.value.startswith("Added cam · labyrinth")
    qtbot.waitUntil(lambda: result.data_level == 2, timeout=5000)  # napari zooms through it

    widget.fields["passes"].value = 1  # a second run updates the first's layer in place
    run(qtbot, widget)
    assert [layer.name for layer in viewer.layers] == ["cam", "cam · labyrinth"]
    assert viewer.layers["cam · labyrinth"] is result and result.multiscale
    full = api.labyrinth(levels[0], passes=1, tone_limits=LIMITS)
    np.testing.assert_array_equal(np.asarray(result.data[0]), full)
    np.testing.assert_array_equal(np.asarray(result.data[2]), pyramid(full)[2])
    second_store = store_of(result)
    assert not first_store.exists() and second_store.exists()  # the first one's removed
    viewer.layers.remove(result)
    assert not second_store.exists()


def store_of(layer) -> Path:
    """The directory of the store on disk a multiscale result's levels are in."""
    return Path(str(layer.data[0].store.root)).parent


def test_a_stack_of_passes_of_a_multiscale_stack_shows_its_last_pass(qtbot, shown_viewer):
    viewer = shown_viewer
    levels = pyramid(noise((3, 64, 64), np.uint16, seed=3))  # z, y, x; z not downsampled
    cam = viewer.add_image(levels, name="cam", multiscale=True, contrast_limits=LIMITS)
    viewer.dims.set_current_step(0, 1)
    widget = open_widget(viewer)
    widget.image_layer.value = cam
    widget.mode.value = "stack"
    widget.fields["passes"].value = 2
    run(qtbot, widget)
    result = viewer.layers["cam · stack"]
    assert result.multiscale
    expected = api.labyrinth_stack(levels[0], passes=2, tone_limits=LIMITS)
    np.testing.assert_array_equal(np.asarray(result.data[0]), expected)
    assert [tuple(level.shape) for level in result.data] == [
        (3, 3, 64 >> k, 64 >> k) for k in range(3)
    ]
    assert viewer.dims.current_step[0] == 2  # the last pass
    assert len(result.metadata[METADATA_KEY]["metrics"]) == 2  # measured on the plane on screen


def test_the_preview_zoomed_in_renders_the_part_on_screen_and_follows_a_pan(qtbot, shown_viewer):
    viewer = shown_viewer
    levels = pyramid(noise((2048, 2048), np.uint16, seed=4), count=2)
    cam = viewer.add_image(
        levels, name="cam", multiscale=True, contrast_limits=LIMITS, scale=SCALE,
        translate=TRANSLATE,
    )  # fmt: skip
    widget = open_widget(viewer)
    widget.image_layer.value = cam
    widget.fields["passes"].value = 1
    viewer_camera(viewer).zoom = 4.0 / SCALE[0]  # 4 screen pixels a data pixel: level 0
    viewer_camera(viewer).center = (TRANSLATE[0] + 300 * SCALE[0], TRANSLATE[1] + 400 * SCALE[1])
    qtbot.waitUntil(lambda: cam.data_level == 0, timeout=5000)
    widget.preview_toggle.value = True

    def shown_part():
        qtbot.waitUntil(
            lambda: widget.preview.layer is not None and not widget.preview.busy,
            timeout=RUN_TIMEOUT_MS,
        )
        preview = widget.preview.layer
        (top, bottom), (left, right) = preview.metadata[METADATA_KEY]["source_region"]
        part = levels[0][top:bottom, left:right]
        np.testing.assert_array_equal(preview.data, labyrinth(part, passes=1, tone_limits=LIMITS))
        np.testing.assert_array_equal(
            preview.translate, np.add(TRANSLATE, np.multiply(SCALE, (top, left)))
        )
        return (top, bottom), (left, right)

    (top, bottom), (left, right) = shown_part()
    assert (bottom - top) * (right - left) < 2048 * 2048 / 4  # a part, not the level
    assert top <= 300 < bottom and left <= 400 < right  # around the centre of the view
    viewer_camera(viewer).center = (TRANSLATE[0] + 1700 * SCALE[0], TRANSLATE[1] + 1500 * SCALE[1])
    qtbot.waitUntil(
        lambda: widget.preview.layer.metadata[METADATA_KEY]["source_region"][0][0] > bottom,
        timeout=RUN_TIMEOUT_MS,
    )
    (top, bottom), (left, right) = shown_part()
    assert top <= 1700 < bottom and left <= 1500 < right
    widget.preview_toggle.value = False
