"""The napari widget in a real viewer (headless Qt under Xvfb, started by pytest-xvfb).

Every run goes through the widget's thread worker; the results are checked
against the public API called with the arguments the result layer records,
bit for bit.
"""

from __future__ import annotations

import json
import threading
import time

import numpy as np
import pytest

pytest.importorskip("napari")
pytest.importorskip("pytestqt")

import napari_labyrinth
from napari_labyrinth import api, presets
from napari_labyrinth._qt.menus import render_selected_layer
from napari_labyrinth._qt.widget import LabyrinthWidget
from napari_labyrinth.plan import CURRENT_PLANE, METADATA_KEY, parse_sweep_values, result_name

RUN_TIMEOUT_MS = 60_000

#: Seconds each plane and pass takes under the ``slow_api`` fixture.
SLOW_STEP = 0.02


@pytest.fixture
def viewer(make_napari_viewer):
    return make_napari_viewer()


@pytest.fixture
def widget(viewer) -> LabyrinthWidget:
    """The widget as napari opens it from the manifest (Plugins menu)."""
    _, widget = viewer.window.add_plugin_dock_widget("napari-labyrinth", "Labyrinthine tiling")
    return widget


def _noise(shape, dtype=np.uint8, seed=0):
    rng = np.random.default_rng(seed)
    if np.dtype(dtype).kind == "f":
        return rng.random(shape).astype(dtype)
    return rng.integers(0, 256, shape).astype(dtype)


def _run(qtbot, widget: LabyrinthWidget):
    """Start a run and wait until its worker has finished."""
    worker = widget.run()
    assert worker is not None, widget.status.value
    qtbot.waitUntil(lambda: widget.worker is None, timeout=RUN_TIMEOUT_MS)
    return worker


def _reproduce(layer, source):
    """Render again through the API from what the result layer's metadata records."""
    record = json.loads(json.dumps(layer.metadata[METADATA_KEY]))  # survives JSON
    if record["source_index"] is not None:
        source = source[tuple(record["source_index"])]
    result = getattr(napari_labyrinth, record["function"])(source, **record["arguments"])
    return np.asarray(result)


def _result_data(layer):
    record = layer.metadata[METADATA_KEY]
    data = np.asarray(layer.data)
    if record["source_index"] is not None:  # size-1 axes place the plane in the stack
        extra = 0 if record["mode"] == "single" else 1
        data = data.reshape(data.shape[:extra] + data.shape[extra + len(record["source_index"]) :])
    return data


# -- opening, choices, presets -----------------------------------------------------------------


def test_widget_opens_from_the_manifest_with_the_default_preset(viewer, widget):
    assert isinstance(widget, LabyrinthWidget)
    assert viewer.window.dock_widgets["Labyrinthine tiling (napari-labyrinth)"] is widget
    assert widget.preset.value == presets.DEFAULT_PRESET
    assert list(widget.preset.choices) == list(presets.PRESETS)
    assert widget.overrides() == {}


def test_only_image_layers_are_offered(viewer, widget):
    image = viewer.add_image(_noise((32, 32)), name="picture")
    viewer.add_labels(np.zeros((32, 32), dtype=np.int32), name="labels")
    viewer.add_points([[1, 1]], name="points")
    assert [layer.name for layer in widget.image_layer.choices] == ["picture"]
    assert widget.image_layer.value is image


@pytest.mark.parametrize("preset", list(presets.PRESETS))
def test_a_preset_fills_every_field_and_an_edit_overrides_it(widget, preset):
    widget.preset.value = preset
    values = presets.PRESETS[preset]
    for name, field in widget.fields.items():
        expected = values[name]
        if name == "tone_ranges" and not isinstance(expected, int):
            expected = len(expected) - 1
        assert field.value == pytest.approx(expected), name
    assert widget.overrides() == {}
    widget.fields["variance_threshold"].value = values["variance_threshold"] + 0.01
    widget.fields["scan"].value = "serpentine" if values["scan"] == "raster" else "raster"
    assert set(widget.overrides()) == {"variance_threshold", "scan"}
    assert "variance_threshold" in widget.edited.value
    widget.preset.value = preset  # choosing the preset again refills the fields
    widget._apply_preset(preset)
    assert widget.overrides() == {}


