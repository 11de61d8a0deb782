"""What a run does when the dock, the viewer or the input goes away; progress; replacing."""

from __future__ import annotations

import threading

import pytest

pytest.importorskip("napari")
pytest.importorskip("pytestqt")

from napari_labyrinth.plan import METADATA_KEY

from .helpers import RUN_TIMEOUT_MS, noise, run


def _no_rendering_thread():
    return not any(t.name.startswith("napari-labyrinth") for t in threading.enumerate())


def _start_long_run(viewer, widget):
    source = viewer.add_image(noise((12, 256, 256)), name="movie")
    widget.fields["passes"].value = 4
    worker = widget.run(start=False)
    assert worker is not None
    return source, worker


def test_closing_the_dock_cancels_the_run_and_adds_nothing(qtbot, viewer, widget):
    _, worker = _start_long_run(viewer, widget)

    def close_the_dock(_):
        if not widget._closed:
            viewer.window.remove_dock_widget(widget)  # as its close button does

    worker.yielded.connect(close_the_dock)
    layers_before = len(viewer.layers)
    with qtbot.waitSignal(worker.finished, timeout=RUN_TIMEOUT_MS):
        worker.start()
    assert widget._closed
    qtbot.waitUntil(_no_rendering_thread, timeout=RUN_TIMEOUT_MS)
    qtbot.wait(50)
    assert len(viewer.layers) == layers_before


def test_removing_the_input_cancels_the_run(qtbot, viewer, widget):
    source, worker = _start_long_run(viewer, widget)
    worker.yielded.connect(lambda _: source in viewer.layers and viewer.layers.remove(source))
    worker.start()
    qtbot.waitUntil(lambda: widget.worker is None, timeout=RUN_TIMEOUT_MS)
    qtbot.waitUntil(_no_rendering_thread, timeout=RUN_TIMEOUT_MS)
    assert len(viewer.layers) == 0
    assert "input layer was removed" in widget.status.value


def test_the_widget_shows_the_progress_of_a_run(qtbot, viewer, widget):
    _, worker = _start_long_run(viewer, widget)
    seen = []
    worker.yielded.connect(
        lambda _: seen.append(
            (
                widget.progress_bar.isVisible() or not widget.isVisible(),
                widget.progress_bar.maximum(),
            )
        )
    )
    worker.start()
    qtbot.waitUntil(lambda: widget.worker is None, timeout=RUN_TIMEOUT_MS)
    assert seen and all(maximum == worker.pbar.total for _, maximum in seen)
    assert not widget.progress_bar.isVisible()


def test_a_run_of_the_same_input_and_mode_replaces_the_previous_result(qtbot, viewer, widget):
    viewer.add_image(noise((32, 32)), name="cell")
    viewer.add_image(noise((32, 32), seed=1), name="other")
    widget.image_layer.value = viewer.layers["cell"]
    run(qtbot, widget)
    first = viewer.layers["cell · labyrinth"]
    position = viewer.layers.index(first)
    viewer.layers.move(position, 0)  # the user put it elsewhere
    widget.seed.value = 3
    run(qtbot, widget)
    results = [layer for layer in viewer.layers if layer.name.startswith("cell · labyrinth")]
    assert len(results) == 1 and results[0] is not first
    assert viewer.layers.index(results[0]) == 0  # in the place of the one it replaced
    assert results[0].metadata[METADATA_KEY]["seed"] == 3
    widget.replace.value = False
    run(qtbot, widget)
    assert sum(layer.name.startswith("cell · labyrinth") for layer in viewer.layers) == 2


def test_the_sweep_value_of_the_plane_on_screen_is_shown(qtbot, viewer, widget):
    viewer.add_image(noise((32, 32)), name="cell")
    widget.mode.value = "sweep"
    widget.sweep_values.value = "0.03, 0.04, 0.05"
    run(qtbot, widget)
    result = viewer.layers["cell · sweep V"]
    assert viewer.layers.selection.active is result  # a new result is the active layer
    overlay = widget.sweep_label.overlay
    assert overlay.visible and overlay.text == "V = 0.05"
    viewer.dims.set_current_step(0, 0)
    assert overlay.text == "V = 0.03"
    viewer.layers.selection.active = viewer.layers["cell"]
    assert not overlay.visible


def test_the_metrics_of_a_stack_clear_when_the_mode_or_the_input_changes(qtbot, viewer, widget):
    viewer.add_image(noise((64, 64)), name="cell")
    viewer.add_image(noise((64, 64), seed=2), name="other")
    widget.image_layer.value = viewer.layers["cell"]
    widget.mode.value = "stack"
    widget.fields["passes"].value = 2
    run(qtbot, widget)
    assert widget.metrics_table.columnCount() == 2 and widget.metrics_plot.rows
    viewer.dims.set_current_step(0, 1)  # the pass slider: the same plane of the input
    assert widget.metrics_table.columnCount() == 2
    widget.mode.value = "single"
    assert widget.metrics_table.columnCount() == 0 and not widget.metrics_plot.rows
    widget.mode.value = "stack"
    run(qtbot, widget)
    widget.image_layer.value = viewer.layers["other"]
    assert widget.metrics_table.columnCount() == 0


def test_closing_the_viewer_cancels_the_run(qtbot, make_napari_viewer):
    viewer = make_napari_viewer(show=True)
    _, widget = viewer.window.add_plugin_dock_widget("napari-labyrinth", "Labyrinthine tiling")
    _, worker = _start_long_run(viewer, widget)
    closed = []

    def close_the_viewer(_):
        if not closed:
            closed.append(True)
            viewer.close()

    worker.yielded.connect(close_the_viewer)
    with qtbot.waitSignal(worker.finished, timeout=RUN_TIMEOUT_MS):
        worker.start()
    assert widget._closed
    qtbot.waitUntil(_no_rendering_thread, timeout=RUN_TIMEOUT_MS)
