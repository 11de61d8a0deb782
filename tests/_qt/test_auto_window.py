"""The Auto button beside V: it sets V from find_window and plots the window."""

from __future__ import annotations

import pytest

pytest.importorskip("napari")
pytest.importorskip("pytestqt")

from napari_labyrinth import find_window, samples
from napari_labyrinth.core.presets import DEFAULT_PRESET, PRESETS
from napari_labyrinth.plan import METADATA_KEY

from .helpers import RUN_TIMEOUT_MS, run


def test_auto_sets_v_to_the_window_s_best_and_the_run_records_it(qtbot, viewer, widget):
    data = samples.smectic_batonnets((96, 96))
    viewer.add_image(data, name="batonnets")
    widget.fields["passes"].value = 2
    auto = widget.auto_window
    assert not auto.plot.isVisible()
    assert auto.button.native.isVisible() or not widget.isVisible()

    worker = auto.find(start=False)
    with qtbot.waitSignal(worker.finished, timeout=RUN_TIMEOUT_MS):
        worker.start()

    expected = find_window(data, passes=2, tone_limits=(0.0, 255.0))
    assert auto.window == expected
    assert widget.fields["variance_threshold"].value == pytest.approx(expected.best, abs=5e-5)
    assert auto.plot.window == expected and not auto.plot.isHidden()
    assert expected.summary() in widget.status.value
    assert auto.button.enabled

    run(qtbot, widget)
    record = viewer.layers[-1].metadata[METADATA_KEY]
    assert record["parameters"]["variance_threshold"] == pytest.approx(expected.best, abs=5e-5)
    differs = abs(expected.best - PRESETS[DEFAULT_PRESET]["variance_threshold"]) > 5e-5
    assert ("variance_threshold" in record["overrides"]) == differs


def test_auto_without_a_layer_says_what_is_missing(widget):
    assert widget.auto_window.find() is None
    assert "Auto V" in widget.status.value and "image layer" in widget.status.value


def test_closing_the_widget_during_a_search_leaves_it_alone(qtbot, viewer, widget):
    viewer.add_image(samples.smectic_batonnets((96, 96)), name="batonnets")
    before = widget.fields["variance_threshold"].value
    worker = widget.auto_window.find(start=False)
    with qtbot.waitSignal(worker.finished, timeout=RUN_TIMEOUT_MS):
        worker.start()
        widget.close_down()
    assert widget.auto_window.worker is None and widget.auto_window.window is None
    assert widget.fields["variance_threshold"].value == before
