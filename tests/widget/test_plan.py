"""What a widget run will do, and the run itself, without napari or Qt.

A layer is described by a :class:`LayerSnapshot`, the user's choices by
:class:`Choices`; the run generator is driven directly, as the napari worker
drives it.
"""

from __future__ import annotations

import numpy as np
import pytest

import napari_labyrinth
from napari_labyrinth import api, metrics, provenance
from napari_labyrinth.core import presets
from napari_labyrinth.widget.choices import (
    CURRENT_PLANE,
    Choices,
    LayerSnapshot,
    overrides,
    preset_field_values,
    preview_choices,
    visible_plane,
)
from napari_labyrinth.widget.layer_kwargs import (
    METADATA_KEY,
    data_to_physical,
    result_layer_kwargs,
)
from napari_labyrinth.widget.plan import make_plan, run_steps
from napari_labyrinth.widget.text import (
    METRIC_ROWS,
    SWEEP_PARAMETERS,
    default_sweep_text,
    edited_text,
    format_metric,
    metric_cells,
    metric_row_headers,
    parse_sweep_values,
    plane_label,
    result_description,
    result_name,
    sweep_label,
    tone_limit_text,
    tone_limits,
)

from .plan_helpers import drive, noise

FIELDS = [name for name in presets.PRESETS[presets.DEFAULT_PRESET] if name != "tones"]


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
    # the messages of the parameter table, as everywhere a value is typed
    with pytest.raises(ValueError, match=r"passes must be a whole number; got '1\.5'"):
        parse_sweep_values("passes", "1.5")
    with pytest.raises(ValueError, match="passes must be between 0 and 1000, got 1001"):
        parse_sweep_values("passes", "1 1001")
    with pytest.raises(ValueError, match="border must be one of 'inside', 'mirror', 'nearest'"):
        parse_sweep_values("border", "outside")
    with pytest.raises(ValueError, match="include_centre must be true or false"):
        parse_sweep_values("include_centre", "maybe")
    with pytest.raises(ValueError, match="at least one value"):
        parse_sweep_values("seed", " , ")
    with pytest.raises(ValueError, match="cannot sweep 'tones'"):
        parse_sweep_values("tones", "1")


@pytest.mark.parametrize(
    ("text", "message"),
    [
        # "0.03,,0.05" swept [0.03, 0.05], the empty value skipped, as the command line did
        ("0.03,,0.05", "value 2 of '0.03,,0.05' is empty (between 0.03 and 0.05)"),
        ("0.03, 0.05, ", "value 3 of '0.03, 0.05,' is empty (after 0.05)"),
        (", 0.03", "value 1 of ', 0.03' is empty (before 0.03)"),
        ("0.03:0.05", "got '0.03:0.05': a sweep has no range syntax"),
    ],
)
def test_a_sweep_field_with_an_empty_value_or_a_range_is_refused_before_the_run(text, message):
    snapshot = LayerSnapshot.of(noise((8, 8)), name="cell")
    with pytest.raises(ValueError, match="^variance_threshold") as error:
        make_plan(snapshot, Choices(mode="sweep", sweep_text=text))
    assert message in str(error.value)


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
    for typed in (("5",), ("1", "2", "3"), 5):
        with pytest.raises(ValueError, match=r"must be a pair of numbers \(low, high\)"):
            tone_limits(None, typed)
    assert tone_limit_text((0.1, 1234567.0)) == ("0.1", "1.23457e+06")


def test_result_name_lists_the_key_parameters():
    assert result_description("cell", "single", 4, "labyrinth", {}, 0) == (
        "cell · labyrinth · 4 passes · preset labyrinth"
    )
    name = result_description("cell", "stack", 1, "paper", {"variance_threshold": 0.47}, 3)
    assert name == "cell · stack · 1 pass · preset paper · V=0.47 · seed 3"


