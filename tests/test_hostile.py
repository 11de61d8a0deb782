"""Hostile input through the API: each class of the hostile-input battery, case by case.

Classes (as ``HOSTILE_CLASSES`` counts them): memory bombs, extreme
parameter values, errors that name the problem, valid input once refused
(byte order), silent garbage (non-finite outputs, alpha), valid extreme
data, leftovers. The CLI's cases (files, scheduler, batches, signals) are in
``tests/cli/test_cli_hostile.py``; the property over random images in
``test_hostile_properties.py``.
"""

import os
import time

import numpy as np
import pytest

from napari_labyrinth import (
    find_window,
    labyrinth,
    labyrinth_stack,
    labyrinth_steps,
    labyrinth_sweep,
)
from napari_labyrinth._budget import (
    MEMORY_ENV,
    MemoryBudgetError,
    parse_size,
    refusal,
    render_bytes,
)
from napari_labyrinth.core.parameters import PARAMETERS, PLANE_OFFSET, SEED, WORKERS
from napari_labyrinth.io import read_image, write_array, write_image
from napari_labyrinth.io._atomic import (
    StaleTemporaryWarning,
    remove_stale_temporaries,
    stale_temporaries,
    temporary_name,
)

da = pytest.importorskip("dask.array")

IMAGE = np.random.default_rng(13).integers(0, 256, (12, 12)).astype(np.uint8)


# -- extreme parameter values: refused before any allocation, naming parameter and range ----------

EXTREME_PARAMETERS = [
    (dict(passes=10**12), "passes must be between 0 and 1000"),
    (dict(passes=2**63), "passes must be between 0 and 1000"),
    (dict(passes=-1), "passes must be between 0 and 1000"),
    (dict(max_tries=2**70), "max_tries must be between 0 and 10000"),
    (dict(mean_threshold=1e300), "mean_threshold must be finite and between 0 and 1e\\+06"),
    (dict(variance_threshold=float("inf")), "variance_threshold must be finite"),
    (dict(variance_threshold=float("nan")), "variance_threshold must be finite"),
    (dict(tone_ranges=256), "tone_ranges as a count must be between 1 and 255"),
    (dict(tone_ranges=[0, 1e9]), "tone_ranges must lie on the 0-255 tone scale"),
    (dict(seed=2**64 - 1), "seed must be between 0 and 2\\*\\*63 - 1"),
    (dict(seed=-1), "seed must be between 0 and 2\\*\\*63 - 1"),
    (dict(plane_offset=2**64), "plane_offset must be between 0 and 2\\*\\*63 - 1"),
    (dict(plane_offset=-1), "plane_offset must be between 0 and 2\\*\\*63 - 1"),
    (dict(workers=0), "workers must be between 1 and 1024"),
    (dict(workers=10**9), "workers must be between 1 and 1024"),
]


@pytest.mark.parametrize("kwargs,match", EXTREME_PARAMETERS, ids=lambda v: str(v)[:40])
def test_extreme_parameter_values_are_refused_naming_the_parameter_and_its_range(kwargs, match):
    with pytest.raises(ValueError, match=match):
        labyrinth(IMAGE, **kwargs)


def test_a_plane_offset_beyond_the_stream_range_is_refused_before_rendering():
    stack = np.stack([IMAGE] * 3)
    with pytest.raises(ValueError, match="plane_offset must be between 0 and 9223372036854775805"):
        labyrinth(stack, plane_offset=PLANE_OFFSET.high - 1)
    with pytest.raises(ValueError, match="plane_offset"):
        labyrinth(da.from_array(stack, chunks=(1, 12, 12)), plane_offset=PLANE_OFFSET.high)
    # the largest that fits renders, and as the last planes of a longer stack would
    last = labyrinth(stack, plane_offset=PLANE_OFFSET.high - 2)
    assert last.shape == stack.shape


def test_every_number_of_the_table_has_both_bounds():
    numbers = [p for p in PARAMETERS.values() if p.kind in ("int", "float", "tone_ranges")]
    for parameter in [*numbers, SEED, PLANE_OFFSET, WORKERS]:
        assert parameter.low is not None and parameter.high is not None, parameter.name
    assert SEED.high == 2**63 - 1  # the widget's spin boxes hold no more


