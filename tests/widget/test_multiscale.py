"""Multiscale layers without napari or Qt: the level rendered, where it sits, the result's levels.

A multiscale layer is a :class:`LayerSnapshot` whose ``data`` is its list of
levels, full level first; a preview renders the level on screen, a run the
full level, whose result gets the input's count of levels.
"""

from __future__ import annotations

import numpy as np
import pytest

from napari_labyrinth import api
from napari_labyrinth.io._pyramid import halved
from napari_labyrinth.widget.choices import CURRENT_PLANE, Choices, LayerSnapshot, preview_choices
from napari_labyrinth.widget.layer_kwargs import METADATA_KEY
from napari_labyrinth.widget.multiscale import (
    PREVIEW_GRID,
    PREVIEW_MARGIN,
    downsample_factors,
    level_snapshot,
    lower_levels,
    shown_level,
)
from napari_labyrinth.widget.plan import make_plan
from napari_labyrinth.widget.run import result_layer

from .plan_helpers import counting_lazy, drive, noise

LIMITS = (0.0, 65535.0)


def pyramid(full: np.ndarray, count: int = 3, axes=(-2, -1)) -> list[np.ndarray]:
    """``full`` and its levels halved in Y and X, as a multiscale layer holds them."""
    levels = [full]
    for _ in range(count - 1):
        levels.append(halved(levels[-1], axes))
    return levels


def multiscale(levels, **fields) -> LayerSnapshot:
    fields.setdefault("contrast_limits", LIMITS)
    return LayerSnapshot.of(levels, name="cam", multiscale=True, **fields)


#: The outcomes of the runs: a result rendered band by band reads its store on disk, which
#: is removed once its outcome is collected.
_KEPT: list = []


def run(plan):
    steps, outcome = drive(plan)
    assert steps == list(range(1, plan.total_steps + 1))
    _KEPT.append(outcome)
    return result_layer(plan, outcome)


def test_the_downsample_factors_are_napari_s_the_full_shape_over_the_level_s():
    levels = [np.zeros((5, 64, 48, 3)), np.zeros((5, 32, 24, 3)), np.zeros((5, 16, 12, 3))]
    np.testing.assert_array_equal(downsample_factors(levels, 3), [[1, 1, 1], [1, 2, 2], [1, 4, 4]])


def test_a_preview_renders_the_level_on_screen_placed_over_the_layer():
    levels = pyramid(noise((64, 64), np.uint16))
    fields = {"scale": (0.5, 0.25), "translate": (10.0, 20.0), "units": ("um", "um")}
    for shown in (0, 1, 2):
        snapshot = multiscale(levels, data_level=shown, **fields)
        assert shown_level(snapshot) == shown
        plan = make_plan(snapshot, preview_choices(Choices(overrides={"passes": 1})))
        assert plan.data is levels[shown] and plan.levels == 1
        kwargs = plan.layer_kwargs
        np.testing.assert_array_equal(kwargs["scale"], np.array([0.5, 0.25]) * 2**shown)
        np.testing.assert_array_equal(kwargs["translate"], (10.0, 20.0))
        assert kwargs["units"] == ("um", "um") and "multiscale" not in kwargs
        record = kwargs["metadata"][METADATA_KEY]
        assert record["source_level"] == shown and record["source_shape"] == [64 >> shown] * 2
        data, _ = run(plan)
        expected = api.labyrinth(levels[shown], passes=1, tone_limits=LIMITS)
        np.testing.assert_array_equal(data, expected)


@pytest.mark.parametrize(
    "overrides, band_by_band",
    [({"passes": 2}, True), ({"passes": 2, "scan": "checkerboard"}, False)],
    ids=["band by band", "in memory"],
)
def test_a_run_renders_the_full_level_and_makes_the_lower_levels_from_the_result(
    overrides, band_by_band
):
    levels = pyramid(noise((256, 256), np.uint16, seed=3))
    snapshot = multiscale(
        levels,
        data_level=2,  # what is on screen does not matter to a run
        scale=(0.5, 0.5),
        translate=(3.0, -4.0),
        axis_labels=("y", "x"),
        colormap="magma",
    )
    plan = make_plan(snapshot, Choices(overrides=overrides, seed=5))
    assert plan.data is levels[0] and plan.levels == 3
    assert (plan.streamed is not None) is band_by_band
    # in memory: two passes, two lower levels, assembling; band by band: one band
    assert plan.total_steps == (1 if band_by_band else 2 + 2 + 1)
    data, kwargs = run(plan)
    assert kwargs["multiscale"] is True and kwargs["name"] == "cam · labyrinth"
    full = api.labyrinth(levels[0], seed=5, tone_limits=LIMITS, **overrides)
    assert [level.shape for level in data] == [(256, 256), (128, 128), (64, 64)]
    np.testing.assert_array_equal(data[0], full)  # bit for bit
    np.testing.assert_array_equal(data[1], halved(full, (0, 1)))
    np.testing.assert_array_equal(data[2], halved(np.asarray(data[1]), (0, 1)))
    np.testing.assert_array_equal(kwargs["scale"], (0.5, 0.5))  # of the full level
    np.testing.assert_array_equal(kwargs["translate"], (3.0, -4.0))
    assert kwargs["axis_labels"] == ("y", "x") and kwargs["colormap"] == "magma"
    record = kwargs["metadata"][METADATA_KEY]
    assert record["source_level"] == 0 and record["levels"] == 3
    assert record["band_by_band"] is band_by_band
    assert record["source_shape"] == [256, 256] and record["source_layer"] == "cam"
    reproduced = getattr(api, record["function"])(levels[0], **record["arguments"])
    np.testing.assert_array_equal(data[0], reproduced)