def test_tone_limits_follow_the_contrast_limits(viewer, widget):
    layer = viewer.add_image(_noise((32, 32), np.float32), contrast_limits=(0.2, 0.8))
    assert widget.tone_limits() == (pytest.approx(0.2), pytest.approx(0.8))
    layer.contrast_limits = (0.1, 0.5)
    assert widget.tone_limits() == (pytest.approx(0.1), pytest.approx(0.5))
    assert float(widget.tone_low.value) == pytest.approx(0.1)
    widget.follow_contrast.value = False
    widget.tone_low.value, widget.tone_high.value = "0", "2"
    assert widget.tone_limits() == (0.0, 2.0)


# -- modes -------------------------------------------------------------------------------------


@pytest.mark.parametrize(
    "shape, dtype, rgb",
    [((64, 64), np.uint8, False), ((3, 48, 48), np.float32, False), ((48, 48, 3), np.uint8, True)],
    ids=["grey-uint8", "stack-float32", "rgb"],
)
def test_single_mode_adds_a_layer_that_the_api_reproduces(
    qtbot, viewer, widget, shape, dtype, rgb
):
    data = _noise(shape, dtype)
    before = data.copy()
    source = viewer.add_image(data, name="cell", rgb=rgb, scale=(0.5,) * (len(shape) - rgb))
    widget.fields["passes"].value = 2
    _run(qtbot, widget)

    result = viewer.layers[-1]
    assert result == widget.last_result  # napari hands plugins proxies: == not `is`
    assert result != source
    assert result.name.startswith("cell · labyrinth · 2 passes")
    assert result.data.shape == data.shape and result.data.dtype == data.dtype
    assert result.rgb == rgb
    np.testing.assert_array_equal(result.data, _reproduce(result, data))
    assert not np.array_equal(result.data, data)
    np.testing.assert_array_equal(source.data, before)  # the input is never modified
    np.testing.assert_allclose(result.scale, source.scale)
    np.testing.assert_allclose(result.contrast_limits, source.contrast_limits)
    record = result.metadata[METADATA_KEY]
    assert record["version"] == napari_labyrinth.__version__
    assert record["preset"] == presets.DEFAULT_PRESET
    assert record["seed"] == 0
    assert (
        record["parameters"] == api.resolve_parameters(presets.DEFAULT_PRESET, passes=2).as_dict()
    )
    assert len(record["diagnostics"]["counts"]["redrawn"]) == 2  # one entry per pass


def test_stack_mode_holds_the_input_and_every_pass_with_metrics(qtbot, viewer, widget):
    data = _noise((64, 64))
    viewer.add_image(
        data,
        name="cell",
        scale=(2.0, 3.0),
        translate=(5.0, 7.0),
        units=("um", "um"),
        axis_labels=("y", "x"),
    )
    widget.mode.value = "stack"
    widget.fields["passes"].value = 3
    _run(qtbot, widget)

    result = viewer.layers[-1]
    assert result.name.startswith("cell · stack · 3 passes")
    assert result.data.shape == (4, 64, 64)
    np.testing.assert_array_equal(result.data[0], data)
    np.testing.assert_array_equal(result.data, _reproduce(result, data))
    np.testing.assert_allclose(result.scale, (1.0, 2.0, 3.0))
    np.testing.assert_allclose(result.translate, (0.0, 5.0, 7.0))
    assert tuple(result.axis_labels) == ("pass", "y", "x")
    assert [str(u) for u in result.units][1:] == ["micrometer", "micrometer"]
    assert viewer.dims.current_step[0] == 3  # the slider shows the last pass
    record = result.metadata[METADATA_KEY]
    assert [row["pass"] for row in record["metrics"]] == [1, 2, 3]
    assert {"edge_enhancement", "labyrinth_cover", "changed"} <= set(record["metrics"][0])
    table = widget.metrics_table  # one row per metric, one column per pass
    assert table.columnCount() == 3
    assert table.horizontalHeaderItem(2).text() == "3"
    assert table.verticalHeaderItem(0).text() == "edge enhancement"
    assert float(table.item(0, 2).text()) == pytest.approx(
        record["metrics"][2]["edge_enhancement"], rel=1e-2
    )
    assert table.isVisibleTo(widget)


