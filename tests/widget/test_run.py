"""The widget's run without napari or Qt: progress, metrics, cancel, lazy results."""

from __future__ import annotations

import dataclasses
import json
import subprocess
import sys
import threading

import numpy as np
import pytest

from napari_labyrinth import api, metrics
from napari_labyrinth.core.tone_scale import resolve_tone_scale
from napari_labyrinth.widget.choices import CURRENT_PLANE, Choices, LayerSnapshot
from napari_labyrinth.widget.layer_kwargs import METADATA_KEY
from napari_labyrinth.widget.plan import make_plan
from napari_labyrinth.widget.run import (
    Failure,
    Outcome,
    diagnostics_record,
    render,
    result_layer,
)
from napari_labyrinth.widget.text import METRIC_ROWS

from .plan_helpers import counting_lazy, drive, noise, reproduce

data = pytest.importorskip("skimage.data")

# -- the package stays Qt-free -----------------------------------------------------------------


@pytest.mark.subprocess
def test_the_widget_package_and_a_run_import_neither_napari_nor_qt():
    code = (
        "import importlib, pkgutil, sys, numpy as np;"
        "import napari_labyrinth.widget as widget;"
        "[importlib.import_module(module.name) for module in"
        " pkgutil.iter_modules(widget.__path__, 'napari_labyrinth.widget.')];"
        "plan = widget.make_plan(widget.LayerSnapshot.of(np.zeros((8, 8), np.uint8)),"
        " widget.Choices());"
        "list(widget.render(plan));"
        "print(sorted(m for m in ('napari', 'qtpy', 'PyQt6', 'PyQt5', 'PySide6', 'magicgui',"
        " 'superqt', 'vispy') if m in sys.modules))"
    )
    result = subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, timeout=300, check=False
    )
    assert result.returncode == 0, result.stderr
    assert result.stdout.strip() == "[]"


def test_diagnostics_record_is_plain_json():
    counts = np.array([(1, 3), (2, 4)], dtype=[("redrawn", np.int64), ("kept", np.int64)])
    record = diagnostics_record(counts)
    assert record == {"shape": [2], "counts": {"redrawn": [1, 2], "kept": [3, 4]}}
    assert json.loads(json.dumps(record)) == record
    assert diagnostics_record(None) is None


# -- the run -----------------------------------------------------------------------------------


def test_a_run_yields_every_step_and_reproduces_through_the_api():
    data = noise((3, 16, 16))
    plan = make_plan(LayerSnapshot.of(data), Choices(overrides={"passes": 2}, seed=5))
    steps, outcome = drive(plan)
    assert isinstance(outcome, Outcome)
    assert len(steps) == plan.total_steps == 7
    assert steps[-1] == plan.total_steps
    assert outcome.metric_rows == [] and outcome.seconds >= 0
    np.testing.assert_array_equal(outcome.data, api.labyrinth(data, passes=2, seed=5))
    layer_data, kwargs = result_layer(plan, outcome)
    assert layer_data is outcome.data
    np.testing.assert_array_equal(layer_data, reproduce(kwargs, data))
    record = kwargs["metadata"][METADATA_KEY]
    assert len(record["diagnostics"]["counts"]["redrawn"]) == 2  # one entry per pass
    assert record["diagnostics_scope"] == "all planes"
    assert "diagnostics" not in plan.layer_kwargs["metadata"][METADATA_KEY]  # plan untouched


def test_a_stack_run_measures_every_pass_on_the_visible_plane():
    data = noise((2, 48, 48))
    snapshot = LayerSnapshot.of(data, visible_index=(1,))
    plan = make_plan(snapshot, Choices(mode="stack", overrides={"passes": 3}))
    steps, outcome = drive(plan)
    assert len(steps) == plan.total_steps == 2 * 3 + 3 + 1
    assert outcome.data.shape == (4, 2, 48, 48)
    rows = outcome.metric_rows
    assert [row["pass"] for row in rows] == [1, 2, 3]
    assert {key for key, _, _ in METRIC_ROWS} <= set(rows[0])
    for row in rows:
        after, before = outcome.data[row["pass"], 1], outcome.data[row["pass"] - 1, 1]
        assert row["changed"] == pytest.approx(100.0 * np.mean(after != before))
    # measured on the tone scale the passes ran on
    scale = resolve_tone_scale(data, None)  # the API's default, of the whole layer
    described = metrics.describe(scale.to_tones(data[1]), scale.to_tones(outcome.data[2, 1]))
    for name, value in described.items():
        assert rows[1][name] == pytest.approx(value, nan_ok=True), name
    _, kwargs = result_layer(plan, outcome)
    assert kwargs["metadata"][METADATA_KEY]["metrics"] == rows


