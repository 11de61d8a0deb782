"""A lazy input's result rendered plane by plane into its store, as the API renders it."""

from __future__ import annotations

import numpy as np
import pytest

import napari_labyrinth
from napari_labyrinth.widget.choices import Choices, LayerSnapshot
from napari_labyrinth.widget.lazy_result import LazyResult, render_plane
from napari_labyrinth.widget.plan import make_plan

from .plan_helpers import counting_lazy, noise

pytest.importorskip("dask.array")
pytest.importorskip("zarr")


def lazy_plan(data, visible, **choices):
    lazy, loaded = counting_lazy(data)
    plan = make_plan(LayerSnapshot.of(lazy, visible_index=visible), Choices(**choices))
    return plan, loaded


def test_each_plane_renders_as_the_api_renders_it_within_the_stack(tmp_path):
    data = noise((6, 24, 24), dtype=np.uint16, seed=3) * 200
    plan, _ = lazy_plan(data, (2,), overrides={"passes": 2})
    expected = napari_labyrinth.labyrinth(data, **plan.arguments | {"plane_offset": 0})
    for index in range(6):
        np.testing.assert_array_equal(render_plane(plan, (index,)), expected[index])
    result = LazyResult(plan, render_plane(plan, (2,)), tmp_path)
    order = list(result.renders())
    assert order == [(3,), (1,), (4,), (0,), (5,)]  # outward from the plane on screen
    np.testing.assert_array_equal(np.asarray(result.data), expected)


def test_planes_of_two_leading_axes_go_to_their_place(tmp_path):
    data = noise((2, 3, 16, 16), seed=5)
    plan, loaded = lazy_plan(data, (1, 2), mode="stack", overrides={"passes": 1})
    result = LazyResult(plan, render_plane(plan, (1, 2)), tmp_path)
    loaded.clear()
    result.render_all()
    assert sorted(loaded) == [0, 0, 0, 1, 1], "each other plane loaded once"
    arguments = plan.arguments | {"plane_offset": 0}
    expected = napari_labyrinth.labyrinth_stack(data, **arguments)
    np.testing.assert_array_equal(np.asarray(result.data), expected)


def test_a_stop_between_two_passes_gives_the_plane_back(tmp_path):
    data = noise((4, 16, 16))
    plan, _ = lazy_plan(data, (0,), overrides={"passes": 3})
    result = LazyResult(plan, render_plane(plan, (0,)), tmp_path)
    asked = []

    def stop_in_the_second_pass():
        asked.append(1)
        return len(asked) > 2

    assert list(result.renders(stop_in_the_second_pass)) == []
    assert result.order.done_count == 1 and not result.order.is_done((1,))
    assert not np.asarray(result.data[1]).any(), "a plane stopped midway is not written"
    assert list(result.renders()) == [(1,), (2,), (3,)]


def test_stopped_it_renders_no_more_and_removed_its_store_is_gone(tmp_path):
    data = noise((5, 16, 16))
    plan, _ = lazy_plan(data, (2,))
    result = LazyResult(plan, render_plane(plan, (2,)), tmp_path)
    renders = result.renders()
    assert next(renders) == (3,)
    result.stop()
    assert list(renders) == []
    assert result.order.done_count == 2 and not result.complete
    result.remove()
    assert not list(tmp_path.iterdir())
