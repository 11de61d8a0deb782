"""The napari widget in a real viewer (headless Qt under Xvfb, started by pytest-xvfb).

Every run goes through the widget's thread worker; the results are checked
against the public API called with the arguments the result layer records,
bit for bit.
"""

from __future__ import annotations

import numpy as np
import pytest

pytest.importorskip("napari")
pytest.importorskip("pytestqt")

from napari.layers import Image

import napari_labyrinth
from napari_labyrinth import api
from napari_labyrinth._qt.widget import LabyrinthWidget
from napari_labyrinth.core import presets
from napari_labyrinth.widget.choices import CURRENT_PLANE
from napari_labyrinth.widget.layer_kwargs import METADATA_KEY
from napari_labyrinth.widget.text import default_sweep_text

from ..widget.plan_helpers import counting_lazy
from .helpers import (
    RUN_TIMEOUT_MS,
    grid_squares,
    labyrinth_docks,
    noise,
    reproduce,
    result_data,
    run,
)

# -- opening, choices, presets -----------------------------------------------------------------


def test_widget_opens_from_the_manifest_with_the_default_preset(viewer, widget):
    assert isinstance(widget, LabyrinthWidget)
    (dock,) = labyrinth_docks(viewer)
    assert dock.widget() is widget and dock.name == "Labyrinthine tiling (napari-labyrinth)"
    assert widget.preset.value == presets.DEFAULT_PRESET
    assert list(widget.preset.choices) == list(presets.PRESETS)
    assert widget.overrides() == {}


def test_only_image_layers_are_offered(viewer, widget):
    image = viewer.add_image(noise((32, 32)), name="picture")
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
    layer = viewer.add_image(noise((32, 32), np.float32), contrast_limits=(0.2, 0.8))
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
    data = noise(shape, dtype)
    before = data.copy()
    source = viewer.add_image(data, name="cell", rgb=rgb, scale=(0.5,) * (len(shape) - rgb))
    widget.fields["passes"].value = 2
    widget.fields["noise_gate"].value = 0.0  # white noise is its own noise: the gate off
    run(qtbot, widget)

    result = viewer.layers[-1]
    assert result == widget.last_result  # napari hands plugins proxies: == not `is`
    assert result != source
    assert result.name == "cell · labyrinth"  # short; the description is in the metadata
    assert result.metadata[METADATA_KEY]["description"].startswith("cell · labyrinth · 2 passes")
    assert result.data.shape == data.shape and result.data.dtype == data.dtype
    assert result.rgb == rgb
    np.testing.assert_array_equal(result.data, reproduce(result, data))
    assert not np.array_equal(result.data, data)
    np.testing.assert_array_equal(source.data, before)  # the input is never modified
    np.testing.assert_allclose(result.scale, source.scale)
    np.testing.assert_allclose(result.contrast_limits, source.contrast_limits)
    record = result.metadata[METADATA_KEY]
    assert record["version"] == napari_labyrinth.__version__
    assert record["preset"] == presets.DEFAULT_PRESET
    assert record["seed"] == 0
    assert (
        record["parameters"]
        == api.resolve_parameters(presets.DEFAULT_PRESET, passes=2, noise_gate=0).as_dict()
    )
    assert len(record["diagnostics"]["counts"]["redrawn"]) == 2  # one entry per pass