def _stack_metrics(data, factor=1.0):
    # napari's contrast limits of the layer, the widget's default tone limits
    snapshot = LayerSnapshot.of(data, contrast_limits=(0.0, 255.0 * factor))
    _, outcome = drive(make_plan(snapshot, Choices(mode="stack", overrides={"passes": 2})))
    return outcome.metric_rows


def test_the_metrics_of_an_image_do_not_depend_on_its_dtype_or_units():
    # measured in the layer's own values, a uint16 image had its walls' flatness bound
    # (metrics.ENERGY_FLOOR, in tones) read 257 times too low, and a float image in [0, 1]
    # had no walls at all
    image = data.camera()[128:320, 128:320]
    as_uint8 = _stack_metrics(image)
    assert as_uint8[1]["labyrinth_cover"] > 0.01
    for factor in (257, 1 / 255, 1e6):
        other = image.astype(np.uint16) * 257 if factor == 257 else image * factor
        rows = _stack_metrics(other, factor)
        for row, expected in zip(rows, as_uint8):
            for name, value in expected.items():
                if name == "changed":  # finer values than uint8's keep more of the changes
                    continue
                assert row[name] == pytest.approx(value, rel=0.02, abs=2e-3, nan_ok=True), (
                    other.dtype, name
                )


def test_nan_pixels_that_stay_nan_are_not_counted_as_changed():
    data = noise((48, 48)).astype(np.float32)
    data[:, 24:] = np.nan
    plan = make_plan(LayerSnapshot.of(data), Choices(mode="stack", overrides={"passes": 2}))
    _, outcome = drive(plan)
    for row in outcome.metric_rows:
        after, before = outcome.data[row["pass"]], outcome.data[row["pass"] - 1]
        assert np.isnan(after[:, 24:]).all()
        expected = 100.0 * np.mean(after[:, :24] != before[:, :24]) / 2
        assert row["changed"] == pytest.approx(expected)


def test_metrics_of_a_plane_too_small_for_their_windows_are_nan():
    plan = make_plan(LayerSnapshot.of(noise((2, 2))), Choices(mode="stack"))
    _, outcome = drive(plan)
    assert all(np.isnan(row["edge_enhancement"]) for row in outcome.metric_rows)
    assert all(np.isfinite(row["changed"]) for row in outcome.metric_rows)


@pytest.mark.parametrize("mode", ["single", "stack"])
def test_a_plane_rendered_alone_gets_size_one_axes(mode):
    data = noise((4, 16, 16), np.float32)
    snapshot = LayerSnapshot.of(data, visible_index=(2,), contrast_limits=(0.0, 1.0))
    plan = make_plan(snapshot, Choices(mode=mode, planes=CURRENT_PLANE, overrides={"passes": 2}))
    steps, outcome = drive(plan)
    assert len(steps) == plan.total_steps
    layer_data, kwargs = result_layer(plan, outcome)
    assert layer_data.shape == ((1, 16, 16) if mode == "single" else (3, 1, 16, 16))
    record = kwargs["metadata"][METADATA_KEY]
    assert record["diagnostics_scope"] == "the rendered plane"
    whole = getattr(api, plan.function)(data, passes=2, tone_limits=(0.0, 1.0))
    expected = whole[2] if mode == "single" else whole[:, 2]
    np.testing.assert_array_equal(outcome.data, expected)
    reproduced = reproduce(kwargs, data).reshape(layer_data.shape)
    np.testing.assert_array_equal(np.asarray(layer_data), reproduced)


def test_a_sweep_records_the_diagnostics_of_every_value():
    data = noise((16, 16))
    choices = Choices(mode="sweep", sweep_parameter="scan", sweep_text="raster serpentine")
    plan = make_plan(LayerSnapshot.of(data), choices)
    _, outcome = drive(plan)
    layer_data, kwargs = result_layer(plan, outcome)
    assert layer_data.shape == (2, 16, 16)
    np.testing.assert_array_equal(layer_data[1], api.labyrinth(data, scan="serpentine"))
    assert len(kwargs["metadata"][METADATA_KEY]["diagnostics"]) == 2


def test_a_seed_sweep_renders_with_each_seed():
    data = noise((16, 16))
    choices = Choices(mode="sweep", seed=9, sweep_parameter="seed", sweep_text="1 2")
    plan = make_plan(LayerSnapshot.of(data), choices)
    assert "seed" not in plan.arguments
    assert plan.layer_kwargs["metadata"][METADATA_KEY]["seed"] == 9
    assert plan.name == "image · sweep seed"
    assert plan.description == "image · sweep seed 1, 2 · 4 passes · preset labyrinth"
    _, outcome = drive(plan)
    layer_data, kwargs = result_layer(plan, outcome)
    np.testing.assert_array_equal(layer_data[1], api.labyrinth(data, seed=2))
    np.testing.assert_array_equal(layer_data, reproduce(kwargs, data))