@pytest.mark.parametrize("name", ["passes", "seed", "max_tries"])
def test_the_largest_value_of_the_table_is_accepted(name):
    parameter = SEED if name == "seed" else PARAMETERS[name]
    kwargs = {"passes": 1, name: int(parameter.high)}
    out = labyrinth(IMAGE[:4, :4], **kwargs)
    assert out.shape == (4, 4)


# -- errors that name the problem ------------------------------------------------------------------

NAMED_ERRORS = [
    (lambda: labyrinth([[1, 2], [3]]), ValueError, "image must be a rectangular array"),
    (lambda: labyrinth(np.array([[1, "a"]], dtype=object)), TypeError, "image must be an array of numbers"),
    (lambda: labyrinth(np.zeros((4, 4), np.int64)), TypeError, "image dtype int64"),
    (lambda: labyrinth(np.zeros((4, 4), np.complex64)), TypeError, "image dtype complex64"),
    (lambda: labyrinth(np.zeros(4, np.uint8)), ValueError, "image must have at least 2"),
    (lambda: labyrinth(np.zeros((0, 4), np.uint8)), ValueError, "image is empty"),
    (lambda: labyrinth("camera.png"), TypeError, "image must be an array"),
    (lambda: labyrinth(IMAGE, tone_ranges=np.array(3.5)), TypeError, "tone_ranges must be a count"),
    (lambda: labyrinth(IMAGE, tone_ranges="3"), TypeError, "tone_ranges must be a count"),
    (lambda: labyrinth(IMAGE, tones=np.array(1.0)), TypeError, "tones must be a sequence"),
    (lambda: labyrinth(IMAGE, tone_limits=np.array(3)), TypeError, "tone_limits must be None"),
    (lambda: labyrinth(IMAGE, tone_limits=(5, 5)), ValueError, "tone_limits must be finite"),
    (lambda: labyrinth(IMAGE, passes=np.array([1, 2])), TypeError, "passes must be an integer"),
    (lambda: labyrinth(IMAGE, channel_axis=0), ValueError, "channel_axis needs an image of"),
    (lambda: labyrinth(np.zeros((4, 4, 3)), channel_axis=-1, alpha=1), TypeError, "alpha must be"),
    (lambda: labyrinth(IMAGE, alpha=True), ValueError, "alpha=True needs a channel_axis"),
    (
        lambda: labyrinth(np.zeros((4, 4, 2)), channel_axis=-1, alpha=True, colour="luminance"),
        ValueError,
        "colour='luminance' needs R, G, B",
    ),
    (
        lambda: labyrinth(da.from_array(IMAGE)[da.from_array(IMAGE)[:, 0] > 100]),
        ValueError,
        "image is a dask array with unknown chunk sizes",
    ),
]


HUGE = 10**400  # beyond float64: float() of it overflows


NAMED_ERRORS += [
    (lambda: labyrinth(IMAGE, mean_threshold=HUGE), ValueError, "mean_threshold must be finite"),
    (lambda: labyrinth(IMAGE, variance_threshold=-HUGE), ValueError, "variance_threshold must"),
    (lambda: labyrinth(IMAGE, tone_ranges=[0, HUGE]), ValueError, "tone_ranges must lie on"),
    (lambda: labyrinth(IMAGE, tone_ranges=3, tones=[(0, HUGE)] * 3), ValueError, "tones must lie"),
    (lambda: labyrinth(IMAGE, tone_limits=(0, HUGE)), ValueError, "tone_limits must be finite"),
    (lambda: find_window(IMAGE, thresholds=[0.01, HUGE]), ValueError, "thresholds must be"),
    (lambda: labyrinth_sweep(IMAGE, "seed", [1], seed=3), TypeError, "seed is swept"),
    (lambda: labyrinth_sweep(IMAGE, "seed", [1], seed=0), TypeError, "seed is swept"),
    (lambda: labyrinth_sweep(IMAGE, ["seed"], [1]), ValueError, "parameter must be one of"),
    # sets and mappings have no order of the caller's: their limits came in hash order
    (lambda: labyrinth(IMAGE, tone_limits={0, 200}), TypeError, "tone_limits must be None or"),
    (lambda: find_window(IMAGE, workers=2000), ValueError, "workers must be between 1 and 1024"),
    (
        lambda: labyrinth(np.ma.masked_array(IMAGE, mask=IMAGE > 128)),
        TypeError,
        "image is a masked array with masked pixels",
    ),
    (lambda: labyrinth(IMAGE, tone_ranges={0, 100, 255}), TypeError, "tone_ranges must be a"),
    (lambda: labyrinth(IMAGE, tone_ranges={0: 1, 255: 2}), TypeError, "tone_ranges must be a"),
    (
        lambda: labyrinth(IMAGE, tone_ranges=[0, 100, 255], tones={(0, 100), (100, 255)}),
        TypeError,
        "tones must be a sequence",
    ),
]