def test_stack_mode_holds_the_input_and_every_pass_with_metrics(qtbot, viewer, widget):
    data = noise((64, 64))
    # napari 0.5's add_image takes no units nor axis labels (a sequence asks for channel_axis)
    viewer.add_layer(
        Image(
            data,
            name="cell",
            scale=(2.0, 3.0),
            translate=(5.0, 7.0),
            units=("um", "um"),
            axis_labels=("y", "x"),
        )
    )
    widget.mode.value = "stack"
    widget.fields["passes"].value = 3
    run(qtbot, widget)

    result = viewer.layers[-1]
    assert result.name == "cell · stack"
    assert result.metadata[METADATA_KEY]["description"].startswith("cell · stack · 3 passes")
    assert result.data.shape == (4, 64, 64)
    np.testing.assert_array_equal(result.data[0], data)
    np.testing.assert_array_equal(result.data, reproduce(result, data))
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
    data = noise((48, 48), np.uint16)
    viewer.add_image(data, name="cell", contrast_limits=(1000, 60000))
    widget.mode.value = "sweep"
    widget.sweep_parameter.value = "variance_threshold"
    widget.sweep_values.value = "0.05, 0.08, 0.11"
    run(qtbot, widget)

    result = viewer.layers[-1]
    assert result.data.shape == (3, 48, 48)
    assert result.name == "cell · sweep V"
    description = result.metadata[METADATA_KEY]["description"]
    assert description.startswith("cell · sweep variance_threshold 0.05, 0.08, 0.11")
    assert result.axis_labels[0] == "variance_threshold"
    record = result.metadata[METADATA_KEY]
    assert record["arguments"]["tone_limits"] == [1000.0, 60000.0]
    assert len(record["diagnostics"]) == 3
    np.testing.assert_array_equal(result.data, reproduce(result, data))
    expected = api.labyrinth(data, variance_threshold=0.08, tone_limits=(1000, 60000))
    np.testing.assert_array_equal(result.data[1], expected)


def test_a_seed_sweep_renders_one_plane_per_seed(qtbot, viewer, widget):
    data = noise((32, 32))
    viewer.add_image(data, name="cell", contrast_limits=(0, 255))
    widget.mode.value = "sweep"
    widget.sweep_parameter.value = "seed"
    assert widget.sweep_values.value == "0, 1, 2"
    run(qtbot, widget)

    result = viewer.layers[-1]
    assert result.name == "cell · sweep seed"
    assert result.metadata[METADATA_KEY]["description"].startswith("cell · sweep seed 0, 1, 2")
    np.testing.assert_array_equal(result.data, reproduce(result, data))
    np.testing.assert_array_equal(result.data[2], api.labyrinth(data, seed=2))


def test_the_sweep_values_follow_v_until_the_user_types_their_own(qtbot, viewer, widget):
    data = noise((32, 32))
    viewer.add_image(data, name="cell", contrast_limits=(0, 255))
    widget.fields["variance_threshold"].value = 0.01  # typed, or set by Auto
    widget.mode.value = "sweep"
    assert widget.sweep_parameter.value == "variance_threshold"
    assert widget.sweep_values.value == "0, 0.01, 0.03"
    run(qtbot, widget)
    description = viewer.layers[-1].metadata[METADATA_KEY]["description"]
    assert description.startswith("cell · sweep variance_threshold 0, 0.01, 0.03 · ")

    widget.preset.value = "paper"  # its V, 0.5: Fig. 3's values
    assert widget.sweep_values.value == "0.47, 0.5, 0.53"
    widget.sweep_values.native.clear()
    qtbot.keyClicks(widget.sweep_values.native, "0.3, 0.6")  # the user's own values stay
    widget.fields["variance_threshold"].value = 0.2
    widget.preset.value = presets.DEFAULT_PRESET
    assert widget.sweep_values.value == "0.3, 0.6"
    widget.sweep_parameter.value = "passes"  # another parameter: its own proposal
    assert widget.sweep_values.value == "1, 2, 4, 8"
    widget.sweep_parameter.value = "variance_threshold"
    current = widget.fields["variance_threshold"].value
    assert widget.sweep_values.value == default_sweep_text("variance_threshold", current)


def test_auto_v_moves_the_proposed_sweep_values(qtbot, viewer, widget):
    viewer.add_image(noise((48, 48)), name="cell", contrast_limits=(0, 255))
    widget.mode.value = "sweep"
    worker = widget.auto_window.find(start=False)
    with qtbot.waitSignal(worker.finished, timeout=RUN_TIMEOUT_MS):
        worker.start()
    best = widget.fields["variance_threshold"].value
    assert best == widget.auto_window.window.best
    assert widget.sweep_values.value == default_sweep_text("variance_threshold", best)


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
    data = noise(shape, np.uint8 if rgb else np.float32)
    layer = viewer.add_image(
        data, name="movie", rgb=rgb, scale=(10.0, 1.0, 1.0), translate=(3.0, 0, 0)
    )
    viewer.dims.set_current_step(0, 2)
    widget.planes.value = CURRENT_PLANE
    widget.mode.value = mode
    run(qtbot, widget)

    result = viewer.layers[-1]
    record = result.metadata[METADATA_KEY]
    assert record["source_index"] == [2]
    assert record["arguments"]["plane_offset"] == (2 * 3 if rgb else 2)  # flat plane index
    whole = getattr(napari_labyrinth, record["function"])(
        data, **{k: v for k, v in record["arguments"].items() if k != "plane_offset"}
    )
    rendered = result_data(result)
    expected = whole[2] if mode == "single" else whole[:, 2]
    np.testing.assert_array_equal(rendered, expected)
    # the plane stays where it is in the world
    plane_axis = 0 if mode == "single" else 1
    assert result.data.shape[plane_axis] == 1
    np.testing.assert_allclose(result.translate[plane_axis], 3.0 + 2 * 10.0)
    assert "movie" in result.name and "=2" in result.name
    np.testing.assert_array_equal(layer.data, data)


