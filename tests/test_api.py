"""The public API: shapes, dtypes, tone scale, planes, channels, presets, errors."""

import numpy as np
import pytest

import napari_labyrinth
from napari_labyrinth import (
    DIAGNOSTIC_FIELDS,
    PRESETS,
    labyrinth,
    labyrinth_stack,
    labyrinth_sweep,
    resolve_parameters,
)
from napari_labyrinth.core._reference import reference_render


@pytest.fixture(scope="module")
def camera():
    from skimage import data

    return data.camera()[::4, ::4].copy()  # 128 x 128 uint8


@pytest.mark.parametrize("preset", ["paper", "labyrinth"])
def test_uint8_result_matches_the_reference_reading(camera, preset):
    image = camera[30:54, 20:44]  # the head and the collar: edges and flat areas
    parameters = resolve_parameters(preset, passes=2)
    got = labyrinth(image, preset=preset, passes=2, seed=4)
    tones, _ = reference_render(image.astype(np.float32), parameters, seed=4)
    want = np.where(tones != image, np.clip(np.rint(tones), 0, 255), image).astype(np.uint8)
    np.testing.assert_array_equal(got, want)
    assert (got != image).sum() > 10


def test_shape_dtype_kept_and_input_untouched(camera):
    for dtype in (np.uint8, np.uint16, np.int16, np.float32, np.float64):
        image = (camera.astype(np.float64) * (4 if dtype == np.uint16 else 1)).astype(dtype)
        before = image.copy()
        out = labyrinth(image, preset="paper", passes=2)
        assert out.shape == image.shape and out.dtype == image.dtype
        np.testing.assert_array_equal(image, before)
        assert out is not image
        assert 0 < np.mean(out != image) < 0.5


def test_unchanged_pixels_keep_their_exact_values():
    rng = np.random.default_rng(3)
    image = rng.normal(1000.0, 200.0, (40, 50))  # float64, mapped to 0-255 and back
    out = labyrinth(image, preset="paper")
    same = out == image
    assert same.mean() > 0.3
    changed = ~same
    low, high = np.percentile(image, (0.5, 99.5))
    assert (out[changed] >= low - 1e-9).all() and (out[changed] <= high + 1e-9).all()


def test_uint16_tone_limits_control_the_scale(camera):
    image = camera.astype(np.uint16) * 16 + 1000
    scaled = labyrinth(image, tone_limits=(1000, 1000 + 255 * 16), seed=2)
    as_uint8 = labyrinth(camera, seed=2)
    # the same tones: a redrawn tone rounds to 1/16 of a uint16 step but to a
    # whole uint8 step, where it may fall back on the original value
    changed = scaled != image
    assert changed.sum() > 100
    assert (changed | (as_uint8 == camera)).all()
    assert np.abs((scaled.astype(float) - 1000) / 16 - as_uint8).max() <= 0.5


def test_passes_zero_returns_a_copy(camera):
    out = labyrinth(camera, passes=0)
    np.testing.assert_array_equal(out, camera)
    assert out is not camera


def test_same_seed_same_result_other_seed_other_result(camera):
    a = labyrinth(camera, seed=123)
    b = labyrinth(camera, seed=123)
    c = labyrinth(camera, seed=124)
    np.testing.assert_array_equal(a, b)
    assert not np.array_equal(a, c)


def test_planes_are_independent_and_indexed_by_position(camera):
    stack = np.stack([camera, camera[::-1], camera.T])
    out = labyrinth(stack, seed=1)
    assert out.shape == stack.shape
    # changing one plane changes no other plane
    altered = stack.copy()
    altered[1] = 0
    out2 = labyrinth(altered, seed=1)
    np.testing.assert_array_equal(out[0], out2[0])
    np.testing.assert_array_equal(out[2], out2[2])
    # identical planes at different indices draw different random streams
    twins = labyrinth(np.stack([camera, camera]), seed=1)
    assert not np.array_equal(twins[0], twins[1])
    np.testing.assert_array_equal(twins[0], out[0])


def test_4d_stack_matches_plane_by_plane(camera):
    stack = np.stack([np.stack([camera, camera[::-1]]), np.stack([camera.T, camera])])
    out, diagnostics = labyrinth(stack, return_diagnostics=True, passes=2)
    assert diagnostics.shape == (2, 2, 2)
    flat = labyrinth(stack.reshape(4, *camera.shape), passes=2)
    np.testing.assert_array_equal(out.reshape(flat.shape), flat)


