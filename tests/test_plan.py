"""What a widget run will do, and the run itself, without napari or Qt.

A layer is described by a :class:`LayerSnapshot`, the user's choices by
:class:`Choices`; the run generator is driven directly, as the napari worker
drives it.
"""

from __future__ import annotations

import dataclasses
import json
import subprocess
import sys
import threading
import time

import numpy as np
import pytest

import napari_labyrinth
from napari_labyrinth import api, metrics, presets
from napari_labyrinth.plan import (
    CURRENT_PLANE,
    METADATA_KEY,
    METRIC_ROWS,
    SWEEP_PARAMETERS,
    Choices,
    Failure,
    LayerSnapshot,
    Outcome,
    data_to_physical,
    default_sweep_text,
    diagnostics_record,
    edited_text,
    format_metric,
    make_plan,
    metric_cells,
    metric_row_headers,
    overrides,
    parse_sweep_values,
    plane_label,
    plane_offset,
    preset_field_values,
    render,
    result_layer,
    result_layer_kwargs,
    result_name,
    splice_plane,
    step_count,
    tone_limit_text,
    tone_limits,
    visible_plane,
)

FIELDS = [name for name in presets.PRESETS[presets.DEFAULT_PRESET] if name != "tones"]


def _noise(shape, dtype=np.uint8, seed=0):
    rng = np.random.default_rng(seed)
    if np.dtype(dtype).kind == "f":
        return rng.random(shape).astype(dtype)
    return rng.integers(0, 256, shape).astype(dtype)


def _drive(plan, on_step=None):
    """Run the plan's generator to its end as the worker does: (yields, returned value)."""
    steps = []
    run = render(plan)
    while True:
        try:
            step = next(run)
        except StopIteration as stop:
            return steps, stop.value
        steps.append(step)
        if on_step is not None:
            on_step(step)


def _reproduce(kwargs, source):
    """Render again through the API from the layer's metadata record (after JSON)."""
    record = json.loads(json.dumps(kwargs["metadata"][METADATA_KEY]))
    if record["source_index"] is not None:
        source = source[tuple(record["source_index"])]
    return np.asarray(getattr(napari_labyrinth, record["function"])(source, **record["arguments"]))


# -- the module stays Qt-free ------------------------------------------------------------------


def test_plan_and_a_run_import_neither_napari_nor_qt():
    code = (
        "import sys, numpy as np;"
        "from napari_labyrinth.plan import LayerSnapshot, Choices, make_plan, render;"
        "plan = make_plan(LayerSnapshot.of(np.zeros((8, 8), np.uint8)), Choices());"
        "list(render(plan));"
        "print(sorted(m for m in ('napari', 'qtpy', 'PyQt6', 'PyQt5', 'PySide6', 'magicgui',"
        " 'superqt', 'vispy') if m in sys.modules))"
    )
    result = subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, timeout=300, check=False
    )
    assert result.returncode == 0, result.stderr
    assert result.stdout.strip() == "[]"


# -- text in, text out -------------------------------------------------------------------------


def test_sweep_values_are_parsed_and_checked():
    assert parse_sweep_values("variance_threshold", "0.47, 0.50;0.53") == [0.47, 0.5, 0.53]
    assert parse_sweep_values("passes", "1 2 4") == [1, 2, 4]
    assert parse_sweep_values("seed", "\t3,\n4 ") == [3, 4]
    assert parse_sweep_values("include_centre", "false, true, YES, 0") == [
        False,
        True,
        True,
        False,
    ]
    assert parse_sweep_values("border", "inside, wrap") == ["inside", "wrap"]
    with pytest.raises(ValueError, match=r"passes values must be whole numbers; got '1\.5'"):
        parse_sweep_values("passes", "1.5")
    with pytest.raises(
        ValueError, match="border values must be inside or mirror or nearest or wrap"
    ):
        parse_sweep_values("border", "outside")
    with pytest.raises(ValueError, match="include_centre values must be true or false"):
        parse_sweep_values("include_centre", "maybe")
    with pytest.raises(ValueError, match="at least one value"):
        parse_sweep_values("seed", " , ")
    with pytest.raises(ValueError, match="cannot sweep 'tones'"):
        parse_sweep_values("tones", "1")