@pytest.mark.parametrize("call,error,match", NAMED_ERRORS, ids=[m[:40] for *_, m in NAMED_ERRORS])
def test_bad_input_gets_an_error_that_names_it(call, error, match):
    with pytest.raises(error, match=match):
        call()


def test_tone_limits_of_zero_d_arrays_are_their_numbers():
    image = IMAGE.astype(np.float32)
    np.testing.assert_array_equal(
        labyrinth(image, tone_limits=(np.array(10.0), np.array(200))),
        labyrinth(image, tone_limits=(10.0, 200)),
    )


def test_a_zero_d_array_holding_a_count_is_that_count():
    np.testing.assert_array_equal(
        labyrinth(IMAGE, tone_ranges=np.array(4), passes=np.array(2)),
        labyrinth(IMAGE, tone_ranges=4, passes=2),
    )


# -- valid input once refused: big-endian arrays ---------------------------------------------------


@pytest.mark.parametrize("dtype", [">u2", ">i2", ">u4", ">i4", ">f2", ">f4", ">f8"])
def test_a_big_endian_image_renders_as_its_native_equivalent_in_its_own_dtype(dtype):
    big = (IMAGE.astype(np.float64) * 3).astype(dtype)
    native = big.astype(np.dtype(dtype).newbyteorder("="))
    out = labyrinth(big, passes=2, seed=4)
    assert out.dtype == np.dtype(dtype)
    np.testing.assert_array_equal(out, labyrinth(native, passes=2, seed=4))
    stack = labyrinth_stack(big, passes=2, seed=4)
    assert stack.dtype == np.dtype(dtype) and stack.shape == (3, *big.shape)
    sweep = labyrinth_sweep(big, "seed", [1, 2])
    assert sweep.dtype == np.dtype(dtype)
    lazy = labyrinth(da.from_array(big, chunks=(6, 12)), passes=2, seed=4)
    assert lazy.dtype == np.dtype(dtype)
    np.testing.assert_array_equal(lazy.compute(), out)


@pytest.mark.parametrize("dtype", [">u2", ">f4"])
@pytest.mark.parametrize("limits", [None, (0.0, 500.0)])
def test_a_big_endian_image_keeps_its_tone_limits_in_the_result(dtype, limits):
    big = (IMAGE.astype(np.float64) * 3).astype(dtype)
    native = big.astype(np.dtype(dtype).newbyteorder("="))
    *_, result = labyrinth_steps(big, tone_limits=limits, passes=1)
    *_, expected = labyrinth_steps(native, tone_limits=limits, passes=1)
    assert result.tone_limits == expected.tone_limits is not None
    assert result.image.dtype == np.dtype(dtype)


# -- valid input once refused: read-only arrays -----------------------------------------------------


