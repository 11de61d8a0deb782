"""Colour images rendered in their luminance (``colour="luminance"``) or per channel."""

import hashlib

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays

from napari_labyrinth import labyrinth, labyrinth_stack, labyrinth_steps, labyrinth_sweep
from napari_labyrinth.api import Progress, Result
from napari_labyrinth.core.colour import (
    LUMA_WEIGHTS,
    luminance,
    recolour,
    resolve_colour,
)
from napari_labyrinth.core.planes import first_plane_index, step_count
from napari_labyrinth.core.tone_scale import resolve_tone_scale


@pytest.fixture(scope="module")
def tissue():
    from skimage import data

    return data.immunohistochemistry()[100:164, 200:264].copy()  # 64 x 64 RGB uint8


def hue_saturation(rgb):
    from skimage.color import rgb2hsv

    hsv = rgb2hsv(np.asarray(rgb, dtype=np.float64).reshape(-1, 1, 3))
    return hsv[:, 0, 0], hsv[:, 0, 1]


# -- the luminance ----------------------------------------------------------------------------


def test_luminance_by_hand():
    pixels = np.array([[100, 50, 200], [7, 7, 7], [0, 0, 0], [255, 255, 255]], np.uint8)
    np.testing.assert_allclose(luminance(pixels), [71.46, 7, 0, 255], rtol=0, atol=1e-12)
    assert luminance(pixels)[1] == 7.0 and luminance(pixels)[3] == 255.0  # grey: exactly
    assert LUMA_WEIGHTS == (0.2126, 0.7152, 0.0722) and sum(LUMA_WEIGHTS) == pytest.approx(1)


def test_luminance_is_rec709_luma_and_ignores_alpha():
    from skimage.color import rgb2gray

    rgb = np.random.default_rng(1).random((5, 6, 3))
    np.testing.assert_allclose(luminance(rgb), rgb @ [0.2126, 0.7152, 0.0722], atol=1e-15)
    np.testing.assert_allclose(luminance(rgb), rgb2gray(rgb), atol=2e-4)  # 0.2125, 0.7154, 0.0721
    rgba = np.concatenate([rgb, np.ones((5, 6, 1))], axis=-1)
    np.testing.assert_array_equal(luminance(rgba), luminance(rgb))
    np.testing.assert_array_equal(luminance(np.moveaxis(rgb, -1, 0), axis=0), luminance(rgb))


def test_luminance_of_a_non_finite_channel_is_not_finite():
    pixels = np.array([[np.nan, 1, 1], [1, np.inf, 1], [np.inf, np.inf, 0], [-np.inf, 1, 1]])
    assert not np.isfinite(luminance(pixels)).any()


# -- putting the change back into the colour ----------------------------------------------------


def test_darker_scales_every_channel_by_the_ratio():
    # Y = 71.46; Y' = Y / 2: (100, 50, 200) / 2
    got = recolour([[100, 50, 200]], [71.46], [35.73], np.float64)
    np.testing.assert_allclose(got, [[50, 25, 100]], rtol=1e-13)
    np.testing.assert_array_equal(
        recolour([[100, 50, 200]], [71.46], [35.73], np.uint8), [[50, 25, 100]]
    )


def test_brighter_adds_the_same_amount_to_every_channel():
    # Y' - Y = 30: (100, 50, 200) + 30; the difference from grey (28.54, -21.46, 128.54) is kept
    got = recolour([[100, 50, 200]], [71.46], [101.46], np.float64)
    np.testing.assert_allclose(got, [[130, 80, 230]], rtol=1e-13)
    np.testing.assert_array_equal(
        recolour([[100, 50, 200]], [71.46], [101.46], np.uint8), [[130, 80, 230]]
    )


def test_brighter_beyond_the_range_moves_towards_grey_and_keeps_luminance_and_hue():
    # adding 70 would give B = 270 > 255: f = (255 - 141.46) / (200 - 71.46) = 0.88331...
    f = (255 - 141.46) / (200 - 71.46)
    want = 141.46 + f * (np.array([100, 50, 200]) - 71.46)  # (166.67, 122.50, 255)
    got = recolour([[100, 50, 200]], [71.46], [141.46], np.uint8)
    np.testing.assert_array_equal(got, [np.rint(want)])
    assert got[0, 2] == 255
    exact = 141.46 + f * (np.array([[100.0, 50, 200]]) - 71.46)
    assert luminance(exact)[0] == pytest.approx(141.46, abs=1e-12)
    hue, saturation = hue_saturation(exact)
    hue0, saturation0 = hue_saturation([[100, 50, 200]])
    assert hue == pytest.approx(hue0, abs=1e-12) and saturation < saturation0
    # floats have no range to leave: the shift is applied as it is
    np.testing.assert_allclose(
        recolour([[100, 50, 200]], [71.46], [141.46], np.float32), [[170, 120, 270]]
    )