@pytest.mark.parametrize(
    "parameter, current, text",
    [
        ("variance_threshold", 0.5, "0.47, 0.5, 0.53"),  # Fig. 3
        ("variance_threshold", 0.04, "0.02, 0.04, 0.06"),
        ("mean_threshold", 0.01, "0, 0.01, 0.03"),  # never below 0
        ("passes", 4, "1, 2, 4, 8"),
        ("seed", 7, "0, 1, 2"),
        ("tone_ranges", 3, "2, 3, 5"),
        ("max_tries", 10, "1, 10, 100"),
        ("include_centre", False, "false, true"),
        ("scan", "raster", "raster, serpentine, checkerboard"),
    ],
)
def test_default_sweep_text(parameter, current, text):
    assert default_sweep_text(parameter, current) == text


@pytest.mark.parametrize("preset", list(presets.PRESETS))
def test_every_default_sweep_parses_and_every_value_is_valid(preset):
    fields = preset_field_values(preset, FIELDS)
    for parameter in SWEEP_PARAMETERS:
        current = 0 if parameter == "seed" else fields[parameter]
        values = parse_sweep_values(parameter, default_sweep_text(parameter, current))
        assert len(values) >= 2, parameter
        if parameter != "seed":
            for value in values:
                api.resolve_parameters(preset, **{parameter: value})


def test_tone_limits_follow_the_contrast_limits_or_the_typed_values():
    assert tone_limits((0.2, 0.8)) == (0.2, 0.8)
    assert tone_limits((np.uint16(10), np.uint16(900)), ("5", "1")) == (10.0, 900.0)
    assert tone_limits(None, ("0", "2")) == (0.0, 2.0)
    assert tone_limits(None, (1, 3.5)) == (1.0, 3.5)
    with pytest.raises(ValueError, match="tone limits must be numbers, got 'a' and '2'"):
        tone_limits(None, ("a", "2"))
    with pytest.raises(ValueError, match=r"low < high, got \(5.0, 1.0\)"):
        tone_limits(None, ("5", "1"))
    with pytest.raises(ValueError, match="finite"):
        tone_limits(None, ("nan", "1"))
    with pytest.raises(ValueError, match="low < high"):
        tone_limits((3.0, 3.0))
    assert tone_limit_text((0.1, 1234567.0)) == ("0.1", "1.23457e+06")


def test_result_name_lists_the_key_parameters():
    assert result_name("cell", "single", 4, "labyrinth", {}, 0) == (
        "cell · labyrinth · 4 passes · preset labyrinth"
    )
    name = result_name("cell", "stack", 1, "paper", {"variance_threshold": 0.47}, 3)
    assert name == "cell · stack · 1 pass · preset paper · V=0.47 · seed 3"


def test_result_name_of_sweeps_edits_and_planes():
    values = [0.03, 0.04, 0.05, 0.06, 0.07]
    assert result_name("cell", "sweep", 4, "labyrinth", {}, 0, ("variance_threshold", values)) == (
        "cell · sweep variance_threshold 0.03, 0.04, 0.05, 0.06 … · 4 passes · preset labyrinth"
    )
    assert result_name("cell", "sweep", 4, "paper", {}, 0, ("passes", [1, 2])) == (
        "cell · sweep passes 1, 2 · preset paper"
    )
    assert result_name("cell", "sweep", 1, "paper", {}, 5, ("seed", [0, 1])) == (
        "cell · sweep seed 0, 1 · 1 pass · preset paper"
    )
    edits = {
        "mean_threshold": 0.2,
        "passes": 3,  # in the pass count already
        "include_centre": True,
        "border": "wrap",
        "scan": "serpentine",
    }
    assert result_name("cell", "single", 3, "paper", edits, 0, plane_label="t=2") == (
        "cell · labyrinth · 3 passes · preset paper · t=0.2, include_centre=true, border=wrap … "
        "· t=2"
    )


def test_plane_label_names_the_axes():
    assert plane_label(("-3", "-2", "-1"), (2,)) == "axis 0=2"
    assert plane_label(("t", "z", "y", "x"), (2, 5)) == "t=2, z=5"
    assert plane_label(("t", "y", "x"), ()) == ""


