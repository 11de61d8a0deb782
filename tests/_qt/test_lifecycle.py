"""What a run does when the dock, the viewer or the input goes away; progress; replacing."""

from __future__ import annotations

import threading

import numpy as np
import pytest

pytest.importorskip("napari")
pytest.importorskip("pytestqt")

from napari_labyrinth.widget.layer_kwargs import METADATA_KEY

from .helpers import RUN_TIMEOUT_MS, noise, reproduce, run


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


@pytest.mark.parametrize("proxied", [False, True], ids=["layer", "napari's proxy of it"])
def test_removing_the_input_cancels_the_run(qtbot, viewer, widget, proxied):
    from napari.utils._proxies import PublicOnlyProxy

    source, worker = _start_long_run(viewer, widget)
    if proxied:  # the event names the layer through the proxy napari hands a plugin
        widget._input = PublicOnlyProxy(widget._input)
    worker.yielded.connect(lambda _: source in viewer.layers and viewer.layers.remove(source))
    worker.start()
    qtbot.waitUntil(lambda: widget.worker is None, timeout=RUN_TIMEOUT_MS)
    qtbot.waitUntil(_no_rendering_thread, timeout=RUN_TIMEOUT_MS)
    assert len(viewer.layers) == 0
    assert "input layer was removed" in widget.status.value


@pytest.mark.parametrize("leave", ["close the dock", "remove the input"])
def test_leaving_after_the_rendering_but_before_the_result_is_shown_adds_nothing(
    qtbot, viewer, widget, leave
):
    """The result is shown in a later turn of the event loop than the worker's end: the
    run is still on until then, and going away in between still adds nothing."""
    source = viewer.add_image(noise((64, 64)), name="cell")
    worker = widget.run(start=False)

    def go(*_):
        if leave == "close the dock":
            viewer.window.remove_dock_widget(widget)
        else:
            viewer.layers.remove(source)

    worker.finished.connect(go)  # runs after the widget's own handler, in the same turn
    with qtbot.waitSignal(worker.finished, timeout=RUN_TIMEOUT_MS):
        worker.start()
    qtbot.waitUntil(lambda: widget.worker is None, timeout=RUN_TIMEOUT_MS)
    qtbot.wait(50)
    assert [layer.name for layer in viewer.layers] == (
        [] if leave == "remove the input" else ["cell"]
    )


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
    assert seen and all(maximum == 12 * 4 + 1 for _, maximum in seen)  # planes x passes + 1
    assert not widget.progress_bar.isVisible()


def test_a_run_of_the_same_input_and_mode_replaces_the_previous_result(qtbot, viewer, widget):
    viewer.add_image(noise((32, 32)), name="cell")
    viewer.add_image(noise((32, 32), seed=1), name="other")
    widget.image_layer.value = viewer.layers["cell"]
    widget.fields["noise_gate"].value = 0.0  # white noise is its own noise: the gate off
    run(qtbot, widget)
    first = viewer.layers["cell · labyrinth"]
    position = viewer.layers.index(first)
    viewer.layers.move(position, 0)  # the user put it elsewhere
    before = np.array(first.data)
    widget.seed.value = 3
    run(qtbot, widget)
    results = [layer for layer in viewer.layers if layer.name.startswith("cell · labyrinth")]
    assert results == [first]  # the same layer, updated in place
    assert viewer.layers.index(first) == 0  # where the user put it
    assert first.metadata[METADATA_KEY]["seed"] == 3
    assert not np.array_equal(first.data, before)
    np.testing.assert_array_equal(first.data, reproduce(first, viewer.layers["cell"].data))
    assert viewer.layers.selection.active is first
    widget.replace.value = False
    run(qtbot, widget)
    assert sum(layer.name.startswith("cell · labyrinth") for layer in viewer.layers) == 2