def test_black_becomes_grey_and_zero_luminance_becomes_black():
    np.testing.assert_array_equal(recolour([[0, 0, 0]], [0.0], [40.4], np.uint8), [[40, 40, 40]])
    np.testing.assert_array_equal(recolour([[0, 0, 0]], [0.0], [40.4], np.float64), [[40.4] * 3])
    np.testing.assert_array_equal(
        recolour([[100, 50, 200]], [71.46], [0.0], np.uint8), [[0, 0, 0]]
    )
    # a float luminance pushed below zero: grey, the ratio would flip the colour
    np.testing.assert_array_equal(
        recolour([[0.4, 0.2, 0.8]], [0.2858], [-0.1], np.float64), [[-0.1] * 3]
    )


def test_zero_or_negative_luminance_of_signed_values_is_shifted():
    # Y = -20 + 0.2126 * 10 + 0.0722 * 20 = -16.43 -> Y' = 5: +21.43 on every channel
    got = recolour([[-10, -20, 0]], [-16.43], [5.0], np.int16)
    np.testing.assert_array_equal(got, [[11, 1, 21]])
    # never below the dtype's minimum: towards grey instead
    low = recolour(
        [[-32768, 0, 0]], [luminance(np.array([[-32768, 0, 0]]))[0]], [-32000.0], np.int16
    )
    assert low.min() >= -32768 and luminance(low.astype(float))[0] == pytest.approx(-32000, abs=1)


def test_recolour_takes_the_channel_axis_and_ignores_alpha():
    pixels = np.array([[100, 50, 200, 9]], np.uint8).T  # channels first, with alpha
    got = recolour(pixels, [71.46], [101.46], np.uint8, axis=0)
    np.testing.assert_array_equal(got, [[130], [80], [230]])


@settings(max_examples=100, deadline=None)
@given(
    rgb=arrays(np.float64, (20, 3), elements=st.floats(0.01, 1)),
    factors=arrays(np.float64, 20, elements=st.floats(0.05, 3)),
)
def test_hue_is_kept_and_saturation_too_where_darker(rgb, factors):
    old = luminance(rgb)
    new = old * factors
    got = recolour(rgb, old, new, np.float64)
    np.testing.assert_allclose(luminance(got), new, rtol=1e-9, atol=1e-12)
    hue0, saturation0 = hue_saturation(rgb)
    hue, saturation = hue_saturation(got)
    coloured = saturation0 > 1e-3  # grey has no hue
    turn = np.abs(hue - hue0)[coloured]
    np.testing.assert_allclose(np.minimum(turn, 1 - turn), 0, atol=1e-9)
    darker = factors <= 1
    np.testing.assert_allclose(saturation[darker], saturation0[darker], atol=1e-9)
    assert (saturation[~darker] <= saturation0[~darker] + 1e-12).all()


# -- the mode ---------------------------------------------------------------------------------


def test_default_mode_is_luminance_for_3_or_4_channels_only():
    assert resolve_colour(None, (8, 8, 3), 2) == "luminance"
    assert resolve_colour(None, (4, 8, 8), 0) == "luminance"
    assert resolve_colour(None, (8, 8, 2), 2) == "channels"
    assert resolve_colour(None, (8, 8, 5), 2) == "channels"
    assert resolve_colour(None, (8, 8), None) == "channels"
    assert resolve_colour("channels", (8, 8), None) == "channels"


@pytest.mark.parametrize(
    "shape, channel_axis, colour, error, match",
    [
        ((8, 8, 3), -1, "rgb", ValueError, "colour must be one of 'luminance', 'channels'"),
        ((8, 8, 3), -1, 3, TypeError, "colour must be a string"),
        ((8, 8, 2), -1, "luminance", ValueError, "colour='luminance'.*got 2 channels"),
        ((8, 8, 5), -1, "luminance", ValueError, "colour='luminance'.*got 5 channels"),
        ((8, 8, 3), None, "luminance", ValueError, "colour='luminance'.*no channel_axis"),
    ],
)
def test_bad_colour_is_refused_naming_colour(shape, channel_axis, colour, error, match):
    image = np.zeros(shape, np.uint8)
    with pytest.raises(error, match=match):
        labyrinth(image, channel_axis=channel_axis, colour=colour)
    with pytest.raises(error, match=match):
        labyrinth_steps(image, "stack", channel_axis=channel_axis, colour=colour)