@pytest.mark.parametrize("mode", ["single", "stack", "sweep"])
def test_every_mode_of_a_multiscale_stack_renders_its_full_level(mode):
    # z, y, x levels, z not downsampled (as ome-zarr writes them by default)
    levels = pyramid(noise((3, 64, 64), np.uint16, seed=1))
    snapshot = multiscale(levels, visible_index=(1,), scale=(2.0, 0.5, 0.5))
    choices = Choices(mode=mode, overrides={"passes": 2}, sweep_text="0.03, 0.05")
    data, kwargs = run(make_plan(snapshot, choices))
    whole = getattr(api, f"labyrinth{'' if mode == 'single' else '_' + mode}")
    arguments = {"parameter": "variance_threshold", "values": [0.03, 0.05]}
    expected = whole(
        levels[0], passes=2, tone_limits=LIMITS, **(arguments if mode == "sweep" else {})
    )
    np.testing.assert_array_equal(data[0], expected)
    extra = () if mode == "single" else (expected.shape[0],)
    assert [level.shape for level in data] == [extra + (3, 64 >> k, 64 >> k) for k in range(3)]
    assert len(kwargs["scale"]) == len(extra) + 3


def test_the_current_plane_of_a_multiscale_stack_sits_at_its_place():
    levels = pyramid(noise((4, 32, 32), np.uint16, seed=2))
    snapshot = multiscale(levels, visible_index=(2,), scale=(3.0, 1.0, 1.0))
    plan = make_plan(snapshot, Choices(planes=CURRENT_PLANE, overrides={"passes": 1}))
    data, kwargs = run(plan)
    expected = api.labyrinth(levels[0][2], passes=1, tone_limits=LIMITS, plane_offset=2)
    assert [level.shape for level in data] == [(1, 32, 32), (1, 16, 16), (1, 8, 8)]
    np.testing.assert_array_equal(data[0][0], expected)
    np.testing.assert_array_equal(kwargs["translate"], (6.0, 0.0, 0.0))


def test_the_visible_plane_of_a_level_downsampled_in_z_is_the_full_plane_over_its_factor():
    levels = [noise((8, 16, 16)), noise((4, 8, 8)), noise((2, 4, 4))]
    snapshot = multiscale(levels, visible_index=(5,), scale=(1.0, 0.5, 0.5))
    level = level_snapshot(snapshot, 2)
    assert level.visible_index == (1,) and level.data is levels[2]
    np.testing.assert_array_equal(level.scale, (4.0, 2.0, 2.0))
    plan = make_plan(
        multiscale(levels, visible_index=(5,), data_level=1), preview_choices(Choices())
    )
    assert plan.source_index == (2,)  # 5 / 2, rounded as napari rounds it
    with pytest.raises(ValueError, match="level must be 0 to 2, got 3"):
        level_snapshot(snapshot, 3)


def test_rgb_levels_halve_y_and_x_and_keep_the_channels():
    levels = pyramid(noise((32, 32, 3), seed=4), axes=(0, 1))
    snapshot = LayerSnapshot.of(levels, multiscale=True, rgb=True)
    assert snapshot.ndim == 2
    data, kwargs = run(make_plan(snapshot, Choices(overrides={"passes": 1})))
    assert [level.shape for level in data] == [(32, 32, 3), (16, 16, 3), (8, 8, 3)]
    np.testing.assert_array_equal(data[1], halved(data[0], (0, 1)))
    assert kwargs["rgb"] is True


def test_a_lazy_multiscale_stack_renders_the_visible_plane_and_the_others_in_the_background():
    pytest.importorskip("dask.array")
    full = noise((4, 32, 32), np.uint16, seed=6)
    lazy, loaded = counting_lazy(full)
    lower = pyramid(full)[1:]
    snapshot = multiscale([lazy, *lower], visible_index=(2,))
    plan = make_plan(snapshot, Choices(overrides={"passes": 1}))
    loaded.clear()
    steps, outcome = drive(plan)
    assert steps == list(range(1, plan.total_steps + 1))
    try:
        data, kwargs = result_layer(plan, outcome)
        assert set(loaded) == {2}, "only the visible plane of the full level may be loaded"
        assert kwargs["metadata"][METADATA_KEY]["lazy"] is True
        expected = api.labyrinth(full, passes=1, tone_limits=LIMITS)
        want = pyramid(expected)
        for level, wanted in zip(data, want, strict=True):  # the plane on screen, on every level
            np.testing.assert_array_equal(np.asarray(level[2]), wanted[2])
            assert not np.asarray(level[0]).any()  # not rendered yet: blank
        outcome.background.render_all()
        for level, wanted in zip(data, want, strict=True):  # each level read as it is now
            np.testing.assert_array_equal(np.asarray(level), wanted)
            np.testing.assert_array_equal(level[1:3, 2:9, ::2], wanted[1:3, 2:9, ::2])
    finally:
        outcome.background.remove()