def test_sweep_mode_renders_one_plane_per_value(qtbot, viewer, widget):
    data = _noise((48, 48), np.uint16)
    viewer.add_image(data, name="cell", contrast_limits=(1000, 60000))
    widget.mode.value = "sweep"
    widget.sweep_parameter.value = "variance_threshold"
    widget.sweep_values.value = "0.05, 0.08, 0.11"
    _run(qtbot, widget)

    result = viewer.layers[-1]
    assert result.data.shape == (3, 48, 48)
    assert result.name.startswith("cell · sweep variance_threshold 0.05, 0.08, 0.11")
    assert result.axis_labels[0] == "variance_threshold"
    record = result.metadata[METADATA_KEY]
    assert record["arguments"]["tone_limits"] == [1000.0, 60000.0]
    assert len(record["diagnostics"]) == 3
    np.testing.assert_array_equal(result.data, _reproduce(result, data))
    expected = api.labyrinth(data, variance_threshold=0.08, tone_limits=(1000, 60000))
    np.testing.assert_array_equal(result.data[1], expected)


def test_sweep_values_are_parsed_and_checked():
    assert parse_sweep_values("variance_threshold", "0.47, 0.50;0.53") == [0.47, 0.5, 0.53]
    assert parse_sweep_values("passes", "1 2 4") == [1, 2, 4]
    assert parse_sweep_values("include_centre", "false, true") == [False, True]
    assert parse_sweep_values("border", "inside, wrap") == ["inside", "wrap"]
    with pytest.raises(ValueError, match="passes values must be whole numbers"):
        parse_sweep_values("passes", "1.5")
    with pytest.raises(ValueError, match="border"):
        parse_sweep_values("border", "outside")
    with pytest.raises(ValueError, match="at least one value"):
        parse_sweep_values("seed", " , ")


@pytest.mark.parametrize(
    "mode, shape, rgb",
    [
        ("single", (4, 40, 40), False),
        ("stack", (4, 40, 40), False),
        ("single", (4, 40, 40, 3), True),
    ],
    ids=["single", "stack", "rgb"],
)
def test_current_plane_equals_that_plane_of_the_whole_stack(
    qtbot, viewer, widget, mode, shape, rgb
):
    data = _noise(shape, np.uint8 if rgb else np.float32)
    layer = viewer.add_image(
        data, name="movie", rgb=rgb, scale=(10.0, 1.0, 1.0), translate=(3.0, 0, 0)
    )
    viewer.dims.set_current_step(0, 2)
    widget.planes.value = CURRENT_PLANE
    widget.mode.value = mode
    _run(qtbot, widget)

    result = viewer.layers[-1]
    record = result.metadata[METADATA_KEY]
    assert record["source_index"] == [2]
    assert record["arguments"]["plane_offset"] == (2 * 3 if rgb else 2)  # flat plane index
    whole = getattr(napari_labyrinth, record["function"])(
        data, **{k: v for k, v in record["arguments"].items() if k != "plane_offset"}
    )
    rendered = _result_data(result)
    expected = whole[2] if mode == "single" else whole[:, 2]
    np.testing.assert_array_equal(rendered, expected)
    # the plane stays where it is in the world
    plane_axis = 0 if mode == "single" else 1
    assert result.data.shape[plane_axis] == 1
    np.testing.assert_allclose(result.translate[plane_axis], 3.0 + 2 * 10.0)
    assert "movie" in result.name and "=2" in result.name
    np.testing.assert_array_equal(layer.data, data)


# -- the worker: progress, cancel, responsiveness, errors --------------------------------------