@pytest.mark.parametrize(
    "value, text",
    [
        (float("nan"), "–"),
        (float("inf"), "–"),
        (123.456, "123"),
        (-250.4, "-250"),
        (99.94, "99.9"),
        (0.012345, "0.0123"),
        (1234567.0, "1.23e+06"),
        (0.0, "0"),
    ],
)
def test_format_metric(value, text):
    assert format_metric(value) == text


def test_metrics_table_content():
    headers = metric_row_headers()
    assert len(headers) == len(METRIC_ROWS)
    assert headers[0] == (
        "edge enhancement",
        "edge_enhancement: " + metrics.edge_enhancement.__doc__.strip().splitlines()[0],
    )
    assert headers[-1] == ("changed %", "changed: Pixels this pass changed, in percent.")
    rows = [
        {"pass": pass_number, **{key: 0.5 * pass_number for key, _, _ in METRIC_ROWS}}
        for pass_number in (1, 2)
    ]
    rows[1]["wall_width"] = 250.0
    column_headers, cells = metric_cells(rows)
    assert column_headers == ["1", "2"]
    assert cells[0] == ["0.5", "1"]
    assert cells[2] == ["0.5", "250"]  # wall width
    assert len(cells) == len(METRIC_ROWS)


def test_diagnostics_record_is_plain_json():
    counts = np.array([(1, 3), (2, 4)], dtype=[("redrawn", np.int64), ("kept", np.int64)])
    record = diagnostics_record(counts)
    assert record == {"shape": [2], "counts": {"redrawn": [1, 2], "kept": [3, 4]}}
    assert json.loads(json.dumps(record)) == record
    assert diagnostics_record(None) is None


# -- presets and overrides ---------------------------------------------------------------------


def test_overrides_are_the_fields_that_differ_from_the_preset():
    fields = preset_field_values("paper", FIELDS)
    assert fields["tone_ranges"] == 3 and fields["variance_threshold"] == 0.5
    assert overrides("paper", fields) == {}
    assert edited_text({}) == "as the preset"
    nearly = dict(fields, variance_threshold=0.5 + 1e-12)  # a spin box's rounding
    assert overrides("paper", nearly) == {}
    edited = dict(fields, scan="serpentine", variance_threshold=0.47, tone_ranges=4)
    assert overrides("paper", edited) == {
        "variance_threshold": 0.47,
        "tone_ranges": 4,
        "scan": "serpentine",
    }
    assert (
        edited_text(overrides("paper", edited)) == "edited: variance_threshold, tone_ranges, scan"
    )
    labyrinth = preset_field_values("labyrinth", ["variance_threshold", "passes", "scan"])
    assert labyrinth == {"variance_threshold": 0.04, "passes": 4, "scan": "raster"}
    assert overrides("labyrinth", {"passes": 1}) == {"passes": 1}


# -- planes and steps --------------------------------------------------------------------------


def test_visible_plane_is_rounded_and_clipped():
    assert visible_plane([2.4, -1.0, 7.6], (5, 3, 6)) == (2, 0, 5)
    assert visible_plane([], ()) == ()


@pytest.mark.parametrize(
    "shape, index, rgb, offset",
    [
        ((4, 5, 8, 8), (2, 3), False, 13),  # 2 * 5 + 3
        ((4, 8, 8, 3), (2,), True, 6),  # every channel is a plane of the API
        ((4, 8, 8, 4), (1,), True, 4),
        ((4, 8, 8), (0,), False, 0),
    ],
)
def test_plane_offset_is_the_flat_index_of_the_plane(shape, index, rgb, offset):
    assert plane_offset(shape, index, rgb) == offset


@pytest.mark.parametrize(
    "shape, n_leading, rgb, one_plane, passes, stack_passes, total",
    [
        ((3, 32, 32), 1, False, False, [2], 0, 7),  # 3 planes x 2 passes + assembling
        ((3, 32, 32), 1, False, False, [3], 3, 13),  # stack: and the metrics of 3 passes
        ((2, 8, 8, 4), 1, True, False, [2], 0, 13),  # RGBA: alpha is kept, 3 channels render
        ((2, 8, 8, 3), 1, True, True, [1], 0, 4),
        ((5, 8, 8), 1, False, True, [1, 2, 4], 0, 8),  # a sweep of passes on one plane
        ((8, 8), 0, False, False, [4], 0, 5),
    ],
)
def test_step_count(shape, n_leading, rgb, one_plane, passes, stack_passes, total):
    assert step_count(shape, n_leading, rgb, one_plane, passes, stack_passes) == total