@pytest.mark.parametrize("dtype", [np.uint8, np.uint16, np.int16, np.float32])
@pytest.mark.parametrize("kwargs", [{}, {"passes": 1}, {"preset": "paper"}, {"passes": 3}])
def test_a_read_only_image_renders_as_a_writable_one(dtype, kwargs):
    writable = (IMAGE.astype(np.float64) * (200 if dtype == np.uint16 else 1)).astype(dtype)
    image = writable.copy()
    image.flags.writeable = False
    np.testing.assert_array_equal(labyrinth(image, **kwargs), labyrinth(writable, **kwargs))
    np.testing.assert_array_equal(
        labyrinth_stack(image, passes=2), labyrinth_stack(writable, passes=2)
    )
    np.testing.assert_array_equal(
        labyrinth_sweep(image, "seed", [1, 2]), labyrinth_sweep(writable, "seed", [1, 2])
    )
    np.testing.assert_array_equal(image, writable)


def test_a_read_only_memory_map_renders_and_stays_as_it_is(tmp_path):
    path = tmp_path / "values.dat"
    values = np.memmap(path, dtype=np.uint16, mode="w+", shape=(3, 40, 36))
    values[...] = np.random.default_rng(2).integers(0, 4000, values.shape)
    values.flush()
    before = path.read_bytes()
    mapped = np.memmap(path, dtype=np.uint16, mode="r", shape=(3, 40, 36))
    np.testing.assert_array_equal(labyrinth(mapped), labyrinth(np.array(mapped)))
    assert path.read_bytes() == before


# -- silent garbage ---------------------------------------------------------------------------------


def test_float16_with_tone_limits_beyond_its_range_makes_no_infinity():
    image = IMAGE.astype(np.float16) * 250  # up to 63750, near float16's limit of 65504
    assert np.isfinite(image).all()
    for limits in [(0.0, 1e6), (-1e6, 1e6), (-1e9, -1e8)]:
        out = labyrinth(image, tone_limits=limits, passes=3, seed=1)
        assert np.isfinite(out).all(), limits
    rgb = np.stack([image, image[::-1], image.T], axis=-1)
    out = labyrinth(rgb, channel_axis=-1, tone_limits=(-1e6, 1e6), passes=3, seed=1)
    assert np.isfinite(out).all()


@pytest.mark.parametrize("dtype", [np.uint8, np.int16, np.float16, np.float32, np.float64])
@pytest.mark.parametrize("limits", [(-1e300, 1e300), (-3e38, 3e38), (0.0, 1e-200), (1e36, 2e36)])
def test_finite_values_get_finite_tones_whatever_the_tone_limits(dtype, limits):
    # float32 intermediates overflowed for limits beyond its range: finite pixels got NaN
    # tones, and NaN tones are left alone as holes, silently
    from napari_labyrinth.core.tone_scale import ToneScale

    info = np.finfo(dtype) if np.dtype(dtype).kind == "f" else np.iinfo(dtype)
    values = np.array([info.min, info.min + 1, 0, 1, info.max], dtype=dtype)
    tones = ToneScale(*limits).to_tones(values)
    assert np.isfinite(tones).all() and (tones >= 0).all() and (tones <= 255).all(), tones


def test_an_image_of_subnormal_values_renders_on_a_widened_scale():
    # its own percentiles are closer than any usable gain: widened, never refused
    image = np.array([[2.22507386e-309, 0.0], [1e-310, 3e-309]])
    out = labyrinth(image, passes=1)
    assert out.shape == image.shape and np.isfinite(out).all()


def test_tone_limits_too_close_for_a_scale_are_refused():
    with pytest.raises(ValueError, match="tone_limits .* too close"):
        labyrinth(IMAGE.astype(np.float32), tone_limits=(0.0, 5e-324))


@pytest.mark.parametrize(
    "shape,axis,alpha",
    [((12, 12, 2), -1, True), ((2, 12, 12), 0, True), ((12, 12, 4), -1, None), ((4, 12, 12), 0, None),
     ((3, 12, 12, 2), -1, True), ((12, 12, 3), -1, True)],
)
def test_alpha_is_never_rendered_whatever_the_layout(shape, axis, alpha):
    image = np.random.default_rng(1).integers(0, 256, shape).astype(np.uint8)
    # white noise all over: the noise gate would leave every pixel alone
    options = dict(channel_axis=axis, alpha=alpha, passes=3, seed=2, noise_gate=0)
    out = labyrinth(image, **options)
    np.testing.assert_array_equal(np.take(out, -1, axis=axis), np.take(image, -1, axis=axis))
    assert not np.array_equal(out, image)  # the colour channels were rendered
    lazy = labyrinth(da.from_array(image), **options)
    np.testing.assert_array_equal(lazy.compute(), out)