@pytest.fixture
def slow_api(monkeypatch):
    """Make every plane and pass of the API take at least ``SLOW_STEP`` seconds.

    Runs of small test images finish in milliseconds, before a test could
    watch or cancel them; slowed down, they leave time to do both.
    """

    def slowed(function):
        def wrapper(image, *, progress=None, **options):
            if progress is None:  # lazy (dask) calls take no progress callback
                return function(image, **options)

            def slow_progress(done, total):
                time.sleep(SLOW_STEP)
                progress(done, total)

            return function(image, progress=slow_progress, **options)

        return wrapper

    for name in ("labyrinth", "labyrinth_stack", "labyrinth_sweep"):
        monkeypatch.setattr(api, name, slowed(getattr(api, name)))


def test_progress_bar_counts_every_plane_and_pass(qtbot, viewer, widget, slow_api):
    from napari._qt.widgets.qt_progress_bar import QtLabeledProgressBar
    from qtpy.QtWidgets import QApplication

    viewer.add_image(_noise((3, 32, 32)), name="movie")
    widget.fields["passes"].value = 2
    worker = widget.run(start=False)
    assert worker.pbar.total == 3 * 2 + 1  # planes x passes, and assembling the result
    yields, bars = [], []

    def on_yield(value):
        yields.append(value)
        if len(yields) == 3:  # the bar napari shows in its activity panel
            bars.extend(
                (bar.description_label.text(), bar.qt_progress_bar.maximum())
                for top in QApplication.topLevelWidgets()
                for bar in top.findChildren(QtLabeledProgressBar)
            )

    worker.yielded.connect(on_yield)
    worker.start()
    qtbot.waitUntil(lambda: widget.worker is None, timeout=RUN_TIMEOUT_MS)
    assert len(yields) == worker.pbar.total
    assert ("Labyrinthine tiling: ", 7) in bars, bars


def test_cancel_stops_the_run_and_adds_no_layer(qtbot, viewer, widget, slow_api):
    viewer.add_image(_noise((10, 32, 32)), name="movie")
    widget.fields["passes"].value = 3
    layers_before = len(viewer.layers)
    worker = widget.run(start=False)
    yields = []

    def cancel_on_first_yield(value):
        yields.append(value)
        widget.cancel()

    worker.yielded.connect(cancel_on_first_yield)
    worker.start()
    qtbot.waitUntil(lambda: widget.worker is None, timeout=RUN_TIMEOUT_MS)
    assert len(viewer.layers) == layers_before
    assert widget.last_result is None
    assert len(yields) <= 2  # stopped at the next plane or pass
    assert "Cancelled" in widget.status.value
    assert widget.run_button.enabled and not widget.cancel_button.enabled
    qtbot.waitUntil(
        lambda: not any(t.name == "napari-labyrinth render" for t in threading.enumerate()),
        timeout=RUN_TIMEOUT_MS,
    )


def test_the_viewer_stays_responsive_during_a_run(qtbot, viewer, widget, slow_api):
    from qtpy.QtCore import QTimer

    viewer.add_image(_noise((5, 32, 32)), name="movie")
    widget.fields["passes"].value = 2
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


@pytest.fixture
def shown_errors(monkeypatch):
    messages = []
    import napari_labyrinth._qt.widget as widget_module

    monkeypatch.setattr(widget_module, "show_error", messages.append)
    return messages


def test_api_errors_reach_the_user_as_a_message(qtbot, viewer, widget, shown_errors):
    viewer.add_image(np.arange(32 * 32, dtype=np.int64).reshape(32, 32), name="labels-like")
    layers_before = len(viewer.layers)
    _run(qtbot, widget)
    assert len(viewer.layers) == layers_before
    assert len(shown_errors) == 1
    assert "dtype int64 is not supported" in shown_errors[0]
    assert "Traceback" not in shown_errors[0]


def test_bad_choices_are_reported_before_a_worker_starts(viewer, widget, shown_errors):
    assert widget.run() is None
    assert "choose an image layer" in shown_errors[-1]
    viewer.add_image(_noise((32, 32)))
    widget.mode.value = "sweep"
    widget.sweep_values.value = "a, b"
    assert widget.run() is None
    assert "values must be numbers" in shown_errors[-1]
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