# -- the plan ----------------------------------------------------------------------------------


def test_a_single_run_of_a_stack_renders_every_plane():
    data = _noise((3, 16, 16))
    plan = make_plan(LayerSnapshot.of(data, name="cell"), Choices(overrides={"passes": 2}))
    assert plan.function == "labyrinth" and plan.mode == "single"
    assert plan.data is data and plan.source_index is None and plan.lazy_source is None
    assert plan.total_steps == 3 * 2 + 1
    assert plan.name == "cell · labyrinth · 2 passes · preset labyrinth"
    expected = dict(
        api.resolve_parameters("labyrinth", passes=2).as_dict(),
        preset="labyrinth",
        seed=0,
        tone_limits=(0.0, 255.0),
        channel_axis=None,
    )
    assert plan.arguments == expected
    record = plan.layer_kwargs["metadata"][METADATA_KEY]
    assert record == {
        "version": napari_labyrinth.__version__,
        "mode": "single",
        "function": "labyrinth",
        "arguments": dict(expected, tone_limits=[0.0, 255.0]),
        "source_layer": "cell",
        "source_shape": [3, 16, 16],
        "source_dtype": "uint8",
        "source_index": None,
        "preset": "labyrinth",
        "overrides": {"passes": 2},
        "parameters": api.resolve_parameters("labyrinth", passes=2).as_dict(),
        "seed": 0,
        "tone_limits": [0.0, 255.0],
        "sweep": None,
        "lazy": False,
    }


def test_tone_limits_of_a_plan_follow_the_contrast_limits_unless_typed():
    snapshot = LayerSnapshot.of(_noise((8, 8), np.uint16), contrast_limits=(1000, 60000))
    assert make_plan(snapshot, Choices()).arguments["tone_limits"] == (1000.0, 60000.0)
    typed = make_plan(snapshot, Choices(tone_limits=("10", "20")))
    assert typed.arguments["tone_limits"] == (10.0, 20.0)
    with pytest.raises(ValueError, match="low < high"):
        make_plan(snapshot, Choices(tone_limits=("20", "10")))


@pytest.mark.parametrize(
    "parameter, text, values, removed",
    [
        ("variance_threshold", "0.05, 0.08", [0.05, 0.08], {"variance_threshold"}),
        ("tone_ranges", "2 4", [2, 4], {"tone_ranges", "tones"}),
        ("seed", "1, 2, 3", [1, 2, 3], {"seed"}),
        ("passes", "1, 3", [1, 3], {"passes"}),
    ],
)
def test_a_sweep_calls_labyrinth_sweep_without_the_swept_parameter(
    parameter, text, values, removed
):
    snapshot = LayerSnapshot.of(_noise((2, 8, 8)))
    choices = Choices(
        mode="sweep", preset="paper", sweep_parameter=parameter, sweep_text=text, seed=4
    )
    plan = make_plan(snapshot, choices)
    assert plan.function == "labyrinth_sweep"
    assert plan.arguments["parameter"] == parameter and plan.arguments["values"] == values
    assert removed.isdisjoint(plan.arguments)
    assert plan.layer_kwargs["axis_labels"][0] == parameter
    record = plan.layer_kwargs["metadata"][METADATA_KEY]
    assert record["sweep"] == {"parameter": parameter, "values": values}
    passes_per_run = values if parameter == "passes" else [1] * len(values)  # paper: 1 pass
    assert plan.total_steps == 2 * sum(passes_per_run) + 1
    steps, _ = _drive(plan)
    assert steps == list(range(1, plan.total_steps)) + [plan.total_steps]


def test_bad_choices_are_reported_by_the_plan():
    snapshot = LayerSnapshot.of(_noise((8, 8)))
    with pytest.raises(ValueError, match="choose an image layer"):
        make_plan(None, Choices())
    with pytest.raises(ValueError, match="'big' is a multiscale layer"):
        make_plan(LayerSnapshot.of(_noise((8, 8)), name="big", multiscale=True), Choices())
    with pytest.raises(ValueError, match="mode must be one of"):
        make_plan(snapshot, Choices(mode="all"))
    with pytest.raises(ValueError, match="values must be numbers"):
        make_plan(snapshot, Choices(mode="sweep", sweep_text="a, b"))
    with pytest.raises(ValueError, match="variance_threshold"):  # checked before the run
        make_plan(snapshot, Choices(mode="sweep", sweep_text="0.04, -1"))
    with pytest.raises((TypeError, ValueError), match="passes"):
        make_plan(snapshot, Choices(overrides={"passes": -1}))


