"""Runs in a napari thread worker: progress, cancel, responsiveness, errors."""

from __future__ import annotations

import threading

import numpy as np
import pytest

pytest.importorskip("napari")
pytest.importorskip("pytestqt")

from qtpy.QtCore import Qt

from .helpers import RUN_TIMEOUT_MS, noise, run


@pytest.mark.parametrize("mode, total", [("single", 3 * 2 + 1), ("sweep", 2 * 3 * 2 + 1)])
def test_progress_bar_counts_every_plane_and_pass(qtbot, viewer, widget, mode, total):
    from napari._qt.widgets.qt_progress_bar import QtLabeledProgressBar
    from qtpy.QtWidgets import QApplication

    viewer.add_image(noise((3, 512, 512)), name="movie")  # passes of a few ms: the bar shows
    widget.activity_panel = True
    widget.fields["passes"].value = 2
    widget.mode.value = mode
    widget.sweep_values.value = "0.03, 0.05"
    worker = widget.run(start=False)
    # planes x passes (x values of a sweep), and assembling the result
    assert worker.pbar.total == total

    def bars():  # the bar napari shows for the run in its activity panel
        return [
            (bar.description_label.text(), bar.qt_progress_bar.maximum())
            for top in QApplication.topLevelWidgets()
            for bar in top.findChildren(QtLabeledProgressBar)
            if bar.progress is worker.pbar
        ]

    yields = []
    worker.yielded.connect(yields.append)
    # held before its first step: napari makes and labels the bar as the worker starts,
    # processing the events waiting meanwhile (yields of a fast run among them)
    worker.pause()
    worker.start()
    labelled = lambda: bool(bars()) and bars()[0][0] != ""  # noqa: E731
    qtbot.waitUntil(lambda: worker.is_paused and labelled(), timeout=RUN_TIMEOUT_MS)
    assert bars() == [("Labyrinthine tiling: ", total)] and yields == []
    worker.resume()
    qtbot.waitUntil(lambda: widget.worker is None, timeout=RUN_TIMEOUT_MS)
    assert len(yields) == worker.pbar.total


def test_by_default_the_progress_shows_in_the_widget_only(qtbot, viewer, widget):
    """No bar in napari's activity panel: its animated indicator repaints the window."""
    from napari._qt.widgets.qt_progress_bar import QtLabeledProgressBar
    from qtpy.QtWidgets import QApplication

    viewer.add_image(noise((3, 64, 64)), name="movie")
    widget.fields["passes"].value = 2
    worker = widget.run(start=False)
    assert worker.pbar is None and widget.progress_bar.maximum() == 3 * 2 + 1
    bars = []
    worker.yielded.connect(
        lambda _: bars.extend(
            bar
            for top in QApplication.topLevelWidgets()
            for bar in top.findChildren(QtLabeledProgressBar)
        )
    )
    worker.start()
    qtbot.waitUntil(lambda: widget.worker is None, timeout=RUN_TIMEOUT_MS)
    assert bars == []


def on_first_yield(widget, worker, stop, abort_requested=None):
    """Call ``stop`` on the main thread at the run's first yield; the run waits for it.

    A short run may otherwise end before the main thread gets to its first yield
    (a busy machine: Qt queues the worker's signals), and nothing is left to stop.
    The run's plan asks ``abort_requested`` (default: its own) once ``stop`` is done.
    """
    yielded, stopped = threading.Event(), threading.Event()
    sees = widget._plan.abort_requested if abort_requested is None else abort_requested

    def waiting_abort_requested():
        if yielded.is_set():
            stopped.wait(RUN_TIMEOUT_MS / 1000)
        return sees()

    def stop_once(_):
        if not stopped.is_set():
            stop()
            stopped.set()

    widget._plan.abort_requested = waiting_abort_requested
    # marked in the worker's thread as it yields, before the run goes on
    worker.yielded.connect(lambda _: yielded.set(), Qt.ConnectionType.DirectConnection)
    worker.yielded.connect(stop_once)


def test_cancel_stops_the_run_and_adds_no_layer(qtbot, viewer, widget):
    viewer.add_image(noise((12, 256, 256)), name="movie")
    widget.fields["passes"].value = 4
    layers_before = len(viewer.layers)
    worker = widget.run(start=False)
    total = widget.progress_bar.maximum()
    yields = []
    worker.yielded.connect(yields.append)
    on_first_yield(widget, worker, widget.cancel)
    worker.start()
    qtbot.waitUntil(lambda: widget.worker is None, timeout=RUN_TIMEOUT_MS)
    assert len(viewer.layers) == layers_before
    assert widget.last_result is None
    assert len(yields) < total // 2  # stopped long before the end
    assert "Cancelled" in widget.status.value
    assert widget.run_button.enabled and not widget.cancel_button.enabled
    # the run was closed: none of its rendering threads goes on
    qtbot.waitUntil(
        lambda: not any(t.name.startswith("napari-labyrinth") for t in threading.enumerate()),
        timeout=RUN_TIMEOUT_MS,
    )


