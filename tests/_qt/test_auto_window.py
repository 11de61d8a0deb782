"""The Auto button beside V: it sets V from find_window and plots the window."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

pytest.importorskip("napari")
pytest.importorskip("pytestqt")

from napari_labyrinth import find_window, samples
from napari_labyrinth._qt.auto_window import COVER_CAPTION, CURVE_CAPTION, WindowPlot
from napari_labyrinth.core.presets import DEFAULT_PRESET, PRESETS
from napari_labyrinth.widget.layer_kwargs import METADATA_KEY

from .helpers import RUN_TIMEOUT_MS, run


def test_auto_sets_v_to_the_window_s_best_and_the_run_records_it(qtbot, viewer, widget):
    # a texture whose best V on the default grid (0.04 * sqrt 2) has more decimals than
    # the field shows, unless the grid is rounded to them
    data = np.rint(samples.nematic_schlieren((96, 96)) * 255).astype(np.uint8)
    viewer.add_image(data, name="schlieren")
    widget.fields["passes"].value = 2
    auto = widget.auto_window
    assert not auto.plot.isVisible()
    assert auto.button.native.isVisible() or not widget.isVisible()

    worker = auto.find(start=False)
    with qtbot.waitSignal(worker.finished, timeout=RUN_TIMEOUT_MS):
        worker.start()

    expected = find_window(data, passes=2, tone_limits=(0.0, 255.0))
    assert auto.window == expected
    # the V chosen is the V the field holds, runs and records, not a rounding of it
    assert widget.fields["variance_threshold"].value == expected.best
    assert auto.plot.window == expected and not auto.plot.isHidden()
    assert expected.summary() in widget.status.value
    assert auto.button.enabled

    run(qtbot, widget)
    record = viewer.layers[-1].metadata[METADATA_KEY]
    assert record["parameters"]["variance_threshold"] == expected.best
    differs = expected.best != PRESETS[DEFAULT_PRESET]["variance_threshold"]
    assert ("variance_threshold" in record["overrides"]) == differs


def test_the_plot_marks_the_chosen_v_and_says_why(qtbot, viewer, widget):
    # a smooth texture with a camera's noise: the V of the best edge score drew no walls
    smooth = samples.nematic_schlieren((256, 256), seed=0, noise=0.0) * 255.0
    noise = np.random.default_rng(0).normal(0.0, 2.0, smooth.shape)
    data = np.clip(np.rint(smooth + noise), 0, 255).astype(np.uint8)
    viewer.add_image(data, name="schlieren")
    auto = widget.auto_window
    worker = auto.find(start=False)
    with qtbot.waitSignal(worker.finished, timeout=RUN_TIMEOUT_MS):
        worker.start()

    window = auto.window
    assert window.reason.startswith("cover ") and ", aligned " in window.reason
    assert window.choice == f"V = {window.best:.4g}: {window.reason}"
    captions = [text for _, text in auto.plot.plot_rects().legend]
    assert captions == [CURVE_CAPTION, COVER_CAPTION, window.choice, window.range_note]
    assert window.choice in widget.status.value
    assert not auto.plot.isHidden()
    auto.plot.grab()  # paints without error


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


def test_the_plot_notes_a_window_open_at_an_end(qtbot):
    from napari_labyrinth.window import Window

    thresholds = (0.01, 0.02, 0.04, 0.08)
    closed = Window(0.02, 0.04, 0.04, True, thresholds, (0.1, 0.5, 0.6, 0.2), (0,) * 4, (), 64)
    open_low = dataclasses.replace(closed, low=0.01, low_open=True)
    plot = WindowPlot()
    qtbot.addWidget(plot)
    plot.show_window(closed)
    assert closed.open_note == "" and "probed" not in closed.summary()
    # the curve says what it is, the dashed line which V was chosen, then the window
    legend = [text for _, text in plot.plot_rects().legend]
    assert legend == [CURVE_CAPTION, "V = 0.04", "window 0.02-0.04"]
    plot.show_window(open_low)
    assert open_low.open_note == "it reaches the lowest V probed"
    assert open_low.summary().endswith("; it reaches the lowest V probed)")
    # the note follows the window's range
    captions = [text for _, text in plot.plot_rects().legend]
    assert captions == [CURVE_CAPTION, "V = 0.04", "window 0.01-0.04; it reaches the lowest V probed"]
    plot.grab()  # paints without error


def test_the_plot_draws_the_cover_and_the_reason_of_a_window_found(qtbot):
    from napari_labyrinth.window import Window

    thresholds = (0.01, 0.02, 0.04, 0.08)
    window = Window(0.02, 0.02, 0.04, True, thresholds, (0.1, 0.5, 0.6, 0.2), (0.5,) * 4, (),
                    64, cover=(0.2, 0.19, 0.1, math.nan), alignment=(0.9,) * 4,
                    reason="cover 0.19, aligned 0.90")  # fmt: skip
    plot = WindowPlot()
    qtbot.addWidget(plot)
    plot.show_window(window)
    legend = [text for _, text in plot.plot_rects().legend]
    assert legend == [CURVE_CAPTION, COVER_CAPTION, "V = 0.02: cover 0.19, aligned 0.90",
                      "window 0.02-0.04"]  # fmt: skip
    assert window.summary() == "V = 0.02: cover 0.19, aligned 0.90 (window 0.02-0.04)"
    plot.grab()