def test_the_current_plane_is_rendered_alone_at_its_place():
    data = _noise((4, 16, 16), np.float32)
    snapshot = LayerSnapshot.of(
        data,
        name="movie",
        scale=(10.0, 1.0, 1.0),
        translate=(3.0, 0.0, 0.0),
        contrast_limits=(0.0, 1.0),
        visible_index=(2,),
    )
    plan = make_plan(snapshot, Choices(planes=CURRENT_PLANE))
    assert plan.source_index == (2,)
    np.testing.assert_array_equal(plan.data, data[2])
    assert plan.arguments["plane_offset"] == 2
    assert plan.total_steps == 1 * 4 + 1  # one plane, the preset's 4 passes
    assert plan.name.endswith(" · axis 0=2")
    np.testing.assert_allclose(plan.layer_kwargs["translate"], (3.0 + 2 * 10.0, 0.0, 0.0))
    record = plan.layer_kwargs["metadata"][METADATA_KEY]
    assert record["source_index"] == [2] and record["arguments"]["plane_offset"] == 2
    # a 2-D layer has no current plane to choose
    flat = make_plan(LayerSnapshot.of(data[0]), Choices(planes=CURRENT_PLANE))
    assert flat.source_index is None and "plane_offset" not in flat.arguments


def test_rgb_layers_render_each_channel_and_keep_no_colormap():
    snapshot = LayerSnapshot.of(_noise((2, 8, 8, 3)), rgb=True, visible_index=(1,))
    assert snapshot.ndim == 3
    plan = make_plan(snapshot, Choices(planes=CURRENT_PLANE, overrides={"passes": 1}))
    assert plan.arguments["channel_axis"] == -1
    assert plan.arguments["plane_offset"] == 3
    assert plan.total_steps == 3 + 1
    assert plan.layer_kwargs["rgb"] is True and "colormap" not in plan.layer_kwargs
    grey = make_plan(LayerSnapshot.of(_noise((8, 8)), colormap="magma"), Choices())
    assert grey.layer_kwargs["colormap"] == "magma"


def test_lazy_data_plans_the_visible_plane_and_keeps_the_rest_lazy():
    da = pytest.importorskip("dask.array")
    source = da.from_array(_noise((4, 16, 16)), chunks=(1, 16, 16))
    plan = make_plan(LayerSnapshot.of(source, visible_index=(3,)), Choices(mode="stack"))
    assert plan.source_index == (3,) and plan.lazy_source is source
    assert plan.arguments["plane_offset"] == 3
    assert plan.total_steps == 4 + 4 + 1  # the visible plane's 4 passes, their metrics, assembling
    record = plan.layer_kwargs["metadata"][METADATA_KEY]
    assert record["lazy"] is True and record["source_index"] is None
    assert "plane_offset" not in record["arguments"]  # the record renders the whole data