@pytest.mark.parametrize("run_sees_the_abort", [True, False])
def test_napari_s_abort_ends_the_run_and_its_threads(qtbot, viewer, widget, run_sees_the_abort):
    viewer.add_image(noise((12, 256, 256)), name="movie")
    widget.fields["passes"].value = 4
    layers_before = len(viewer.layers)
    worker = widget.run(start=False)
    sees = widget._plan.abort_requested if run_sees_the_abort else lambda: False
    # (False: only napari's loop sees it: it stops driving the run, which must then be closed)
    on_first_yield(widget, worker, worker.quit, sees)  # as napari's activity panel does
    worker.start()
    qtbot.waitUntil(lambda: widget.worker is None, timeout=RUN_TIMEOUT_MS)
    qtbot.waitUntil(
        lambda: not any(t.name.startswith("napari-labyrinth") for t in threading.enumerate()),
        timeout=RUN_TIMEOUT_MS,
    )
    assert len(viewer.layers) == layers_before


def test_the_viewer_stays_responsive_during_a_run(qtbot, viewer, widget):
    from qtpy.QtCore import QTimer

    viewer.add_image(noise((8, 1024, 1024)), name="movie")  # a run of about a second
    widget.fields["passes"].value = 4
    worker = widget.run()
    assert worker is not None  # run() returns at once, the worker renders
    assert not widget.run_button.enabled and widget.cancel_button.enabled
    assert widget.run() is None  # a second run waits for the first
    viewer.add_points([[1, 1, 1]], name="added meanwhile")
    ticks_while_running = []
    timer = QTimer()
    timer.timeout.connect(lambda: ticks_while_running.append(widget.worker is not None))
    timer.start(5)
    qtbot.waitUntil(lambda: widget.worker is None, timeout=RUN_TIMEOUT_MS)
    timer.stop()
    assert sum(ticks_while_running) >= 5, "the event loop did not run during the render"
    assert viewer.layers[-1].name.startswith("movie · labyrinth")


def test_api_errors_reach_the_user_as_a_message(qtbot, viewer, widget, shown_errors):
    viewer.add_image(np.arange(32 * 32, dtype=np.int64).reshape(32, 32), name="labels-like")
    layers_before = len(viewer.layers)
    run(qtbot, widget)
    assert len(viewer.layers) == layers_before
    assert len(shown_errors) == 1
    assert "dtype int64 is not supported" in shown_errors[0]
    assert "Traceback" not in shown_errors[0]


def test_bad_choices_are_reported_before_a_worker_starts(viewer, widget, shown_errors):
    assert widget.run() is None
    assert "choose an image layer" in shown_errors[-1]
    viewer.add_image(noise((32, 32)))
    widget.mode.value = "sweep"
    widget.sweep_values.value = "a, b"
    assert widget.run() is None
    assert "variance_threshold must be a number; got 'a'" in shown_errors[-1]
    widget.mode.value = "single"
    widget.follow_contrast.value = False
    widget.tone_low.value, widget.tone_high.value = "5", "1"
    assert widget.run() is None
    assert "low < high" in shown_errors[-1]


def test_error_notifications_are_napari_notifications(qtbot, viewer, widget):
    from napari.utils.notifications import notification_manager

    notification_manager.records.clear()
    widget.run()  # no image layer
    assert any("choose an image layer" in str(n.message) for n in notification_manager.records)


def test_agrees_tells_which_layer_attributes_an_update_must_set():
    from napari.utils.transforms import Affine

    from napari_labyrinth._qt.worker import agrees

    assert agrees([0.0, 255.0], (0, 255)) and not agrees([0.0, 255.0], [0.0, 254.0])
    assert agrees(np.array([1.0, 2.0]), [1.0, 2.0]) and not agrees(np.array([1.0]), [1.0, 1.0])
    assert agrees(np.eye(3), Affine(ndim=2).affine_matrix)
    assert agrees(Affine(ndim=2), np.eye(3)) and not agrees(Affine(scale=(2, 1)), np.eye(3))
    assert agrees(("y", "x"), ["y", "x"]) and not agrees(("y", "x"), ("x", "y"))
    assert agrees("translucent", "translucent") and not agrees(1.0, 0.5)
    assert not agrees({"a": 1}, {"a": 1})  # metadata is set, never compared