def test_two_channels_render_per_channel_by_default():
    image = np.random.default_rng(2).integers(0, 256, (20, 24, 2), dtype=np.uint8)
    np.testing.assert_array_equal(
        labyrinth(image, channel_axis=-1), labyrinth(image, channel_axis=-1, colour="channels")
    )


# -- "channels" is today's rendering, bit for bit -----------------------------------------------

#: sha256 (16 hex digits) of the renderings below, made by the per-channel
#: rendering before the colour option existed.
CHANNELS_DIGESTS = {
    "ihc": "10e28c6793967562",
    "ihc_stack": "9128b31aaea4df74",
    "rgba16": "47ec371bc3403383",
    "f32_axis0": "c19b19a053a7b0a1",
    "sweep": "43ce6d9f3f54da7b",
}


def _digest(array):
    array = np.ascontiguousarray(array)
    header = str((array.shape, array.dtype.str)).encode()
    return hashlib.sha256(header + array.tobytes()).hexdigest()[:16]


def test_channels_is_the_per_channel_rendering_bit_for_bit(tissue):
    rng = np.random.default_rng(7)
    rgba16 = rng.integers(0, 4000, (2, 24, 20, 4)).astype(np.uint16)
    f32 = rng.normal(0.3, 0.2, (3, 18, 22)).astype(np.float32)
    f32[1, 3, 4] = np.nan
    f32[0, 5, 5] = np.inf
    # the ranges and the gate (off) the digests were made with
    channels = {"colour": "channels", "tone_ranges": 3, "noise_gate": 0}
    renderings = {
        "ihc": labyrinth(tissue, channel_axis=-1, seed=3, **channels),
        "ihc_stack": labyrinth_stack(tissue, passes=2, channel_axis=-1, **channels),
        "rgba16": labyrinth(rgba16, channel_axis=-1, plane_offset=5, **channels),
        "f32_axis0": labyrinth(f32, channel_axis=0, preset="paper", passes=2, **channels),
        "sweep": labyrinth_sweep(tissue[:32, :32], "seed", [1, 2], channel_axis=-1, **channels),
    }
    assert {name: _digest(array) for name, array in renderings.items()} == CHANNELS_DIGESTS
    # and each channel is the channel rendered alone, with its plane's stream
    for c in range(3):
        np.testing.assert_array_equal(
            renderings["ihc"][..., c],
            labyrinth(tissue[..., c], seed=3, plane_offset=c, tone_ranges=3, noise_gate=0),
        )


# -- luminance rendering ----------------------------------------------------------------------


def test_luminance_renders_the_grey_image_and_keeps_unchanged_pixels(tissue):
    image = tissue.astype(np.float64) / 255  # no rounding: the put-back is seen exactly
    out, diagnostics = labyrinth(image, channel_axis=-1, passes=2, return_diagnostics=True)
    grey = luminance(image)
    grey_out, grey_diagnostics = labyrinth(grey, passes=2, return_diagnostics=True)
    np.testing.assert_array_equal(diagnostics, grey_diagnostics)
    assert diagnostics.shape == (2,)
    changed = (out != image).any(axis=-1)
    np.testing.assert_array_equal(changed, grey_out != grey)  # same pixels change
    assert 0.05 < changed.mean() < 0.95
    np.testing.assert_array_equal(out[~changed], image[~changed])  # bit for bit
    np.testing.assert_allclose(luminance(out)[changed], grey_out[changed], rtol=1e-12)
    hue0, saturation0 = hue_saturation(image[changed])
    hue, saturation = hue_saturation(out[changed])
    turn = np.abs(hue - hue0)
    coloured = saturation0 > 0.02
    np.testing.assert_allclose(np.minimum(turn, 1 - turn)[coloured], 0, atol=1e-9)
    darker = (grey_out < grey)[changed]
    np.testing.assert_allclose(saturation[darker], saturation0[darker], atol=1e-9)