def test_result_layer_keeps_the_input_transforms_and_display():
    snapshot = LayerSnapshot.of(
        _noise((8, 8)),
        scale=(2.0, 3.0),
        translate=(5.0, 7.0),
        shear=(0.5,),
        affine=[[1.0, 0.0, 4.0], [0.0, 1.0, 6.0], [0.0, 0.0, 1.0]],
        units=("micrometer", "micrometer"),
        axis_labels=("y", "x"),
        contrast_limits=(10, 200),
        gamma=0.8,
        opacity=0.5,
        blending="additive",
        interpolation2d="linear",
        colormap="viridis",
    )
    single = result_layer_kwargs(snapshot, "out", None, None)
    np.testing.assert_array_equal(single["scale"], (2.0, 3.0))
    np.testing.assert_array_equal(single["translate"], (5.0, 7.0))
    np.testing.assert_array_equal(single["shear"], (0.5,))
    np.testing.assert_array_equal(single["affine"], snapshot.affine)
    assert single["units"] == ("micrometer", "micrometer") and single["axis_labels"] == ("y", "x")
    assert single["contrast_limits"] == [10, 200]
    assert (single["gamma"], single["opacity"], single["blending"]) == (0.8, 0.5, "additive")
    assert single["interpolation2d"] == "linear" and single["colormap"] == "viridis"

    stack = result_layer_kwargs(snapshot, "out", "pass", None)
    np.testing.assert_array_equal(stack["scale"], (1.0, 2.0, 3.0))
    np.testing.assert_array_equal(stack["translate"], (0.0, 5.0, 7.0))
    np.testing.assert_array_equal(stack["rotate"], np.eye(3))
    np.testing.assert_array_equal(stack["shear"], (0.0, 0.0, 0.5))  # (0,1), (0,2), (1,2)
    np.testing.assert_array_equal(
        stack["affine"],
        [[1, 0, 0, 0], [0, 1, 0, 4], [0, 0, 1, 6], [0, 0, 0, 1]],
    )
    assert stack["units"] == ("pixel", "micrometer", "micrometer")
    assert stack["axis_labels"] == ("pass", "y", "x")


def test_an_extra_axis_embeds_rotation_and_shear_matrices():
    rotate = [[0.0, -1.0], [1.0, 0.0]]
    shear = [[1.0, 0.0], [0.5, 1.0]]  # lower triangular: napari keeps the matrix
    snapshot = LayerSnapshot.of(_noise((8, 8)), rotate=rotate, shear=shear)
    kwargs = result_layer_kwargs(snapshot, "out", "variance_threshold", None)
    np.testing.assert_array_equal(kwargs["rotate"], [[1, 0, 0], [0, 0, -1], [0, 1, 0]])
    np.testing.assert_array_equal(kwargs["shear"], [[1, 0, 0], [0, 1, 0], [0, 0.5, 1]])


def test_a_plane_rendered_alone_moves_by_the_data_to_physical_image_of_its_index():
    rotate = [[0.0, -1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 1.0]]  # a quarter turn of axes 0, 1
    snapshot = LayerSnapshot.of(
        _noise((4, 8, 8)), scale=(10.0, 1.0, 1.0), translate=(3.0, 0.0, 0.0), rotate=rotate
    )
    np.testing.assert_allclose(data_to_physical(snapshot), [[0, -1, 0], [10, 0, 0], [0, 0, 1]])
    kwargs = result_layer_kwargs(snapshot, "out", None, (2,))
    np.testing.assert_allclose(kwargs["translate"], (3.0, 20.0, 0.0))
    # shear (0, 1) = 0.5 moves the plane (1, 2) of a 4-D layer to (1 + 0.5 * 2, 2)
    sheared = LayerSnapshot.of(_noise((2, 3, 8, 8)), shear=(0.5, 0, 0, 0, 0, 0))
    kwargs = result_layer_kwargs(sheared, "out", "pass", (1, 2))
    np.testing.assert_allclose(kwargs["translate"], (0.0, 2.0, 2.0, 0.0, 0.0))


# -- the run -----------------------------------------------------------------------------------


def test_a_run_yields_every_step_and_reproduces_through_the_api():
    data = _noise((3, 16, 16))
    plan = make_plan(LayerSnapshot.of(data), Choices(overrides={"passes": 2}, seed=5))
    steps, outcome = _drive(plan)
    assert isinstance(outcome, Outcome)
    assert len(steps) == plan.total_steps == 7
    assert steps[-1] == plan.total_steps
    assert outcome.metric_rows == [] and outcome.seconds >= 0
    np.testing.assert_array_equal(outcome.data, api.labyrinth(data, passes=2, seed=5))
    layer_data, kwargs = result_layer(plan, outcome)
    assert layer_data is outcome.data
    np.testing.assert_array_equal(layer_data, _reproduce(kwargs, data))
    record = kwargs["metadata"][METADATA_KEY]
    assert len(record["diagnostics"]["counts"]["redrawn"]) == 2  # one entry per pass
    assert record["diagnostics_scope"] == "all planes"
    assert "diagnostics" not in plan.layer_kwargs["metadata"][METADATA_KEY]  # plan untouched