def test_rgb_channels_render_independently_and_alpha_is_kept():
    from skimage import data

    rgb = data.astronaut()[::4, ::4].copy()
    out, diagnostics = labyrinth(
        rgb, channel_axis=-1, colour="channels", passes=1, return_diagnostics=True
    )
    assert out.shape == rgb.shape and diagnostics.shape == (1, 3)
    channels_first = labyrinth(np.moveaxis(rgb, -1, 0), passes=1)
    np.testing.assert_array_equal(np.moveaxis(out, -1, 0), channels_first)
    alpha = np.linspace(0, 255, rgb.shape[0] * rgb.shape[1]).reshape(rgb.shape[:2])
    rgba = np.dstack([rgb, alpha.astype(np.uint8)])
    out4, diagnostics4 = labyrinth(
        rgba, channel_axis=2, colour="channels", passes=1, return_diagnostics=True
    )
    np.testing.assert_array_equal(out4[..., 3], rgba[..., 3])
    np.testing.assert_array_equal(out4[..., :3], out)
    assert diagnostics4["skipped"][0, 3] == rgb.shape[0] * rgb.shape[1]


def test_channel_axis_in_the_middle_of_a_time_series():
    rng = np.random.default_rng(0)
    movie = rng.integers(0, 256, (2, 3, 20, 30), dtype=np.uint8)  # T, C, Y, X
    out, diagnostics = labyrinth(
        movie, channel_axis=1, colour="channels", passes=1, return_diagnostics=True
    )
    assert diagnostics.shape == (1, 2, 3)
    np.testing.assert_array_equal(out, labyrinth(movie, passes=1))


def test_non_finite_pixels_are_kept_and_do_not_spread(camera):
    image = camera.astype(np.float32) / 255
    image[10:14, 10:14] = np.nan
    image[50, 60] = np.inf
    image[70, 20] = -np.inf
    out = labyrinth(image, passes=3)
    assert np.isnan(out[10:14, 10:14]).all()
    assert out[50, 60] == np.inf and out[70, 20] == -np.inf
    assert np.isfinite(out).sum() == np.isfinite(image).sum()


def test_all_nan_image_is_returned_as_it_is():
    image = np.full((5, 6), np.nan)
    out, diagnostics = labyrinth(image, return_diagnostics=True)
    assert np.isnan(out).all()
    assert diagnostics["skipped"][0] == 30


def test_constant_image_is_unchanged():
    for image in (
        np.full((8, 9), 0.25),
        np.zeros((8, 9), np.uint16),
        np.full((4, 4), 7, np.uint8),
    ):
        np.testing.assert_array_equal(labyrinth(image, passes=3), image)