# -- lazy input --------------------------------------------------------------------------------


@pytest.mark.parametrize("mode", ["single", "stack", "sweep"])
def test_lazy_input_renders_every_plane_in_the_background(qtbot, viewer, widget, mode):
    pytest.importorskip("dask.array")
    data = noise((6, 32, 32))
    lazy, _ = counting_lazy(data)
    viewer.add_image(lazy, name="lazy", contrast_limits=(0, 255))
    viewer.dims.set_current_step(0, 4)
    widget.mode.value = mode
    widget.fields["passes"].value = 2
    widget.sweep_values.value = "0.03, 0.05"
    run(qtbot, widget)  # the run, then the other planes

    result = viewer.layers[-1]
    record = result.metadata[METADATA_KEY]
    assert record["lazy"] and record["source_index"] is None
    assert "6 planes" in widget.status.value
    np.testing.assert_array_equal(np.asarray(result.data), reproduce(result, data))


@pytest.mark.parametrize("other_between", [False, True])
def test_compare_shows_input_and_result_side_by_side_and_back(
    qtbot, viewer, widget, other_between
):
    # a hidden layer between the input and the result took a square of napari 0.5's grid
    if not other_between:
        other = viewer.add_image(noise((32, 32), seed=1), name="other")
    source = viewer.add_image(noise((32, 32)), name="cell")
    if other_between:
        other = viewer.add_image(noise((32, 32), seed=1), name="other")
    widget.image_layer.value = source
    run(qtbot, widget)
    result = widget.last_result
    grid = viewer.canvas.grid if hasattr(viewer, "canvas") else viewer.grid

    widget.toggle_compare()
    assert widget.comparing and grid.enabled
    assert [layer.visible for layer in (other, source, result)] == [False, True, True]
    assert tuple(grid.shape) == (1, 2)
    assert grid_squares(viewer) == {"cell": (0, 0), result.name: (0, 1)}
    widget.toggle_compare()
    assert not widget.comparing and not grid.enabled
    assert all(layer.visible for layer in (other, source, result))


# -- colour ------------------------------------------------------------------------------------


@pytest.mark.parametrize("colour", ["luminance", "channels"])
def test_an_rgb_layer_keeps_its_hue_in_luminance_mode(qtbot, viewer, widget, colour):
    from skimage import color, data

    rgb = data.immunohistochemistry()[:96, :96].copy()
    viewer.add_image(rgb, name="ihc")
    assert widget.inputs.colour.enabled
    widget.inputs.colour.value = colour
    run(qtbot, widget)
    result = viewer.layers["ihc · labyrinth"]
    assert result.metadata[METADATA_KEY]["arguments"]["colour"] == colour
    np.testing.assert_array_equal(result.data, reproduce(result, rgb))
    changed = (result.data != rgb).any(axis=-1)
    inside = changed & (result.data < 255).all(axis=-1) & (result.data > 0).all(axis=-1)
    assert inside.sum() > 100
    hue_in = color.rgb2hsv(rgb)[..., 0][inside]
    hue_out = color.rgb2hsv(result.data)[..., 0][inside]
    turn = np.abs((hue_out - hue_in + 0.5) % 1.0 - 0.5)  # circular difference, in turns
    if colour == "luminance":
        assert np.median(turn) < 0.01  # the rounding of 8-bit channels only
    else:
        assert np.median(turn) > 0.02  # each channel drew its own tones: hue changes