# -- lazy input --------------------------------------------------------------------------------


@pytest.mark.parametrize("mode", ["single", "stack", "sweep"])
def test_lazy_input_renders_the_visible_plane_and_keeps_the_rest_lazy(qtbot, viewer, widget, mode):
    da = pytest.importorskip("dask.array")
    data = _noise((6, 32, 32))
    loaded = []

    def count(block, block_info=None):
        loaded.append(block_info[0]["array-location"][0][0])
        return block

    lazy = da.from_array(data, chunks=(1, 32, 32)).map_blocks(count, dtype=data.dtype)
    viewer.add_image(lazy, name="lazy", contrast_limits=(0, 255))
    viewer.dims.set_current_step(0, 4)
    loaded.clear()
    widget.mode.value = mode
    widget.fields["passes"].value = 2
    widget.sweep_values.value = "0.03, 0.05"
    _run(qtbot, widget)

    result = viewer.layers[-1]
    assert isinstance(result.data, da.Array)
    assert set(loaded) <= {4}, "only the visible plane may be loaded"
    record = result.metadata[METADATA_KEY]
    assert record["lazy"] and record["source_index"] is None
    np.testing.assert_array_equal(np.asarray(result.data), _reproduce(result, data))


# -- compare, menus, samples -------------------------------------------------------------------


def test_compare_shows_input_and_result_side_by_side_and_back(qtbot, viewer, widget):
    other = viewer.add_image(_noise((32, 32), seed=1), name="other")
    source = viewer.add_image(_noise((32, 32)), name="cell")
    widget.image_layer.value = source
    _run(qtbot, widget)
    result = widget.last_result
    grid = viewer.canvas.grid if hasattr(viewer, "canvas") else viewer.grid

    widget.toggle_compare()
    assert widget.comparing and grid.enabled
    assert [layer.visible for layer in (other, source, result)] == [False, True, True]
    assert grid.actual_shape(list(viewer.layers)) == (1, 2)
    widget.toggle_compare()
    assert not widget.comparing and not grid.enabled
    assert all(layer.visible for layer in (other, source, result))


def test_menu_command_renders_the_selected_layer(qtbot, viewer):
    from napari._app_model import get_app_model

    menu = get_app_model().menus.get_menu("napari/layers/filter")
    commands = {item.command.id for item in menu if hasattr(item, "command")}
    assert {
        "napari-labyrinth.open_widget",
        "napari-labyrinth.render_selected_layer",
        "napari-labyrinth.stack_selected_layer",
    } <= commands

    layer = viewer.add_image(_noise((32, 32)), name="cell")
    viewer.layers.selection.active = layer
    render_selected_layer(viewer)
    widget = viewer.window.dock_widgets["Labyrinthine tiling (napari-labyrinth)"]
    qtbot.waitUntil(lambda: widget.worker is None, timeout=RUN_TIMEOUT_MS)
    assert viewer.layers[-1].name.startswith("cell · labyrinth")


@pytest.mark.parametrize(
    "key, shape, rgb",
    [
        ("nematic_schlieren", (512, 512), False),
        ("cholesteric_fingerprint", (512, 512), False),
        ("cell", (660, 550), False),
        ("immunohistochemistry", (512, 512, 3), True),
    ],
)
def test_samples_open_in_the_viewer(viewer, key, shape, rgb):
    layers = viewer.open_sample("napari-labyrinth", key)
    (layer,) = layers
    assert layer.data.shape == shape
    assert layer.rgb == rgb


def test_result_name_lists_the_key_parameters():
    assert result_name("cell", "single", 4, "labyrinth", {}, 0) == (
        "cell · labyrinth · 4 passes · preset labyrinth"
    )
    name = result_name("cell", "stack", 1, "paper", {"variance_threshold": 0.47}, 3)
    assert name == "cell · stack · 1 pass · preset paper · V=0.47 · seed 3"