def test_diagnostics_count_every_pixel_of_every_plane_and_pass(camera):
    stack = np.stack([camera, camera // 2])
    _, diagnostics = labyrinth(stack, passes=3, return_diagnostics=True)
    assert diagnostics.shape == (3, 2)
    assert diagnostics.dtype.names == DIAGNOSTIC_FIELDS
    totals = sum(diagnostics[name] for name in DIAGNOSTIC_FIELDS)
    assert (totals == camera.size).all()
    assert (diagnostics["redrawn"] > 0).all()


def test_progress_is_reported_for_every_plane_and_pass(camera):
    calls = []
    labyrinth(np.stack([camera, camera]), passes=3, progress=lambda d, t: calls.append((d, t)))
    assert calls == [(k, 6) for k in range(1, 7)]


def test_stack_holds_the_input_and_every_pass(camera):
    stack, diagnostics = labyrinth_stack(camera, passes=3, seed=5, return_diagnostics=True)
    assert stack.shape == (4,) + camera.shape and stack.dtype == camera.dtype
    np.testing.assert_array_equal(stack[0], camera)
    for k in range(1, 4):
        np.testing.assert_array_equal(stack[k], labyrinth(camera, passes=k, seed=5))
    assert diagnostics.shape == (3,)


def test_stack_of_rgb_keeps_the_channel_axis():
    from skimage import data

    rgb = data.astronaut()[::8, ::8].copy()
    stack = labyrinth_stack(rgb, passes=2, channel_axis=-1)
    assert stack.shape == (3,) + rgb.shape
    np.testing.assert_array_equal(stack[2], labyrinth(rgb, passes=2, channel_axis=-1))


def test_sweep_varies_one_parameter_with_one_seed(camera):
    values = (0.05, 0.12, 0.3)
    ungated = dict(noise_gate=0)  # t alone decides what changes
    sweep, diagnostics = labyrinth_sweep(
        camera, "mean_threshold", values, seed=9, return_diagnostics=True, **ungated
    )
    assert sweep.shape == (3,) + camera.shape and len(diagnostics) == 3
    for k, value in enumerate(values):
        np.testing.assert_array_equal(
            sweep[k], labyrinth(camera, mean_threshold=value, seed=9, **ungated)
        )
    changed = [(s != camera).mean() for s in sweep]
    assert changed[0] > changed[1] > changed[2]


def test_sweep_default_is_the_papers_figure_3(camera):
    sweep = labyrinth_sweep(camera)  # the preset's V -6 %, 0, +6 %, as 47 / 50 / 53 %
    assert sweep.shape == (3,) + camera.shape
    np.testing.assert_array_equal(sweep[1], labyrinth(camera))
    np.testing.assert_array_equal(sweep[2], labyrinth(camera, variance_threshold=0.0424))
    paper = labyrinth_sweep(camera, preset="paper")
    np.testing.assert_array_equal(
        paper[0], labyrinth(camera, preset="paper", variance_threshold=0.47)
    )
    with pytest.raises(ValueError, match="non-empty"):
        labyrinth_sweep(camera, "mean_threshold")


def test_sweep_over_seeds_and_passes(camera):
    seeds = labyrinth_sweep(camera, "seed", [1, 2])
    np.testing.assert_array_equal(seeds[1], labyrinth(camera, seed=2))
    calls = []
    passes = labyrinth_sweep(camera, "passes", [1, 3], progress=lambda d, t: calls.append((d, t)))
    np.testing.assert_array_equal(passes[1], labyrinth(camera, passes=3))
    assert calls == [(k, 4) for k in range(1, 5)]


def test_labyrinth_is_the_default_preset_and_paper_stays_literal(camera):
    assert napari_labyrinth.core.presets.DEFAULT_PRESET == "labyrinth"
    np.testing.assert_array_equal(labyrinth(camera), labyrinth(camera, preset="labyrinth"))
    labyrinth_parameters = resolve_parameters()
    assert labyrinth_parameters.variance_action == "push_in_range"
    assert labyrinth_parameters.condition_order == "variance_first"
    assert labyrinth_parameters.variance_ratio == "sqrt(V/N)/M"  # as printed
    paper = resolve_parameters("paper")
    assert (paper.variance_action, paper.condition_order) == ("leave", "mean_first")


def test_presets_supply_defaults_and_keywords_override_them():
    paper = resolve_parameters("paper")
    assert paper.mean_threshold == 0.12 and paper.variance_threshold == 0.5
    assert paper.variance_ratio == "sqrt(V/N)/M" and paper.border == "inside"
    assert paper.tone_ranges[0] > 0 and paper.tone_ranges[-1] == 255 and len(paper.tones) == 3
    assert set(PRESETS) >= {"paper", "labyrinth"}
    custom = resolve_parameters("paper", mean_threshold=0.2, tone_ranges=(5, 100, 255))
    assert custom.mean_threshold == 0.2
    assert custom.tones == ((5.0, 100.0), (100.0, 255.0))  # T = L for the new ranges
    assert custom.as_dict()["tone_ranges"] == [5.0, 100.0, 255.0]


def test_tones_shape_the_redrawn_values(camera):
    out = labyrinth(
        camera,
        preset="paper",
        tone_ranges=(10, 128, 255),
        tones=((40, 60), (200, 220)),
        on_exhausted="last_draw",
    )
    changed = out[out != camera]
    assert changed.size > 0
    assert (((changed >= 40) & (changed <= 60)) | ((changed >= 200) & (changed <= 220))).all()


def test_options_change_the_result(camera):
    base = labyrinth(camera, preset="paper", passes=2)
    for option in (
        dict(border="mirror"),
        dict(variance_ratio="sqrt(V)/M"),
        dict(variance_action="push_in_range"),
        dict(variance_action="push_full_scale"),
        dict(condition_order="variance_first", variance_ratio="sqrt(V)/M"),
        dict(on_exhausted="last_draw"),
        dict(include_centre=True),
        dict(scan="serpentine"),
        dict(max_tries=1),
    ):
        other = labyrinth(camera, preset="paper", passes=2, **option)
        assert not np.array_equal(base, other), option


@pytest.mark.subprocess
def test_import_does_not_load_numba():
    import subprocess
    import sys

    code = "import sys, napari_labyrinth; print('numba' in sys.modules, 'skimage' in sys.modules)"
    result = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True)
    assert result.stdout.split() == ["False", "False"], result.stderr


@pytest.mark.parametrize(
    "image,error,match",
    [
        (np.zeros((0, 5), np.uint8), ValueError, "empty"),
        (np.array(3.0), ValueError, "at least 2 dimensions"),
        (np.zeros(5), ValueError, "at least 2 dimensions"),
        (np.zeros((4, 4), complex), TypeError, "complex"),
        (np.zeros((4, 4), bool), TypeError, "bool"),
        (np.zeros((4, 4), np.int64), TypeError, "labels"),
        (np.zeros((4, 4), object), TypeError, "object"),
        ("image.png", TypeError, "image must be an array"),
        (None, TypeError, "image must be an array"),
    ],
)
def test_bad_images_raise_clear_errors(image, error, match):
    with pytest.raises(error, match=match):
        labyrinth(image)


@pytest.mark.parametrize(
    "options,error,match",
    [
        (dict(passes=-1), ValueError, "passes"),
        (dict(passes=1.5), TypeError, "passes"),
        (dict(seed=-1), ValueError, "seed"),
        (dict(seed=2**64), ValueError, "seed"),
        (dict(seed=1.0), TypeError, "seed"),
        (dict(mean_threshold=-0.1), ValueError, "mean_threshold"),
        (dict(mean_threshold=float("nan")), ValueError, "mean_threshold"),
        (dict(variance_threshold=float("inf")), ValueError, "variance_threshold"),
        (dict(variance_threshold="0.5"), TypeError, "variance_threshold"),
        (dict(max_tries=-3), ValueError, "max_tries"),
        (dict(max_tries=10**9), ValueError, "max_tries"),
        (dict(max_tries=True), TypeError, "max_tries"),
        (dict(tone_ranges=(10, 200, 100)), ValueError, "strictly increasing"),
        (dict(tone_ranges=(10, 300)), ValueError, "0-255"),
        (dict(tone_ranges=(10,)), ValueError, "at least two"),
        (dict(tone_ranges=0), ValueError, "tone_ranges"),
        (dict(tone_ranges="3"), TypeError, "tone_ranges"),
        (dict(tones=((0, 10),)), ValueError, "one \\(T_inf, T_sup\\) pair per tone range"),
        (dict(tones=((0, 300), (1, 2), (3, 4), (5, 6))), ValueError, "0-255"),
        (dict(tones=((20, 10), (1, 2), (3, 4), (5, 6))), ValueError, "T_inf <= T_sup"),
        (dict(border="reflect"), ValueError, "border"),
        (dict(variance_ratio="V/M"), ValueError, "variance_ratio"),
        (dict(variance_action="shove"), ValueError, "variance_action"),
        (dict(condition_order="random"), ValueError, "condition_order"),
        (dict(on_exhausted="random"), ValueError, "on_exhausted"),
        (dict(include_centre="yes"), TypeError, "include_centre"),
        (dict(scan="spiral"), ValueError, "scan"),
        (dict(preset="nope"), ValueError, "preset"),
        (dict(channel_axis=5), ValueError, "channel_axis"),
        (dict(channel_axis=1.0), TypeError, "channel_axis"),
        (dict(colour="rgb"), ValueError, "colour"),
        (dict(colour=1), TypeError, "colour"),
        (dict(colour="luminance"), ValueError, "colour='luminance' needs a channel_axis"),
        (dict(tone_limits=(5, 5)), ValueError, "tone_limits"),
        (dict(tone_limits=(0, float("nan"))), ValueError, "tone_limits"),
        (dict(tone_limits=3), TypeError, "tone_limits"),
        (dict(progress="bar"), TypeError, "progress"),
    ],
)
def test_bad_parameters_raise_errors_naming_them(options, error, match):
    image = np.zeros((6, 6, 3), np.uint8)
    with pytest.raises(error, match=match):
        labyrinth(image, **options)


def test_bad_sweeps_raise_clear_errors(camera):
    with pytest.raises(ValueError, match="parameter must be one of"):
        labyrinth_sweep(camera, "colour", [1])
    with pytest.raises(ValueError, match="non-empty"):
        labyrinth_sweep(camera, "mean_threshold", [])
    with pytest.raises(TypeError, match="swept"):
        labyrinth_sweep(camera, "mean_threshold", [0.1], mean_threshold=0.2)
    with pytest.raises(ValueError, match="mean_threshold"):
        labyrinth_sweep(camera, "mean_threshold", [0.1, -1])
    with pytest.raises(TypeError, match="unknown parameter"):
        labyrinth_stack(camera, passes=2, palette=3)


def test_version_is_exposed():
    assert napari_labyrinth.__version__ != "0+unknown"


def test_plane_offset_renders_a_plane_as_within_its_stack(camera):
    stack = np.stack([camera, camera[::-1], camera.T, camera // 2, camera, camera[:, ::-1]])
    whole = labyrinth(stack, passes=2, seed=3)
    for k in range(len(stack)):
        np.testing.assert_array_equal(
            labyrinth(stack[k], passes=2, seed=3, plane_offset=k), whole[k]
        )
    grid = stack.reshape(2, 3, *camera.shape)
    np.testing.assert_array_equal(
        labyrinth(grid[1, 1:], passes=2, seed=3, plane_offset=4), whole[4:]
    )
    with pytest.raises(ValueError, match="plane_offset"):
        labyrinth(camera, plane_offset=-1)
    with pytest.raises(TypeError, match="plane_offset"):
        labyrinth(camera, plane_offset=1.5)