def test_a_result_that_cannot_hold_the_new_data_is_replaced_by_a_new_layer(qtbot, viewer, widget):
    """A stack has one more axis than the result of a single run: no update in place."""
    from napari_labyrinth._qt.worker import add_result_layer

    viewer.add_image(noise((32, 32)), name="cell")
    widget.mode.value = "stack"
    widget.fields["passes"].value = 2
    run(qtbot, widget)
    stack = viewer.layers["cell · stack"]
    viewer.layers.move(viewer.layers.index(stack), 0)
    widget.mode.value = "single"
    plan = widget.plan()
    outcome = _rendered_outcome(plan)
    layer = add_result_layer(viewer, plan, outcome, previous=stack)
    assert layer is not stack and stack not in viewer.layers
    assert viewer.layers.index(layer) == 0 and layer.ndim == 2


def test_an_update_in_place_takes_the_name_contrast_and_transforms_of_the_new_result(
    qtbot, viewer, widget
):
    from napari_labyrinth._qt.worker import add_result_layer

    source = viewer.add_image(noise((32, 32), dtype=np.uint16) * 10, name="cell")
    run(qtbot, widget)
    result = viewer.layers["cell · labyrinth"]
    source.contrast_limits = (100, 2000)
    source.scale = (2.0, 3.0)
    source.name = "renamed"
    widget.image_layer.value = source
    plan = widget.plan()
    layer = add_result_layer(viewer, plan, _rendered_outcome(plan), previous=result)
    assert layer is result and len(viewer.layers) == 2
    assert layer.name == "renamed · labyrinth"
    assert tuple(layer.contrast_limits) == (100, 2000)
    np.testing.assert_array_equal(layer.scale, (2.0, 3.0))
    assert layer.metadata[METADATA_KEY]["source_layer"] == "renamed"


def _rendered_outcome(plan):
    """The outcome of ``plan``, rendered here (no worker)."""
    from napari_labyrinth.widget.run import render

    steps = render(plan)
    while True:
        try:
            next(steps)
        except StopIteration as stop:
            return stop.value


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
    from napari_labyrinth._qt.collector import holds

    held_before = holds()
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
    qtbot.wait(50)
    assert holds() == held_before  # full collections given back


def test_the_progress_bar_changes_a_few_times_a_second_not_at_the_end(widget, monkeypatch):
    import napari_labyrinth._qt.widget as widget_module

    clock = [100.0]
    monkeypatch.setattr(widget_module, "_clock", lambda: clock[0])
    widget.progress_bar.setRange(0, 10)
    widget.progress_bar.setValue(0)
    widget._progress_shown = clock[0]
    widget._on_progress(1)
    assert widget.progress_bar.value() == 0  # too soon after the last change
    clock[0] += widget_module.PROGRESS_INTERVAL
    widget._on_progress(2)
    assert widget.progress_bar.value() == 2
    clock[0] += widget_module.PROGRESS_INTERVAL
    widget._on_progress(10)
    # the last step: the bar is hidden as the result is shown; a repaint for it would
    # stall the event loop in the same turn
    assert widget.progress_bar.value() == 2


def test_no_full_garbage_collection_starts_by_itself_while_a_run_is_on(qtbot, viewer, widget):
    import gc

    from napari_labyrinth._qt.collector import HELD_THRESHOLD

    threshold = gc.get_threshold()
    _, worker = _start_long_run(viewer, widget)
    seen = []
    worker.yielded.connect(lambda _: seen.append(gc.get_threshold()[2]))
    with qtbot.waitSignal(worker.finished, timeout=RUN_TIMEOUT_MS):
        worker.start()
    assert seen and set(seen) == {HELD_THRESHOLD}
    assert gc.get_threshold()[2] == HELD_THRESHOLD  # the result is still to be shown
    qtbot.waitUntil(lambda: widget.worker is None, timeout=RUN_TIMEOUT_MS)
    assert widget.last_result.visible
    qtbot.waitUntil(lambda: gc.get_threshold() == threshold, timeout=1000)  # after its draw


def test_a_cancelled_run_gives_the_collections_back(qtbot, viewer, widget):
    import gc

    threshold = gc.get_threshold()
    _, worker = _start_long_run(viewer, widget)
    worker.yielded.connect(lambda _: widget.cancel())
    worker.start()
    qtbot.waitUntil(lambda: widget.worker is None, timeout=RUN_TIMEOUT_MS)
    assert "Cancelled" in widget.status.value
    qtbot.waitUntil(lambda: gc.get_threshold() == threshold, timeout=1000)