def test_a_stack_run_measures_every_pass_on_the_visible_plane():
    data = _noise((2, 48, 48))
    snapshot = LayerSnapshot.of(data, visible_index=(1,))
    plan = make_plan(snapshot, Choices(mode="stack", overrides={"passes": 3}))
    steps, outcome = _drive(plan)
    assert len(steps) == plan.total_steps == 2 * 3 + 3 + 1
    assert outcome.data.shape == (4, 2, 48, 48)
    rows = outcome.metric_rows
    assert [row["pass"] for row in rows] == [1, 2, 3]
    assert {key for key, _, _ in METRIC_ROWS} <= set(rows[0])
    for row in rows:
        after, before = outcome.data[row["pass"], 1], outcome.data[row["pass"] - 1, 1]
        assert row["changed"] == pytest.approx(100.0 * np.mean(after != before))
    described = metrics.describe(data[1].astype(float), outcome.data[2, 1].astype(float))
    assert rows[1]["edge_enhancement"] == pytest.approx(described["edge_enhancement"])
    _, kwargs = result_layer(plan, outcome)
    assert kwargs["metadata"][METADATA_KEY]["metrics"] == rows


def test_metrics_of_a_plane_too_small_for_their_windows_are_nan():
    plan = make_plan(LayerSnapshot.of(_noise((2, 2))), Choices(mode="stack"))
    _, outcome = _drive(plan)
    assert all(np.isnan(row["edge_enhancement"]) for row in outcome.metric_rows)
    assert all(np.isfinite(row["changed"]) for row in outcome.metric_rows)


@pytest.mark.parametrize("mode", ["single", "stack"])
def test_a_plane_rendered_alone_gets_size_one_axes(mode):
    data = _noise((4, 16, 16), np.float32)
    snapshot = LayerSnapshot.of(data, visible_index=(2,), contrast_limits=(0.0, 1.0))
    plan = make_plan(snapshot, Choices(mode=mode, planes=CURRENT_PLANE, overrides={"passes": 2}))
    steps, outcome = _drive(plan)
    assert len(steps) == plan.total_steps
    layer_data, kwargs = result_layer(plan, outcome)
    assert layer_data.shape == ((1, 16, 16) if mode == "single" else (3, 1, 16, 16))
    record = kwargs["metadata"][METADATA_KEY]
    assert record["diagnostics_scope"] == "the rendered plane"
    whole = getattr(api, plan.function)(data, passes=2, tone_limits=(0.0, 1.0))
    expected = whole[2] if mode == "single" else whole[:, 2]
    np.testing.assert_array_equal(outcome.data, expected)
    reproduced = _reproduce(kwargs, data).reshape(layer_data.shape)
    np.testing.assert_array_equal(np.asarray(layer_data), reproduced)


def test_a_sweep_records_the_diagnostics_of_every_value():
    data = _noise((16, 16))
    choices = Choices(mode="sweep", sweep_parameter="scan", sweep_text="raster serpentine")
    plan = make_plan(LayerSnapshot.of(data), choices)
    _, outcome = _drive(plan)
    layer_data, kwargs = result_layer(plan, outcome)
    assert layer_data.shape == (2, 16, 16)
    np.testing.assert_array_equal(layer_data[1], api.labyrinth(data, scan="serpentine"))
    assert len(kwargs["metadata"][METADATA_KEY]["diagnostics"]) == 2


def test_a_seed_sweep_renders_with_each_seed():
    data = _noise((16, 16))
    choices = Choices(mode="sweep", seed=9, sweep_parameter="seed", sweep_text="1 2")
    plan = make_plan(LayerSnapshot.of(data), choices)
    assert "seed" not in plan.arguments
    assert plan.layer_kwargs["metadata"][METADATA_KEY]["seed"] == 9
    assert plan.name == "image · sweep seed 1, 2 · 4 passes · preset labyrinth"
    _, outcome = _drive(plan)
    layer_data, kwargs = result_layer(plan, outcome)
    np.testing.assert_array_equal(layer_data[1], api.labyrinth(data, seed=2))
    np.testing.assert_array_equal(layer_data, _reproduce(kwargs, data))