def test_luminance_of_uint8_keeps_hue_up_to_rounding(tissue):
    out = labyrinth(tissue, channel_axis=-1)
    assert out.dtype == np.uint8 and out.shape == tissue.shape
    changed = (out != tissue).any(axis=-1)
    assert changed.mean() > 0.05
    hue0, saturation0 = hue_saturation(tissue[changed] / 255)
    hue, _ = hue_saturation(out[changed] / 255)
    turn = np.abs(hue - hue0)
    turn = np.minimum(turn, 1 - turn)[saturation0 > 0.2]
    assert np.median(turn) < 0.01  # rounding to 8 bits moves the hue of dark pixels a little


def test_alpha_comes_back_bit_for_bit_and_is_never_rendered(tissue):
    alpha = np.random.default_rng(4).integers(0, 256, tissue.shape[:2], dtype=np.uint8)
    rgba = np.dstack([tissue, alpha])
    out, diagnostics = labyrinth(rgba, channel_axis=-1, passes=2, return_diagnostics=True)
    np.testing.assert_array_equal(out[..., 3], alpha)
    np.testing.assert_array_equal(out[..., :3], labyrinth(tissue, channel_axis=-1, passes=2))
    assert diagnostics.shape == (2,)
    # channels first, in the middle of a time series
    movie = np.stack([np.moveaxis(rgba, -1, 0), np.moveaxis(rgba[::-1], -1, 0)])
    out, diagnostics = labyrinth(movie, channel_axis=1, passes=1, return_diagnostics=True)
    assert diagnostics.shape == (1, 2)
    np.testing.assert_array_equal(out[:, 3], movie[:, 3])
    np.testing.assert_array_equal(
        np.moveaxis(out[0], 0, -1), labyrinth(rgba, channel_axis=-1, passes=1)
    )


