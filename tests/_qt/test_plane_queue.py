"""A lazy layer's result in a real viewer: its planes render in the background, where the user
looks first, into a store on disk that goes with the layer."""

from __future__ import annotations

import time

import numpy as np
import pytest

pytest.importorskip("napari")
pytest.importorskip("pytestqt")
da = pytest.importorskip("dask.array")
pytest.importorskip("zarr")

import napari_labyrinth
from napari_labyrinth._qt.plane_queue import PlaneQueue

from .helpers import RUN_TIMEOUT_MS, noise

SHAPE = (6, 64, 64)


def slow_lazy(data: np.ndarray, seconds: float):
    """``data`` as a dask array of one chunk per plane, each plane taking ``seconds`` to load."""

    def load(block):
        time.sleep(seconds)
        return block

    return da.from_array(data, chunks=(1,) + data.shape[1:]).map_blocks(load, dtype=data.dtype)


def expected_planes(data, layer, mode):
    """Each plane rendered by the API on its own, with the run's arguments and its stream."""
    arguments = dict(layer.metadata["napari_labyrinth"]["arguments"])
    function = {"single": napari_labyrinth.labyrinth, "stack": napari_labyrinth.labyrinth_stack}
    return [
        function[mode](data[index], **arguments, plane_offset=index)
        for index in range(data.shape[0])
    ]


def start_background(qtbot, viewer, widget, data, seconds=0.3, mode="single", plane=3):
    """Run on a slow lazy layer from ``plane``; returns when the result layer is shown and its
    other planes render: the queue, the layer, and the planes rendered since, in order."""
    lazy = slow_lazy(data, seconds)
    viewer.add_image(lazy, name="lazy", contrast_limits=(0, 255))
    viewer.dims.set_current_step(0, plane)
    widget.mode.value = mode
    widget.fields["passes"].value = 2
    assert widget.run() is not None, widget.status.value
    qtbot.waitUntil(lambda: isinstance(widget.worker, PlaneQueue), timeout=RUN_TIMEOUT_MS)
    queue, rendered = widget.worker, []
    queue.worker.yielded.connect(rendered.append)
    return queue, widget.last_result, rendered


def shown(layer) -> np.ndarray:
    """What the layer shows where the viewer stands."""
    return np.asarray(layer._data_view)


@pytest.mark.parametrize("mode", ["single", "stack"])
def test_the_plane_on_screen_first_then_every_plane_as_the_api_renders_it(
    qtbot, viewer, widget, mode
):
    data = noise(SHAPE)
    queue, layer, _ = start_background(qtbot, viewer, widget, data, mode=mode)
    assert layer is not None and layer in viewer.layers
    assert queue.done == 1 and queue.background.order.is_done((3,))
    assert widget.cancel_button.enabled and not widget.progress_bar.isHidden()
    expected = expected_planes(data, layer, mode)
    axis = 0 if mode == "single" else 1
    assert shown(layer).any(), "the plane on screen shows at once"
    np.testing.assert_array_equal(np.take(np.asarray(layer.data), 3, axis=axis), expected[3])

    qtbot.waitUntil(lambda: widget.worker is None, timeout=RUN_TIMEOUT_MS)
    assert queue.done == queue.total == SHAPE[0]
    rendered = np.asarray(layer.data)
    for index in range(SHAPE[0]):
        np.testing.assert_array_equal(np.take(rendered, index, axis=axis), expected[index])
    assert "6 planes" in widget.status.value
    assert widget.run_button.enabled and widget.progress_bar.isHidden()


def test_a_move_of_the_slider_renders_the_new_plane_next_and_shows_it(qtbot, viewer, widget):
    data = noise(SHAPE)
    _, layer, rendered = start_background(qtbot, viewer, widget, data, seconds=0.4, plane=4)
    viewer.layers["lazy"].visible = False  # napari would load its plane 0 first, slowly
    viewer.dims.set_current_step(0, 0)  # 5 (being rendered) and 3 came first from 4: 0 is far
    assert not shown(layer).any(), "a plane not rendered yet is blank"
    assert "blank until it is rendered" in widget.status.value
    qtbot.waitUntil(lambda: shown(layer).any(), timeout=RUN_TIMEOUT_MS)
    assert (0,) in rendered[:2], f"the plane on screen was not rendered next: {rendered}"
    expected = expected_planes(data, layer, "single")
    np.testing.assert_array_equal(shown(layer), expected[0])  # refreshed as it arrived
    assert "blank" not in widget.status.value
    qtbot.waitUntil(lambda: widget.worker is None, timeout=RUN_TIMEOUT_MS)
    assert sorted(rendered) == [(0,), (1,), (2,), (3,), (5,)], "each plane rendered once"


def test_cancel_stops_the_background_and_keeps_the_planes_rendered(qtbot, viewer, widget):
    data = noise(SHAPE)
    queue, layer, rendered = start_background(qtbot, viewer, widget, data, seconds=0.5)
    qtbot.waitUntil(lambda: queue.done >= 2, timeout=RUN_TIMEOUT_MS)
    widget.cancel_button.native.click()
    qtbot.waitUntil(lambda: widget.worker is None, timeout=RUN_TIMEOUT_MS)
    done = queue.done
    assert done < queue.total
    assert widget.status.value.startswith(f"Stopped: {done} of 6 planes")
    time.sleep(1.0)
    assert queue.done == done and len(rendered) == done - 1, "nothing rendered after the cancel"
    assert layer in viewer.layers and queue.background.store.path.exists()
    viewer.layers.remove(layer)
    assert not queue.background.store.path.exists()


def test_removing_the_result_layer_stops_and_removes_its_store(qtbot, viewer, widget):
    queue, layer, _ = start_background(qtbot, viewer, widget, noise(SHAPE))
    path = queue.background.store.path
    assert path.exists()
    viewer.layers.remove(layer)
    assert not path.exists()
    qtbot.waitUntil(lambda: widget.worker is None, timeout=RUN_TIMEOUT_MS)
    assert queue.done < queue.total and not path.exists()
    assert widget.run_button.enabled


def test_closing_the_viewer_removes_the_store(qtbot, make_napari_viewer):
    viewer = make_napari_viewer()
    _, widget = viewer.window.add_plugin_dock_widget("napari-labyrinth", "Labyrinthine tiling")
    queue, _, _ = start_background(qtbot, viewer, widget, noise(SHAPE))
    path = queue.background.store.path
    viewer.close()
    assert not path.exists()