def test_lower_levels_of_a_dask_level_equal_those_of_its_array():
    da = pytest.importorskip("dask.array")
    full = noise((3, 37, 21), np.uint16)  # odd sides repeat their last row and column
    lazy = da.from_array(full, chunks=(1, 10, 7))
    eager, lazily = list(lower_levels(full, 3, False)), list(lower_levels(lazy, 3, False))
    assert [level.shape for level in eager] == [(3, 19, 11), (3, 10, 6)]
    for a, b in zip(eager, lazily, strict=True):
        assert isinstance(b, da.Array)
        np.testing.assert_array_equal(a, b.compute())


def test_a_run_cancelled_while_it_makes_the_lower_levels_returns_nothing():
    plan = make_plan(
        multiscale(pyramid(noise((64, 64), np.uint16))),
        Choices(overrides={"passes": 1, "scan": "checkerboard"}),  # in memory
    )
    assert plan.streamed is None
    last_pass = plan.total_steps - plan.levels
    _, outcome = drive(plan, on_step=lambda step: step == last_pass and plan.cancel.set())
    assert outcome is None


def test_a_preview_renders_the_part_of_the_level_on_screen_out_to_the_grid():
    levels = pyramid(noise((1024, 1280), np.uint16, seed=8))
    fields = {"scale": (0.5, 0.25), "translate": (10.0, 20.0)}
    # napari shows rows 300-459 and columns 700-899 of level 0
    snapshot = multiscale(levels, data_level=0, shown_region=((300, 460), (700, 900)), **fields)
    plan = make_plan(snapshot, preview_choices(Choices(overrides={"passes": 1})))
    # with PREVIEW_MARGIN around it, out to multiples of PREVIEW_GRID
    assert (PREVIEW_MARGIN, PREVIEW_GRID) == (32, 256)
    assert plan.source_region == [[256, 512], [512, 1024]]
    assert plan.data.shape == (256, 512)
    np.testing.assert_array_equal(plan.layer_kwargs["translate"], (10 + 0.5 * 256, 20 + 0.25 * 512))
    np.testing.assert_array_equal(plan.layer_kwargs["scale"], (0.5, 0.25))
    data, _ = run(plan)
    part = levels[0][256:512, 512:1024]
    np.testing.assert_array_equal(data, api.labyrinth(part, passes=1, tone_limits=LIMITS))

    # on another level, the region is of that level
    snapshot = multiscale(levels, data_level=1, shown_region=((0, 100), (600, 640)), **fields)
    plan = make_plan(snapshot, preview_choices(Choices(overrides={"passes": 1})))
    assert plan.source_region == [[0, 256], [512, 640]] and plan.data.shape == (256, 128)
    np.testing.assert_array_equal(plan.layer_kwargs["translate"], (10.0, 20 + 0.5 * 512))


@pytest.mark.parametrize(
    "fields",
    [
        {"shown_region": None},  # not known (the viewer shows 3-D)
        {"shown_region": ((0, 1000), (10, 1200))},  # the whole level, with the margin
        {"shown_region": ((2000, 2100), (0, 100))},  # off the level: nothing of it on screen
        {"shown_region": ((300, 460), (700, 900)), "rotate": np.array([[0.0, -1.0], [1.0, 0.0]])},
        {"shown_region": ((300, 460), (700, 900)), "shear": np.array([0.5])},
    ],
    ids=["no region", "whole level", "off the level", "rotated", "sheared"],
)
def test_a_preview_renders_the_whole_level_when_the_part_cannot_be_placed(fields):
    levels = pyramid(noise((1024, 1280), np.uint16, seed=8), count=2)
    plan = make_plan(multiscale(levels, **fields), preview_choices(Choices()))
    assert plan.source_region is None and plan.data is levels[0]


def test_a_run_renders_the_full_level_whatever_part_is_on_screen():
    levels = pyramid(noise((512, 512), np.uint16, seed=8), count=2)
    snapshot = multiscale(levels, data_level=0, shown_region=((0, 10), (0, 10)))
    plan = make_plan(snapshot, Choices())
    assert plan.source_region is None and plan.data is levels[0]
    shown_on_level_1 = multiscale(levels, data_level=1, shown_region=((0, 10), (0, 10)))
    assert level_snapshot(shown_on_level_1, 0).shown_region is None  # of level 1, not 0