@pytest.mark.parametrize("mode", ["single", "stack", "sweep"])
def test_a_lazy_run_loads_the_visible_plane_only(mode):
    da = pytest.importorskip("dask.array")
    data = _noise((5, 16, 16))
    loaded = []

    def count(block, block_info=None):
        loaded.append(block_info[0]["array-location"][0][0])
        return block

    lazy = da.from_array(data, chunks=(1, 16, 16)).map_blocks(count, dtype=data.dtype)
    snapshot = LayerSnapshot.of(lazy, visible_index=(3,))
    choices = Choices(mode=mode, overrides={"passes": 2}, sweep_text="0.03, 0.05")
    plan = make_plan(snapshot, choices)
    loaded.clear()
    steps, outcome = _drive(plan)
    assert set(loaded) == {3}, "only the visible plane may be loaded"
    assert len(steps) == plan.total_steps
    assert isinstance(outcome.data, da.Array)
    layer_data, kwargs = result_layer(plan, outcome)
    record = kwargs["metadata"][METADATA_KEY]
    assert record["diagnostics_scope"] == "the plane on screen (the others render lazily)"
    assert record["diagnostics_plane"] == [3]
    np.testing.assert_array_equal(np.asarray(layer_data), _reproduce(kwargs, data))


@pytest.fixture
def slow_api(monkeypatch):
    """Make every plane and pass of the API take at least 20 ms, so that a run can be cancelled."""

    def slowed(function):
        def wrapper(image, *, progress=None, **options):
            def slow_progress(done, total):
                time.sleep(0.02)
                progress(done, total)

            return function(image, progress=slow_progress, **options)

        return wrapper

    for name in ("labyrinth", "labyrinth_stack", "labyrinth_sweep"):
        monkeypatch.setattr(api, name, slowed(getattr(api, name)))


def test_cancel_stops_a_run_at_its_next_step_and_returns_nothing(slow_api):
    plan = make_plan(LayerSnapshot.of(_noise((10, 32, 32))), Choices(overrides={"passes": 3}))
    steps, outcome = _drive(plan, on_step=lambda _: plan.cancel.set())
    assert outcome is None
    assert len(steps) <= 2  # stopped at the next plane or pass
    for thread in threading.enumerate():  # the helper thread ends too
        if thread.name == "napari-labyrinth render":
            thread.join(timeout=60)
            assert not thread.is_alive()


def test_a_run_cancelled_before_it_starts_yields_nothing():
    plan = make_plan(LayerSnapshot.of(_noise((8, 8))), Choices())
    plan.abort_requested = lambda: True  # napari's activity panel asked to stop
    assert _drive(plan) == ([], None)


def test_api_errors_come_back_as_a_message():
    data = np.arange(32 * 32, dtype=np.int64).reshape(32, 32)
    plan = make_plan(LayerSnapshot.of(data, contrast_limits=(0, 1023)), Choices())
    steps, outcome = _drive(plan)
    assert steps == []
    assert isinstance(outcome, Failure)
    assert "dtype int64 is not supported" in outcome.message


def test_splice_plane_replaces_one_plane_of_a_lazy_array():
    da = pytest.importorskip("dask.array")
    lazy = da.zeros((3, 4, 2, 2), chunks=(1, 1, 2, 2), dtype=int)
    plane = np.array([[1, 2], [3, 4]])
    spliced = splice_plane(lazy, plane, (1, 3), 0)
    expected = np.zeros((3, 4, 2, 2), dtype=int)
    expected[1, 3] = plane
    np.testing.assert_array_equal(spliced.compute(), expected)
    # a stack: the plane of every pass, on the axis after the pass axis
    passes = np.arange(8).reshape(2, 2, 2)
    spliced = splice_plane(da.zeros((2, 3, 2, 2), dtype=int), passes, (2,), 1)
    expected = np.zeros((2, 3, 2, 2), dtype=int)
    expected[:, 2] = passes
    np.testing.assert_array_equal(spliced.compute(), expected)


def test_layer_snapshot_defaults_are_napari_defaults():
    snapshot = LayerSnapshot.of(np.zeros((3, 8, 8, 3)), rgb=True)
    assert snapshot.ndim == 3
    assert snapshot.axis_labels == ("-3", "-2", "-1")
    assert snapshot.units == ("pixel",) * 3
    assert snapshot.shear.shape == (3,) and snapshot.affine.shape == (4, 4)
    assert snapshot.visible_index == (0,)
    with pytest.raises(dataclasses.FrozenInstanceError):
        snapshot.name = "other"
