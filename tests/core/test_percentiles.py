"""Default tone limits by counting values: numpy.percentile's floats, bit for bit."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra import numpy as hnp

from napari_labyrinth.core.percentiles import integer_percentiles
from napari_labyrinth.core.tone_scale import (
    DEFAULT_PERCENTILES,
    default_percentiles,
    resolve_tone_scale,
)

SMALL_INTEGERS = [np.uint8, np.int8, np.uint16, np.int16]
Q = (0.0, 0.5, 1.0, 25.0, 33.3, 50.0, 99.5, 100.0)


def assert_numpy_percentiles(values, q=Q):
    want = [float(v) for v in np.percentile(values, q)]
    got = integer_percentiles(values, q)
    assert np.array(got).tobytes() == np.array(want).tobytes(), (got, want)


@pytest.mark.parametrize("dtype", SMALL_INTEGERS)
def test_edge_cases_equal_numpy(dtype):
    info = np.iinfo(dtype)
    cases = [
        np.full((7, 9), 3, dtype),  # constant
        np.array([[info.min]], dtype),  # one pixel
        np.array([[info.min, info.max]], dtype),  # two values, the widest span
        np.array([[0, 1] * 50], dtype),  # two values, half each
        np.array([[5] * 199 + [info.max]], dtype),  # one outlier
        np.arange(info.min, info.max + 1, dtype=np.int64).astype(dtype).reshape(-1, 16)[:, ::3],
    ]
    for values in cases:
        assert_numpy_percentiles(values)


def test_sparse_uint16_equals_numpy():
    # few distinct values spread over the whole 16-bit range (a sparse histogram)
    rng = np.random.default_rng(1)
    levels = np.array([0, 17, 900, 40000, 65535], np.uint16)
    values = levels[rng.integers(0, 5, (301, 257))]
    assert_numpy_percentiles(values)
    assert default_percentiles(values) == [
        float(v) for v in np.percentile(values, DEFAULT_PERCENTILES)
    ]


@settings(max_examples=150, deadline=None)
@given(
    hnp.arrays(
        st.sampled_from(SMALL_INTEGERS), hnp.array_shapes(min_dims=1, max_dims=3, max_side=40)
    ),
    st.lists(st.floats(0, 100), min_size=1, max_size=4),
)
def test_any_small_integer_array_equals_numpy(values, q):
    assert_numpy_percentiles(values, q)


def test_default_tone_scale_of_integer_images_is_unchanged():
    rng = np.random.default_rng(3)
    for dtype in (np.uint16, np.int16, np.int8, np.uint32, np.int32):
        info = np.iinfo(dtype)
        values = rng.integers(max(info.min, -(2**20)), min(info.max, 2**20), (64, 65))
        values = values.astype(dtype)
        low, high = (float(v) for v in np.percentile(values, DEFAULT_PERCENTILES))
        scale = resolve_tone_scale(values, None)
        assert (scale.low, scale.high) == (low, high if high > low else low + 1.0)
    constant = np.full((8, 8), 300, np.uint16)
    assert resolve_tone_scale(constant, None) == resolve_tone_scale(constant.astype(float), None)


def test_other_dtypes_are_refused_with_a_clear_error():
    with pytest.raises(TypeError, match="8- or 16-bit"):
        integer_percentiles(np.zeros(4, np.float32), Q)
    with pytest.raises(ValueError, match="no values"):
        integer_percentiles(np.zeros(0, np.uint16), Q)


@pytest.mark.parametrize("size", range(10))
def test_counting_in_four_tables_counts_every_value_once(size):
    from napari_labyrinth.core._tone_loops import count_values

    values = np.array([3, 3, 3, 0, 255, 3, 7, 7, 1], np.uint8)[:size]
    counts = np.zeros(256, np.int64)
    count_values(values, 0, counts)
    np.testing.assert_array_equal(counts, np.bincount(values, minlength=256))


# The tails of low and high ranks, counted in the few blocks that may hold them.

from napari_labyrinth.core.percentiles import linear_ranks, tail_rank_values  # noqa: E402


def _photograph() -> np.ndarray:
    """The camera at 4 x the width (as a larger photograph): few blocks of 64 values reach
    a tail; the last block of values is shorter."""
    from skimage import data

    values = np.repeat(data.camera()[:, :501], 4, axis=1).astype(np.uint16) * 256 + 17
    return values[:, :-3]


def test_a_photograph_takes_the_tail_route_and_equals_numpy():
    _takes_the_route_and_equals_numpy(tail_rank_values)


def _takes_the_route_and_equals_numpy(route):
    values = _photograph()
    ranks, _ = linear_ranks(values.size, DEFAULT_PERCENTILES)
    got = route(values.reshape(-1), ranks)
    assert got is not None
    assert got == [int(v) for v in np.sort(values, axis=None)[ranks]]
    assert_numpy_percentiles(values, DEFAULT_PERCENTILES)


def test_noise_is_counted_whole():
    values = np.random.default_rng(2).integers(0, 65536, (256, 256)).astype(np.uint16)
    ranks, _ = linear_ranks(values.size, DEFAULT_PERCENTILES)
    assert tail_rank_values(values.reshape(-1), ranks) is None  # most blocks reach a tail
    assert_numpy_percentiles(values, DEFAULT_PERCENTILES)


@settings(max_examples=100, deadline=None)
@given(
    st.sampled_from(SMALL_INTEGERS),
    st.integers(1, 5000),
    st.integers(0, 2**32 - 1),
    st.floats(0, 1),
    st.lists(st.floats(0, 100), min_size=1, max_size=4),
)
def test_tail_ranks_are_the_sorted_values(dtype, size, seed, noise, q):
    # smooth ramps with some noise and runs of equal values: tails of any shape
    rng = np.random.default_rng(seed)
    info = np.iinfo(dtype)
    ramp = np.cumsum(rng.normal(0, 1, size)) * rng.uniform(1, 300)
    ramp += noise * rng.normal(0, 2000, size) * (rng.random(size) < noise)
    values = np.clip(np.rint(ramp + rng.uniform(info.min, info.max)), info.min, info.max)
    values = values.astype(dtype)
    ranks, _ = linear_ranks(size, q)
    got = tail_rank_values(values, ranks)
    if got is not None:
        assert got == [int(v) for v in np.sort(values)[ranks]]
    assert_numpy_percentiles(values, q)


# One sweep within windows of values that a sample places around the ranks.

from napari_labyrinth.core._tone_loops import SPOT_VALUES, sample_starts  # noqa: E402
from napari_labyrinth.core.percentiles import sampled_rank_values  # noqa: E402


def test_a_ramp_of_every_value_gives_each_rank_its_own_value():
    values = np.arange(65536, dtype=np.uint16)  # the value of rank r is r
    ranks, _ = linear_ranks(values.size, DEFAULT_PERCENTILES)
    assert ranks == [327, 328, 65207, 65208]
    assert sampled_rank_values(values, ranks, spots=1024) == ranks


def test_a_photograph_takes_the_sampled_route_and_equals_numpy():
    _takes_the_route_and_equals_numpy(sampled_rank_values)


def test_a_sample_that_misses_the_tails_falls_back_to_exact_counts():
    # every sampled value is 1000, every other one spreads from 0 to 1999: the
    # sample's windows around 1000 hold neither tail's ranks
    rng = np.random.default_rng(4)
    values = rng.integers(0, 2000, 64 * 64 * 16).astype(np.uint16)
    for start in sample_starts(values.size, 64):
        values[start : start + 4 * SPOT_VALUES : 4] = 1000
    ranks, _ = linear_ranks(values.size, DEFAULT_PERCENTILES)
    assert sampled_rank_values(values, ranks, spots=64) is None
    assert_numpy_percentiles(values, DEFAULT_PERCENTILES)


def test_noise_is_left_to_the_other_routes():
    values = np.random.default_rng(2).integers(0, 65536, (256, 256)).astype(np.uint16)
    ranks, _ = linear_ranks(values.size, DEFAULT_PERCENTILES)
    assert sampled_rank_values(values.reshape(-1), ranks, spots=256) is None  # most reach a tail


def test_a_texture_whose_tails_reach_many_blocks_takes_the_sampled_route():
    # brick: dark and bright grains everywhere, so that about a third of the blocks reach
    # a tail (the sweep counts those), less than half of them
    from skimage import data, transform

    values = transform.resize(data.brick(), (2048, 2048), order=1, preserve_range=True)
    values = (values * 250).astype(np.uint16)
    ranks, _ = linear_ranks(values.size, DEFAULT_PERCENTILES)
    got = sampled_rank_values(values.reshape(-1), ranks)
    assert got == [int(v) for v in np.sort(values, axis=None)[ranks]]


def test_a_wide_window_is_cut_around_the_sampled_value():
    # a smooth dark field with a few bright objects: the sample places the high ranks'
    # window from the field's top up into the objects, wider than the widest window
    rng = np.random.default_rng(5)
    y, x = np.mgrid[:512, :512]
    values = 1000 + 4 * x + 2 * y + rng.integers(0, 3, (512, 512))
    for top, left in rng.integers(0, 500, (12, 2)):
        values[top : top + 8, left : left + 8] = rng.integers(30000, 60000)
    values = values.astype(np.uint16)
    ranks, _ = linear_ranks(values.size, DEFAULT_PERCENTILES)
    got = sampled_rank_values(values.reshape(-1), ranks, spots=256)
    assert got == [int(v) for v in np.sort(values, axis=None)[ranks]]


def test_blocks_of_one_value_are_counted_without_a_visit():
    # a silhouette: most blocks lie wholly in the black or the white, and both tails'
    # ranks fall in them (a block of one value is counted whole at once)
    from skimage import data

    values = np.repeat(np.repeat(data.horse(), 4, axis=0), 4, axis=1).astype(np.uint16) * 60000
    values[::7, ::5] += 17  # and a few other values
    ranks, _ = linear_ranks(values.size, DEFAULT_PERCENTILES)
    got = sampled_rank_values(values.reshape(-1), ranks)
    assert got == [int(v) for v in np.sort(values, axis=None)[ranks]]
    assert_numpy_percentiles(values, DEFAULT_PERCENTILES)


def test_values_of_two_levels_are_left_to_the_count():
    # every block holds both levels: the sweep would count every block twice
    values = np.random.default_rng(6).choice([100, 60000], (256, 256)).astype(np.uint16)
    ranks, _ = linear_ranks(values.size, DEFAULT_PERCENTILES)
    assert sampled_rank_values(values.reshape(-1), ranks, spots=256) is None
    assert_numpy_percentiles(values, DEFAULT_PERCENTILES)


def test_too_few_values_for_the_sample_are_not_sampled():
    values = np.arange(64 * 64 - 1, dtype=np.uint16)
    assert sampled_rank_values(values, [10, 11], spots=64) is None
    assert sampled_rank_values(values[:1], [0, 0], spots=64) is None


@settings(max_examples=100, deadline=None)
@given(
    st.sampled_from(SMALL_INTEGERS),
    st.integers(512, 20000),
    st.integers(0, 2**32 - 1),
    st.floats(0, 1),
    st.lists(st.floats(0, 100), min_size=1, max_size=4),
    st.sampled_from([1, 4, 8]),
)
def test_sampled_ranks_are_the_sorted_values(dtype, size, seed, noise, q, spots):
    # smooth ramps with some noise and runs of equal values: tails of any shape,
    # samples of a few spots whose windows often miss
    rng = np.random.default_rng(seed)
    info = np.iinfo(dtype)
    ramp = np.cumsum(rng.normal(0, 1, size)) * rng.uniform(1, 300)
    ramp += noise * rng.normal(0, 2000, size) * (rng.random(size) < noise)
    values = np.clip(np.rint(ramp + rng.uniform(info.min, info.max)), info.min, info.max)
    values = values.astype(dtype)
    ranks, _ = linear_ranks(size, q)
    got = sampled_rank_values(values, ranks, spots=spots)
    if got is not None:
        assert got == [int(v) for v in np.sort(values)[ranks]]
    assert_numpy_percentiles(values, q)


from napari_labyrinth.core import percentiles as percentiles_module  # noqa: E402
from napari_labyrinth.core.tone_scale import DEFAULT_PERCENTILES, default_percentiles  # noqa: E402


@pytest.mark.parametrize("pays", [False, True])
@pytest.mark.parametrize("dtype", [np.uint8, np.uint16, np.int16])
def test_the_default_tone_limits_are_numpys_whether_or_not_counting_pays(monkeypatch, pays, dtype):
    # counting only once its kernel is compiled (or the image is large), np.percentile else
    values = np.random.default_rng(5).integers(-300, 3000, (300, 200)).clip(0, 255)
    values = values.astype(dtype)
    import napari_labyrinth.core._jit as jit

    monkeypatch.setattr(jit, "is_compiled", lambda *args: pays)
    assert percentiles_module.counting_pays(values) is pays
    assert default_percentiles(values) == [
        float(v) for v in np.percentile(values, DEFAULT_PERCENTILES)
    ]


def test_counting_pays_on_an_image_too_large_to_wait_on_numpy(monkeypatch):
    import napari_labyrinth.core._jit as jit

    monkeypatch.setattr(jit, "is_compiled", lambda *args: False)
    large = np.zeros(percentiles_module.COMPILE_FROM_VALUES, np.uint8)
    assert percentiles_module.counting_pays(large)
    assert not percentiles_module.counting_pays(large[1:])