@pytest.mark.parametrize("mode", ["single", "stack", "sweep"])
def test_a_lazy_run_loads_the_visible_plane_only_and_the_rest_renders_after(mode):
    pytest.importorskip("dask.array")
    data = noise((5, 16, 16))
    lazy, loaded = counting_lazy(data)
    snapshot = LayerSnapshot.of(lazy, visible_index=(3,))
    choices = Choices(mode=mode, overrides={"passes": 2}, sweep_text="0.03, 0.05")
    plan = make_plan(snapshot, choices)
    loaded.clear()
    steps, outcome = drive(plan)
    assert set(loaded) == {3}, "only the visible plane may be loaded"
    assert len(steps) == plan.total_steps
    background = outcome.background
    assert outcome.data is background.data and not background.complete
    layer_data, kwargs = result_layer(plan, outcome)
    record = kwargs["metadata"][METADATA_KEY]
    assert record["diagnostics_scope"] == "the plane on screen (the others render in the background)"
    assert record["diagnostics_plane"] == [3]
    expected = reproduce(kwargs, data)
    axis = 0 if mode == "single" else 1
    shown = np.take(np.asarray(layer_data), 3, axis=axis)
    np.testing.assert_array_equal(shown, np.take(expected, 3, axis=axis))
    background.render_all()
    assert background.complete
    np.testing.assert_array_equal(np.asarray(layer_data), expected)
    background.remove()
    assert not background.store.path.exists()


def test_a_lazy_run_cancelled_leaves_no_store(tmp_path, monkeypatch):
    pytest.importorskip("dask.array")
    monkeypatch.setattr("tempfile.tempdir", str(tmp_path))
    lazy, _ = counting_lazy(noise((4, 16, 16)))
    plan = make_plan(LayerSnapshot.of(lazy, visible_index=(1,)), Choices())
    # cancelled as the last step is yielded: the store of the plane on screen is made by then

    def on_last_step(step):
        if step == plan.total_steps:
            plan.cancel.set()

    steps, outcome = drive(plan, on_step=on_last_step)
    assert steps[-1] == plan.total_steps and outcome is None
    assert not list(tmp_path.iterdir())


@pytest.mark.parametrize("workers", [1, 2])
def test_cancel_stops_a_run_at_its_next_pass_and_leaves_no_thread(workers):
    snapshot = LayerSnapshot.of(noise((10, 64, 64)))
    plan = make_plan(snapshot, Choices(overrides={"passes": 3}))
    plan.arguments["workers"] = workers
    steps, outcome = drive(plan, on_step=lambda _: plan.cancel.set())
    assert outcome is None
    assert steps == [1]  # the next pass saw the cancel
    assert not [t for t in threading.enumerate() if t.name.startswith("napari-labyrinth")]


def test_closing_a_run_stops_the_rendering_threads_at_once():
    plan = make_plan(LayerSnapshot.of(noise((12, 128, 128))), Choices(overrides={"passes": 4}))
    plan.arguments["workers"] = 2
    run = render(plan)
    assert next(run) == 1
    run.close()  # what the worker does when napari aborts it
    assert not [t for t in threading.enumerate() if t.name.startswith("napari-labyrinth")]


def test_a_run_cancelled_before_it_starts_yields_nothing():
    plan = make_plan(LayerSnapshot.of(noise((8, 8))), Choices())
    plan.abort_requested = lambda: True  # napari's activity panel asked to stop
    assert drive(plan) == ([], None)


def test_api_errors_come_back_as_a_message():
    data = np.arange(32 * 32, dtype=np.int64).reshape(32, 32)
    plan = make_plan(LayerSnapshot.of(data, contrast_limits=(0, 1023)), Choices())
    steps, outcome = drive(plan)
    assert steps == []
    assert isinstance(outcome, Failure)
    assert "dtype int64 is not supported" in outcome.message


def test_layer_snapshot_defaults_are_napari_defaults():
    snapshot = LayerSnapshot.of(np.zeros((3, 8, 8, 3)), rgb=True)
    assert snapshot.ndim == 3
    assert snapshot.axis_labels == ("-3", "-2", "-1")
    assert snapshot.units == ("pixel",) * 3
    assert snapshot.shear.shape == (3,) and snapshot.affine.shape == (4, 4)
    assert snapshot.visible_index == (0,)
    with pytest.raises(dataclasses.FrozenInstanceError):
        snapshot.name = "other"