def test_result_name_of_sweeps_edits_and_planes():
    values = [0.03, 0.04, 0.05, 0.06, 0.07]
    assert result_description(
        "cell", "sweep", 4, "labyrinth", {}, 0, ("variance_threshold", values)
    ) == ("cell · sweep variance_threshold 0.03, 0.04, 0.05, 0.06 … · 4 passes · preset labyrinth")
    assert result_description("cell", "sweep", 4, "paper", {}, 0, ("passes", [1, 2])) == (
        "cell · sweep passes 1, 2 · preset paper"
    )
    assert result_description("cell", "sweep", 1, "paper", {}, 5, ("seed", [0, 1])) == (
        "cell · sweep seed 0, 1 · 1 pass · preset paper"
    )
    edits = {
        "mean_threshold": 0.2,
        "passes": 3,  # in the pass count already
        "include_centre": True,
        "border": "wrap",
        "scan": "serpentine",
    }
    assert result_description("cell", "single", 3, "paper", edits, 0, plane_label="t=2") == (
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
        (99.96, "100"),  # rounded up to 3 digits: no point left dangling ("100.")
        (-99.97, "-100"),
        (0.012345, "0.0123"),
        (1234567.0, "1.23e+06"),
        (0.0, "0"),
        (0.32, "0.320"),
        (8.6, "8.60"),
        (1.0, "1.00"),
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
    assert cells[0] == ["0.500", "1.00"]
    assert cells[2] == ["0.500", "250"]  # wall width
    assert len(cells) == len(METRIC_ROWS)


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
    "shape, rgb, passes, stack_passes, total",
    [
        ((3, 32, 32), False, [2], 0, 7),  # 3 planes x 2 passes + assembling
        ((3, 32, 32), False, [3], 3, 13),  # stack: and the metrics of 3 passes
        ((2, 8, 8, 4), True, [2], 0, 5),  # RGBA: alpha is kept, the luminance renders
        ((8, 8, 3), True, [1], 0, 2),  # one RGB plane rendered alone
        ((8, 8), False, [1, 2, 4], 0, 8),  # a sweep of passes on one plane
        ((8, 8), False, [4], 0, 5),
    ],
)
def test_run_steps(shape, rgb, passes, stack_passes, total):
    assert run_steps(shape, rgb, passes, stack_passes) == total


# -- the plan ----------------------------------------------------------------------------------


def test_a_single_run_of_a_stack_renders_every_plane():
    data = noise((3, 16, 16))
    plan = make_plan(LayerSnapshot.of(data, name="cell"), Choices(overrides={"passes": 2}))
    assert plan.function == "labyrinth" and plan.mode == "single"
    assert plan.data is data and plan.source_index is None and plan.lazy_source is None
    assert plan.total_steps == 3 * 2 + 1
    assert plan.name == "cell · labyrinth"
    assert plan.description == "cell · labyrinth · 2 passes · preset labyrinth"
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
        "description": "cell · labyrinth · 2 passes · preset labyrinth",
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
        "schema": provenance.SCHEMA,
        "input": {"name": "cell", "sha256": None, "shape": [3, 16, 16], "dtype": "uint8"},
    }


def test_tone_limits_of_a_plan_follow_the_contrast_limits_unless_typed():
    snapshot = LayerSnapshot.of(noise((8, 8), np.uint16), contrast_limits=(1000, 60000))
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
    snapshot = LayerSnapshot.of(noise((2, 8, 8)))
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
    steps, _ = drive(plan)
    assert steps == list(range(1, plan.total_steps)) + [plan.total_steps]


def test_bad_choices_are_reported_by_the_plan():
    snapshot = LayerSnapshot.of(noise((8, 8)))
    with pytest.raises(ValueError, match="choose an image layer"):
        make_plan(None, Choices())
    with pytest.raises(ValueError, match="mode must be one of"):
        make_plan(snapshot, Choices(mode="all"))
    with pytest.raises(ValueError, match="variance_threshold must be a number; got 'a'"):
        make_plan(snapshot, Choices(mode="sweep", sweep_text="a, b"))
    with pytest.raises(ValueError, match="variance_threshold"):  # checked before the run
        make_plan(snapshot, Choices(mode="sweep", sweep_text="0.04, -1"))
    with pytest.raises((TypeError, ValueError), match="passes"):
        make_plan(snapshot, Choices(overrides={"passes": -1}))
    with pytest.raises(TypeError, match="seed must be an integer, got 2.7"):  # was seed 2
        make_plan(snapshot, Choices(seed=2.7))
    with pytest.raises(ValueError, match="seed must be between 0 and"):
        make_plan(snapshot, Choices(seed=-1))
    assert make_plan(snapshot, Choices(seed=np.int64(3))).arguments["seed"] == 3


def test_the_current_plane_is_rendered_alone_at_its_place():
    data = noise((4, 16, 16), np.float32)
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
    assert plan.name.endswith(" · axis 0=2") and plan.description.endswith(" · axis 0=2")
    np.testing.assert_allclose(plan.layer_kwargs["translate"], (3.0 + 2 * 10.0, 0.0, 0.0))
    record = plan.layer_kwargs["metadata"][METADATA_KEY]
    assert record["source_index"] == [2] and record["arguments"]["plane_offset"] == 2
    # a 2-D layer has no current plane to choose
    flat = make_plan(LayerSnapshot.of(data[0]), Choices(planes=CURRENT_PLANE))
    assert flat.source_index is None and "plane_offset" not in flat.arguments


def test_rgb_layers_render_each_channel_and_keep_no_colormap():
    snapshot = LayerSnapshot.of(noise((2, 8, 8, 3)), rgb=True, visible_index=(1,))
    assert snapshot.ndim == 3
    plan = make_plan(snapshot, Choices(planes=CURRENT_PLANE, overrides={"passes": 1}))
    assert plan.arguments["channel_axis"] == -1
    assert plan.arguments["plane_offset"] == 3
    assert plan.total_steps == 1 + 1  # one luminance plane, then assembling
    assert plan.layer_kwargs["rgb"] is True and "colormap" not in plan.layer_kwargs
    grey = make_plan(LayerSnapshot.of(noise((8, 8)), colormap="magma"), Choices())
    assert grey.layer_kwargs["colormap"] == "magma"