def test_alpha_counts_every_pixel_as_skipped_in_the_diagnostics():
    image = np.random.default_rng(1).integers(0, 256, (12, 12, 2)).astype(np.uint8)
    _, diagnostics = labyrinth(image, channel_axis=-1, alpha=True, return_diagnostics=True)
    assert diagnostics["skipped"][0, 1] == 144


# -- valid extreme data -----------------------------------------------------------------------------


@pytest.mark.parametrize("value", [1e16, -1e16, 2.0**53, 3e38, -3e38])
def test_a_constant_image_of_huge_values_renders_in_memory_and_lazily_alike(value):
    image = np.full((8, 8), value, np.float32)
    out = labyrinth(image, seed=1)
    assert out.dtype == np.float32 and np.isfinite(out).all()
    np.testing.assert_array_equal(labyrinth(da.from_array(image, chunks=4), seed=1).compute(), out)


def test_the_largest_float64_constant_keeps_a_scale():
    image = np.full((6, 6), np.finfo(np.float64).max)
    assert np.isfinite(labyrinth(image)).all()


def test_values_spanning_all_of_float64_are_refused_naming_the_tone_limits():
    image = np.array([[-1.7e308, 1.7e308] * 4] * 8)
    with pytest.raises(ValueError, match="default tone limits .* of image .* pass tone_limits"):
        labyrinth(image)
    assert np.isfinite(labyrinth(image, tone_limits=(-5e307, 5e307))).all()


# -- memory bombs: the budget -----------------------------------------------------------------------


def test_sizes_parse_in_binary_units():
    assert parse_size("512M") == 512 << 20
    assert parse_size("1.5GiB") == 3 << 29
    assert parse_size("1000") == 1000
    with pytest.raises(ValueError, match=MEMORY_ENV):
        parse_size("lots")


def test_a_declared_huge_image_is_refused_with_its_size_and_what_to_do(monkeypatch):
    monkeypatch.setenv(MEMORY_ENV, "1G")
    reason = refusal((100_000, 100_000), np.uint8)
    assert "100000 x 100000 uint8 pixels (9.3 GiB)" in reason
    assert "more than the 1.0 GiB this run may use" in reason and MEMORY_ENV in reason
    assert refusal((1000, 1000), np.uint8) is None
    # the render estimate: input and result, and one plane's work arrays
    assert render_bytes((10, 100, 100), np.uint16) == 2 * 2 * 10**5 + 17 * 10**4


def test_a_lazy_image_of_huge_planes_is_refused_before_a_block_is_read(monkeypatch):
    monkeypatch.setenv(MEMORY_ENV, "100M")
    huge = da.zeros((2, 50_000, 50_000), dtype=np.uint8, chunks=(1, 50_000, 50_000))
    with pytest.raises(MemoryBudgetError, match="image: each plane declares 50000 x 50000"):
        labyrinth(huge, tone_limits=(0, 255))
    small = da.zeros((2, 64, 64), dtype=np.uint8)
    assert labyrinth(small).shape == (2, 64, 64)


def test_a_result_too_big_for_the_memory_is_refused_before_it_is_allocated(monkeypatch):
    # a view of one value declaring 10**12 pixels: numpy's MemoryError leaked out of the engine
    with pytest.raises(MemoryBudgetError, match="the rendering of 1000000 x 1000000 uint8"):
        labyrinth(np.broadcast_to(np.uint8(3), (10**6, 10**6)))
    monkeypatch.setenv(MEMORY_ENV, "64M")
    image = np.zeros((1024, 1024), np.uint8)
    with pytest.raises(MemoryBudgetError, match="a stack of the input and 400 passes .* 64.0 MiB"):
        labyrinth_stack(image, passes=400)
    with pytest.raises(MemoryBudgetError, match="a sweep of 40 renderings"):
        labyrinth_sweep(image, "seed", list(range(40)))
    assert labyrinth_stack(image, passes=3).shape == (4, 1024, 1024)


