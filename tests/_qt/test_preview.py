"""Live preview in a real viewer: one layer, updated in place, newest render only."""

from __future__ import annotations

import numpy as np
import pytest

pytest.importorskip("napari")
pytest.importorskip("pytestqt")

from napari_labyrinth import labyrinth
from napari_labyrinth._qt.worker import main_window

from .helpers import RUN_TIMEOUT_MS, noise


def _settled(widget):
    preview = widget.preview
    return preview.layer is not None and not preview.busy


def _previews(viewer):
    return [layer for layer in viewer.layers if layer.name.endswith("· preview")]


def test_preview_updates_one_layer_in_place_and_follows_the_slider(qtbot, viewer, widget):
    data = noise((3, 64, 64))
    viewer.add_image(data, name="movie", contrast_limits=(0, 255))
    viewer.dims.set_current_step(0, 0)
    widget.fields["passes"].value = 2
    widget.preview_toggle.value = True
    qtbot.waitUntil(lambda: _settled(widget), timeout=RUN_TIMEOUT_MS)
    layer = widget.preview.layer
    assert layer.name == "movie · preview"
    np.testing.assert_array_equal(layer.data[0], labyrinth(data[0], passes=2))

    widget.fields["variance_threshold"].value = 0.06
    generation = widget.preview.generation
    qtbot.waitUntil(
        lambda: widget.preview.shown_generation > generation and _settled(widget),
        timeout=RUN_TIMEOUT_MS,
    )
    assert widget.preview.layer is layer and _previews(viewer) == [layer]  # in place
    want = labyrinth(data[0], passes=2, variance_threshold=0.06)
    np.testing.assert_array_equal(layer.data[0], want)

    viewer.dims.set_current_step(0, 2)  # the preview follows the plane on screen
    qtbot.waitUntil(lambda: layer.translate[0] == 2 and _settled(widget), timeout=RUN_TIMEOUT_MS)
    want = labyrinth(data[2], passes=2, variance_threshold=0.06, plane_offset=2)
    np.testing.assert_array_equal(layer.data[0], want)
    assert len(viewer.layers) == 2

    widget.preview_toggle.value = False
    assert widget.preview.layer is None and _previews(viewer) == []


def test_a_new_preview_layer_is_shown_a_turn_after_its_insertion(qtbot, viewer, widget):
    """Inserted hidden, the window not repainted in that turn; shown, and the window
    repainted, in the next."""
    viewer.add_image(noise((32, 32)), name="cell")
    window = main_window(widget)
    assert window is viewer.window._qt_window
    inserted = []

    def on_inserted(event):
        inserted.append((event.value.visible, window.updatesEnabled()))

    viewer.layers.events.inserted.connect(on_inserted)
    widget.preview_toggle.value = True
    qtbot.waitUntil(lambda: _settled(widget), timeout=RUN_TIMEOUT_MS)
    viewer.layers.events.inserted.disconnect(on_inserted)
    assert inserted == [(False, False)]
    assert widget.preview.layer.visible and window.updatesEnabled()
    assert widget.preview.shown_generation == widget.preview.generation


def test_a_preview_turned_off_before_its_layer_is_shown_leaves_nothing(
    qtbot, viewer, widget, monkeypatch
):
    import napari_labyrinth._qt.preview as preview_module

    monkeypatch.setattr(preview_module, "NEXT_TURN_MS", 300)  # time to turn it off between
    viewer.add_image(noise((32, 32)), name="cell")
    window = main_window(widget)
    widget.preview_toggle.value = True
    qtbot.waitUntil(lambda: widget.preview.layer is not None, timeout=RUN_TIMEOUT_MS)
    assert not widget.preview.layer.visible and not window.updatesEnabled()
    assert widget.preview.busy
    widget.preview_toggle.value = False
    assert _previews(viewer) == [] and not widget.preview.busy
    qtbot.wait(400)  # the turn that would have shown it
    assert window.updatesEnabled() and _previews(viewer) == [] and widget.preview.layer is None


def test_a_stale_render_never_replaces_a_newer_one(qtbot, viewer, widget):
    data = noise((256, 256))
    viewer.add_image(data, name="picture", contrast_limits=(0, 255))
    widget.preview_toggle.value = True
    qtbot.waitUntil(lambda: _settled(widget), timeout=RUN_TIMEOUT_MS)
    for value in (0.02, 0.03, 0.04, 0.05, 0.07):  # renders started one after the other
        widget.fields["variance_threshold"].value = value
        widget.preview._render()
    qtbot.waitUntil(lambda: _settled(widget), timeout=RUN_TIMEOUT_MS)
    qtbot.wait(200)
    assert widget.preview.shown_generation == widget.preview.generation
    want = labyrinth(data, variance_threshold=0.07)
    np.testing.assert_array_equal(widget.preview.layer.data, want)


def test_run_still_renders_the_full_result_beside_the_preview(qtbot, viewer, widget):
    data = noise((2, 32, 32))
    viewer.add_image(data, name="movie", contrast_limits=(0, 255))
    widget.preview_toggle.value = True
    qtbot.waitUntil(lambda: _settled(widget), timeout=RUN_TIMEOUT_MS)
    widget.image_layer.value = viewer.layers["movie"]
    worker = widget.run()
    assert worker is not None
    qtbot.waitUntil(lambda: widget.worker is None, timeout=RUN_TIMEOUT_MS)
    result = viewer.layers["movie · labyrinth"]
    np.testing.assert_array_equal(result.data, labyrinth(data))


def test_no_full_garbage_collection_starts_by_itself_while_a_preview_renders(
    qtbot, viewer, widget
):
    import gc

    from napari_labyrinth._qt.collector import HELD_THRESHOLD

    threshold = gc.get_threshold()
    viewer.add_image(noise((256, 256)), name="plane", contrast_limits=(0, 255))
    held = []
    original_render = widget.preview._render

    def render_and_watch():
        original_render()
        worker = widget.preview._worker
        if worker is not None:
            worker.yielded.connect(lambda _: held.append(gc.get_threshold()[2]))

    widget.preview._render = render_and_watch
    widget.preview._timer.timeout.disconnect()
    widget.preview._timer.timeout.connect(render_and_watch)
    widget.preview_toggle.value = True
    qtbot.waitUntil(lambda: _settled(widget), timeout=RUN_TIMEOUT_MS)
    assert held and set(held) == {HELD_THRESHOLD}
    qtbot.waitUntil(lambda: gc.get_threshold() == threshold, timeout=1000)  # a turn after


def test_full_collections_stay_held_until_a_turn_after_the_new_layer_is_shown(
    qtbot, viewer, widget, monkeypatch
):
    """The worker's hold ends as its result arrives; the layer's first draw comes later."""
    import napari_labyrinth._qt.preview as preview_module
    from napari_labyrinth._qt.collector import holds

    monkeypatch.setattr(preview_module, "NEXT_TURN_MS", 300)
    viewer.add_image(noise((32, 32)), name="cell")
    qtbot.wait(50)
    held_before = holds()
    widget.preview_toggle.value = True
    qtbot.waitUntil(lambda: widget.preview.layer is not None, timeout=RUN_TIMEOUT_MS)
    # the worker's hold has ended
    qtbot.waitUntil(lambda: holds() == held_before + 1, timeout=250)
    assert not widget.preview.layer.visible and widget.preview._worker is None
    qtbot.waitUntil(lambda: widget.preview.layer.visible, timeout=1000)
    assert holds() == held_before + 1  # until the turn after the first draw
    qtbot.waitUntil(lambda: holds() == held_before, timeout=1000)