def test_lazy_data_plans_the_visible_plane_and_keeps_the_rest_lazy():
    da = pytest.importorskip("dask.array")
    source = da.from_array(noise((4, 16, 16)), chunks=(1, 16, 16))
    plan = make_plan(LayerSnapshot.of(source, visible_index=(3,)), Choices(mode="stack"))
    assert plan.source_index == (3,) and plan.lazy_source is source
    assert plan.arguments["plane_offset"] == 3
    assert plan.total_steps == 4 + 4 + 1  # the visible plane's 4 passes, their metrics, assembling
    record = plan.layer_kwargs["metadata"][METADATA_KEY]
    assert record["lazy"] is True and record["source_index"] is None
    assert "plane_offset" not in record["arguments"]  # the record renders the whole data


def test_result_layer_keeps_the_input_transforms_and_display():
    snapshot = LayerSnapshot.of(
        noise((8, 8)),
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
    snapshot = LayerSnapshot.of(noise((8, 8)), rotate=rotate, shear=shear)
    kwargs = result_layer_kwargs(snapshot, "out", "variance_threshold", None)
    np.testing.assert_array_equal(kwargs["rotate"], [[1, 0, 0], [0, 0, -1], [0, 1, 0]])
    np.testing.assert_array_equal(kwargs["shear"], [[1, 0, 0], [0, 1, 0], [0, 0.5, 1]])


def test_a_plane_rendered_alone_moves_by_the_data_to_physical_image_of_its_index():
    rotate = [[0.0, -1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 1.0]]  # a quarter turn of axes 0, 1
    snapshot = LayerSnapshot.of(
        noise((4, 8, 8)), scale=(10.0, 1.0, 1.0), translate=(3.0, 0.0, 0.0), rotate=rotate
    )
    np.testing.assert_allclose(data_to_physical(snapshot), [[0, -1, 0], [10, 0, 0], [0, 0, 1]])
    kwargs = result_layer_kwargs(snapshot, "out", None, (2,))
    np.testing.assert_allclose(kwargs["translate"], (3.0, 20.0, 0.0))
    # shear (0, 1) = 0.5 moves the plane (1, 2) of a 4-D layer to (1 + 0.5 * 2, 2)
    sheared = LayerSnapshot.of(noise((2, 3, 8, 8)), shear=(0.5, 0, 0, 0, 0, 0))
    kwargs = result_layer_kwargs(sheared, "out", "pass", (1, 2))
    np.testing.assert_allclose(kwargs["translate"], (0.0, 2.0, 2.0, 0.0, 0.0))


def test_a_sweep_of_an_edited_field_replaces_the_field_s_value():
    snapshot = LayerSnapshot.of(noise((16, 16)))
    edits = {"variance_threshold": 0.07, "passes": 1}
    choices = Choices(mode="sweep", overrides=edits, sweep_text="0.03, 0.05")
    plan = make_plan(snapshot, choices)
    assert "variance_threshold" not in plan.arguments
    assert plan.arguments["values"] == [0.03, 0.05] and plan.arguments["passes"] == 1
    _, outcome = drive(plan)
    np.testing.assert_array_equal(
        outcome.data[1],
        api.labyrinth(snapshot.data, passes=1, variance_threshold=0.05, tone_limits=(0, 255)),
    )


def test_result_names_are_short_and_sweep_labels_name_the_value():
    assert result_name("cell", "single") == "cell · labyrinth"
    assert result_name("cell", "stack", plane_label="t=3") == "cell · stack · t=3"
    assert result_name("cell", "sweep", "variance_threshold") == "cell · sweep V"
    assert result_name("cell", "sweep", "border") == "cell · sweep border"
    record = {"sweep": {"parameter": "variance_threshold", "values": [0.03, 0.04, 0.05]}}
    assert [sweep_label(record, step) for step in (0, 2, 9)] == [
        "V = 0.03",
        "V = 0.05",
        "V = 0.05",
    ]
    assert (
        sweep_label({"sweep": {"parameter": "scan", "values": ["raster"]}}, 0) == "scan = raster"
    )
    assert sweep_label({"sweep": None}, 0) == ""


def test_a_preview_renders_the_plane_on_screen_once_without_metrics():
    snapshot = LayerSnapshot.of(noise((3, 16, 16)), name="movie", visible_index=(2,))
    choices = Choices(mode="stack", sweep_text="0.03", overrides={"passes": 2})
    plan = make_plan(snapshot, preview_choices(choices))
    assert plan.mode == "single" and plan.source_index == (2,) and not plan.metrics
    assert plan.arguments["plane_offset"] == 2 and plan.total_steps == 2 + 1