@settings(max_examples=40, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(
    dtype=st.sampled_from([np.uint8, np.uint16, np.int16, np.float16, np.float32, np.float64]),
    data=st.data(),
    channel_axis=st.sampled_from([1, -1]),
    seed=st.integers(0, 2**32),
    passes=st.integers(0, 2),
)
def test_a_grey_rgb_image_renders_as_its_grey_planes(dtype, data, channel_axis, seed, passes):
    shape = data.draw(st.tuples(st.integers(1, 3), st.integers(1, 10), st.integers(1, 10)))
    if np.dtype(dtype).kind == "f":
        elements = st.one_of(
            st.floats(-2, 300, width=16 if dtype == np.float16 else 32),
            st.sampled_from([np.nan, np.inf, -np.inf]),
        )
    else:
        info = np.iinfo(dtype)
        elements = st.integers(int(info.min), int(info.max))
    grey = data.draw(arrays(dtype, shape, elements=elements))
    rgb = np.stack([grey] * 3, axis=channel_axis)  # (T, H, W, 3) or (T, 3, H, W)
    out = labyrinth(rgb, channel_axis=channel_axis, seed=seed, passes=passes)
    if shape[0] == 1:
        want = labyrinth(grey, seed=seed, passes=passes)
        for c in range(3):
            np.testing.assert_array_equal(np.take(out, c, axis=channel_axis), want)
    scale = resolve_tone_scale(grey, None)  # the grey stack's limits
    for t in range(shape[0]):
        # every channel is the grey plane rendered with the stream of its first channel
        want = labyrinth(
            grey[t],
            seed=seed,
            passes=passes,
            plane_offset=3 * t,
            tone_limits=(scale.low, scale.high),
        )
        for c in range(3):
            np.testing.assert_array_equal(np.take(out[t], c, axis=max(channel_axis - 1, -1)), want)


def test_a_plane_cut_from_an_rgb_stack_renders_as_within_it(tissue):
    stack = np.stack([tissue, tissue[::-1], tissue[:, ::-1]])
    whole = labyrinth(stack, channel_axis=-1, passes=2)
    for t in range(3):
        offset = first_plane_index(stack.shape, (t,), -1)
        assert offset == 3 * t
        np.testing.assert_array_equal(
            labyrinth(stack[t], channel_axis=-1, passes=2, plane_offset=offset), whole[t]
        )
    assert not np.array_equal(whole[1], labyrinth(stack[1], channel_axis=-1, passes=2))


def test_uint16_tone_limits_are_those_of_the_luminance():
    rng = np.random.default_rng(5)
    rgb = rng.integers(100, 3000, (30, 32, 3)).astype(np.uint16)
    rgb[..., 2] += 20000  # a blue far brighter than the rest: the channels' limits differ
    y = luminance(rgb)
    limits = tuple(np.percentile(y, (0.5, 99.5)))
    np.testing.assert_array_equal(
        labyrinth(rgb, channel_axis=-1), labyrinth(rgb, channel_axis=-1, tone_limits=limits)
    )


def test_non_finite_pixels_stay_and_do_not_spread(tissue):
    image = tissue.astype(np.float32) / 255
    image[10:14, 10:14, 0] = np.nan
    image[30, 40, 1] = np.inf
    image[50, 20, 2] = -np.inf
    out = labyrinth(image, channel_axis=-1, passes=3)
    np.testing.assert_array_equal(out[10:14, 10:14], image[10:14, 10:14])
    np.testing.assert_array_equal(out[30, 40], image[30, 40])
    np.testing.assert_array_equal(out[50, 20], image[50, 20])
    assert np.isfinite(out).sum() == np.isfinite(image).sum()


def test_stack_and_sweep_in_luminance(tissue):
    stack, diagnostics = labyrinth_stack(
        tissue, passes=3, channel_axis=-1, seed=2, return_diagnostics=True
    )
    assert stack.shape == (4,) + tissue.shape and diagnostics.shape == (3,)
    np.testing.assert_array_equal(stack[0], tissue)
    for k in range(1, 4):
        np.testing.assert_array_equal(
            stack[k], labyrinth(tissue, passes=k, channel_axis=-1, seed=2)
        )
    sweep = labyrinth_sweep(tissue, "passes", [1, 2], channel_axis=-1, seed=2)
    np.testing.assert_array_equal(sweep, stack[1:3])


@pytest.mark.parametrize("workers", [1, 3])
def test_progress_counts_one_plane_per_position(tissue, workers):
    stack = np.stack(
        [np.dstack([tissue, tissue[..., 0]])] * 2 + [np.dstack([tissue[::-1], tissue[..., 1]])]
    )
    events = list(labyrinth_steps(stack, "stack", channel_axis=-1, passes=2, workers=workers))
    progress, result = events[:-1], events[-1]
    assert isinstance(result, Result) and all(isinstance(e, Progress) for e in progress)
    assert [e.done for e in progress] == list(range(1, 7))
    assert {e.total for e in progress} == {6} == {step_count(stack.shape, -1, 2)}
    assert sorted((e.plane, e.pass_number) for e in progress) == [
        (plane, k)
        for plane in (0, 4, 8)
        for k in (1, 2)  # the first channel's plane index
    ]
    for event in progress:  # the colour plane after the pass is already in the array
        t = event.plane // 4
        np.testing.assert_array_equal(
            event.partial[event.pass_number, t], result.image[event.pass_number, t]
        )
    assert event.partial is result.image


def test_dask_input_renders_lazily_as_numpy():
    da = pytest.importorskip("dask.array")
    rng = np.random.default_rng(6)
    rgb = (rng.random((3, 2, 24, 20, 3)) ** 3 * 4000).astype(np.uint16)  # dark, uint16
    rgb[..., 1] //= 3
    lazy = da.from_array(rgb, chunks=(2, 1, 12, 20, 2))  # chunks split planes and channels
    for options in ({}, {"tone_limits": (10, 3000)}, {"plane_offset": 7}):
        result = labyrinth(lazy, channel_axis=-1, passes=2, **options)
        assert isinstance(result, da.Array)
        np.testing.assert_array_equal(
            result.compute(), labyrinth(rgb, channel_axis=-1, passes=2, **options)
        )
    np.testing.assert_array_equal(
        labyrinth_stack(lazy, passes=2, channel_axis=-1).compute(),
        labyrinth_stack(rgb, passes=2, channel_axis=-1),
    )
    channels_first = da.moveaxis(lazy, -1, 1)
    np.testing.assert_array_equal(
        labyrinth(channels_first, channel_axis=1, passes=1).compute(),
        labyrinth(np.moveaxis(rgb, -1, 1), channel_axis=1, passes=1),
    )
    np.testing.assert_array_equal(
        labyrinth(lazy, channel_axis=-1, colour="channels", passes=1).compute(),
        labyrinth(rgb, channel_axis=-1, colour="channels", passes=1),
    )
    with pytest.raises(ValueError, match="colour"):
        labyrinth(lazy[..., :2], channel_axis=-1, colour="luminance")