def test_a_lazy_stack_whose_blocks_cannot_be_held_is_refused(monkeypatch):
    # a block holds a plane and every pass of it: 124 MB ran on a 60 MB budget, after a
    # refusal of the same image in memory that advised passing it as a dask array
    da = pytest.importorskip("dask.array")
    monkeypatch.setenv(MEMORY_ENV, "60M")
    image = da.zeros((2, 1024, 1024), np.float32, chunks=(1, 1024, 1024))
    with pytest.raises(MemoryBudgetError, match="each plane's stack of the input and 30 passes"):
        labyrinth_stack(image, passes=30, tone_limits=(0, 1))
    with pytest.raises(MemoryBudgetError) as refused:
        labyrinth_stack(image, passes=30, tone_limits=(0, 1))
    assert "dask array" not in str(refused.value)  # it is one already
    assert labyrinth_stack(image, passes=2, tone_limits=(0, 1)).shape == (3, 2, 1024, 1024)


def test_a_zarr_store_too_big_to_read_whole_is_refused_before_reading(tmp_path, monkeypatch):
    zarr = pytest.importorskip("zarr")
    store = tmp_path / "big.zarr"
    zarr.create_array(store=str(store), shape=(40_000, 40_000), chunks=(4000, 4000), dtype="u2")
    monkeypatch.setenv(MEMORY_ENV, "64M")
    with pytest.raises(ValueError, match="declares 40000 x 40000 uint16 pixels"):
        read_image(store)


# -- leftovers ----------------------------------------------------------------------------------------


def _dead_pid() -> int:
    import subprocess
    import sys

    child = subprocess.Popen([sys.executable, "-c", "pass"])
    child.wait()
    return child.pid


@pytest.mark.subprocess
def test_temporaries_of_dead_writers_are_removed_by_the_next_write(tmp_path):
    name = "out.tif"
    dead = _dead_pid()
    stale_file = tmp_path / temporary_name(name).replace(f"-{os.getpid()}-", f"-{dead}-")
    stale_file.write_bytes(b"half a tiff")
    stale_dir = tmp_path / temporary_name(name).replace(f"-{os.getpid()}-", f"-{dead}-")
    stale_dir.mkdir()
    (stale_dir / "zarr.json").write_text("{}")
    alive = tmp_path / temporary_name(name)  # this process: a write in progress
    alive.write_bytes(b"")
    removable, unknown = stale_temporaries(tmp_path, name)
    assert sorted(removable) == sorted([stale_file, stale_dir]) and unknown == []
    write_image(tmp_path / name, IMAGE)
    assert not stale_file.exists() and not stale_dir.exists() and alive.exists()


def test_unattributed_temporaries_are_reported_not_removed(tmp_path):
    old_style = tmp_path / ".out.tif.0123abcd.tmp"
    old_style.write_bytes(b"")
    with pytest.warns(StaleTemporaryWarning, match=r"\.out\.tif\.0123abcd\.tmp"):
        remove_stale_temporaries(tmp_path, "out.tif")
    assert old_style.exists()


def test_a_normal_write_and_a_failed_one_leave_no_temporary(tmp_path):
    write_array(tmp_path / "a.zarr", IMAGE)
    write_image(tmp_path / "b.tif", IMAGE)
    with pytest.raises(ValueError):
        write_image(tmp_path / "c.jpg", IMAGE.astype(np.float32))
    with pytest.raises(RuntimeError):
        write_array(tmp_path / "d.zarr", da.from_array(IMAGE).map_blocks(_fail, dtype=np.uint8))
    assert sorted(p.name for p in tmp_path.iterdir()) == ["a.zarr", "b.tif"]


def _fail(block):
    time.sleep(0.01)
    raise RuntimeError("a block failed")
