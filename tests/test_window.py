"""find_window: the window of V measured on a probe, and variance_threshold="auto"."""

from __future__ import annotations

import numpy as np
import pytest

from napari_labyrinth import find_window, labyrinth, labyrinth_stack, metrics, samples, window
from napari_labyrinth.cli import main
from napari_labyrinth.core.parameters import AUTO, FLOAT_DECIMALS, PARAMETERS, without_auto
from napari_labyrinth.core.presets import resolve_parameters
from napari_labyrinth.core.tone_scale import resolve_tone_scale
from napari_labyrinth.io import read_image, write_image
from napari_labyrinth.window import window_of
from napari_labyrinth.window_criterion import ALIGNED, MIN_CHANGED

#: A coarse grid of V (steps of 2 over the default grid's range): the tests that
#: render whole images at every V use it to stay quick.
GRID = (0.005, 0.01, 0.02, 0.04, 0.08, 0.16, 0.32)


def small_images(size=192):
    """Images like the study's, small: a photograph, a texture, dark, 16-bit."""
    from skimage import data

    return {
        "camera": np.ascontiguousarray(data.camera()[100 : 100 + size, 150 : 150 + size]),
        "schlieren": np.rint(samples.nematic_schlieren((size, size)) * 255).astype(np.uint8),
        "dark-field": samples.smectic_batonnets((size, size)),
        "fluorescence-16bit": samples.fluorescence_stack((size, size), planes=1)[0],
    }


@pytest.fixture(scope="module")
def images():
    return small_images()


@pytest.fixture(scope="module")
def camera_window():
    """The default window of a small photograph (default grid, default probe)."""
    image = small_images(96)["camera"]
    return image, find_window(image)


def whole_image_curves(image, thresholds):
    """The whole image rendered at every V (the study's sweep) and measured as the probe is:
    edge enhancement, cover, alignment, changed; and the input's own cover."""
    scale = resolve_tone_scale(image, None)
    before = scale.to_tones(image)
    comparison = metrics.Comparison(before)
    names = ("edge_enhancement", "labyrinth_cover", "contour_alignment")
    curves = []
    for value in thresholds:
        rendered = labyrinth(image, variance_threshold=value)
        measured = comparison.measure(scale.to_tones(rendered), names)
        curves.append([measured[name] for name in names] + [np.mean(rendered != image)])
    return [np.array(curve) for curve in zip(*curves)], metrics.labyrinth_cover(before)


def assert_auto_draws_what_a_person_sees(image, found, fraction=0.8):
    """Issue 28's targets on the whole image: Auto never takes a V that draws no walls while
    another does, and its cover is at least ``fraction`` of the best cover of aligned walls
    (the walls a V draws: beyond the input's own cover)."""
    (_, cover, alignment, changed), input_cover = whole_image_curves(image, found.thresholds)
    draws = (cover >= input_cover + metrics.MIN_COVER) & (changed >= MIN_CHANGED)
    chosen = found.thresholds.index(found.best)
    if draws.any():
        assert draws[chosen], (found.summary(), cover, changed)
    along = draws & (np.nan_to_num(alignment, nan=0.0) >= ALIGNED)
    if along.any():
        assert cover[chosen] >= fraction * cover[along].max(), (found.summary(), cover)


def test_window_of_a_hand_made_curve():
    thresholds = [0.01, 0.02, 0.04, 0.08, 0.16]
    assert window_of(thresholds, [0.1, 0.5, 0.6, 0.55, 0.58], default=0) == (
        0.04,
        0.04,
        0.16,
        True,
    )
    # a value at 90 % beyond a dip does not join the window
    assert window_of(thresholds, [0.55, 0.2, 0.6, 0.1, 0.58], default=0)[::2] == (0.04, 0.04)
    assert window_of(thresholds, [-0.1, 0.0, np.nan, -0.3, 0.0], default=0.5) == (
        0.5,
        0.5,
        0.5,
        False,
    )


def test_find_window_is_deterministic_for_a_seed(images):
    image = images["dark-field"]
    first = find_window(image, seed=3, crops=3, crop_size=64, thresholds=GRID)
    assert find_window(image, seed=3, crops=3, crop_size=64, thresholds=GRID, workers=1) == first
    assert first.low <= first.best <= first.high
    assert first.best in first.thresholds
    assert len(first.crops) == 3 and first.crop_size == 64
    assert len(first.edge_enhancement) == len(first.thresholds) == len(first.changed)


@pytest.mark.parametrize("name", list(small_images(32)))
def test_the_chosen_v_draws_walls_on_the_whole_image_if_any_v_does(images, name):
    # a small probe (4 crops of 64²) misjudges the cover by more than the margin of the
    # cover rule on these 192² images: benchmarks/auto_table.py measures that rule with the
    # default probe on the study's images and the hard cases
    image = images[name]
    window = find_window(image, crops=4, crop_size=64, thresholds=GRID)
    assert window.found and window.low <= window.best <= window.high
    assert_auto_draws_what_a_person_sees(image, window, fraction=0.0)


def test_auto_draws_walls_on_a_smooth_noisy_texture():
    # a Schlieren texture with a camera's grey-level noise: the edge score was best where
    # so few pixels change that those few sit on edges (cover 0.000 at V = 0.2263)
    smooth = samples.nematic_schlieren((384, 384), seed=0, noise=0.0) * 255.0
    noise = np.random.default_rng(0).normal(0.0, 2.0, smooth.shape)
    image = np.clip(np.rint(smooth + noise), 0, 255).astype(np.uint8)
    found = find_window(image)
    assert found.found and found.reason.startswith("cover ")
    assert_auto_draws_what_a_person_sees(image, found)
    assert found.summary().startswith(f"V = {found.best:.4g}: {found.reason} (window ")


def test_every_v_probed_is_a_v_the_form_shows(camera_window):
    # the widget's field holds FLOAT_DECIMALS decimals: a V with more would run rounded
    _, found = camera_window
    assert all(v == round(v, FLOAT_DECIMALS) for v in found.thresholds), found.thresholds
    assert found.best == round(found.best, FLOAT_DECIMALS)


def test_a_window_at_an_end_of_the_v_probed_says_so(images):
    image = images["schlieren"]  # its window: 0.04-0.08 on GRID
    below = find_window(image, crops=3, crop_size=64, thresholds=GRID[:3], widen=0)
    assert below.best == GRID[2] and below.high == GRID[2]
    assert below.high_open and not below.low_open
    assert "highest V probed" in below.summary()
    above = find_window(image, crops=3, crop_size=64, thresholds=GRID[-2:], widen=0)
    assert above.low == GRID[-2] and above.low_open and not above.high_open
    assert "lowest V probed" in above.summary()
    inside = find_window(image, crops=3, crop_size=64, thresholds=GRID)
    assert not (inside.low_open or inside.high_open) and "probed" not in inside.summary()


def test_a_best_v_at_the_top_widens_the_grid_upwards(images):
    image = images["schlieren"]
    narrow = find_window(image, crops=3, crop_size=64, thresholds=GRID[:3], widen=0)
    widened = find_window(image, crops=3, crop_size=64, thresholds=GRID[:3], widen=3)
    # the last step (a factor 2) continued, three times; the V probed before are unchanged
    assert widened.thresholds == GRID[:6]
    assert widened.edge_enhancement[:3] == narrow.edge_enhancement
    assert widened.best > GRID[2] and not widened.high_open
    # a best V at the bottom is not widened: below the window the curve is flat
    assert find_window(image, crops=3, crop_size=64, thresholds=GRID[-2:]).thresholds == GRID[-2:]


def test_widening_continues_the_last_step_rounded():
    assert window._above([0.01, 0.02], 3) == [0.04, 0.08, 0.16]
    assert window._above([0.04, 0.0566], 2) == [0.0801, 0.1133]
    assert window._above([0.1], 1) == [round(0.1 * 2**0.5, FLOAT_DECIMALS)]
    assert window._above([0.0, 0.0], 2) == [] and window._above([0.5], 0) == []


def test_a_stack_gets_one_v_from_a_sample_of_its_planes():
    stack = samples.fluorescence_stack((96, 96), planes=6)
    found = find_window(stack, crops=4, crop_size=48, max_planes=3, thresholds=GRID)
    assert {plane for plane, _, _ in found.crops} <= {0, 1, 2}
    assert found.found


def test_a_nan_pixel_in_a_crop_gives_way_to_a_finite_crop_nearby_in_rank(images):
    # a crop with one NaN pixel had an undefined edge enhancement at every V: no window
    image = images["camera"].astype(np.float32)
    clean = find_window(image, thresholds=GRID, crop_size=32)  # 36 cells, 6 strata
    for plane, top, left in clean.crops:
        holed = image.copy()
        holed[top + 5, left + 5] = np.nan  # in a crop the clean probe takes
        window = find_window(holed, thresholds=GRID, crop_size=32)
        assert window.found and not np.isnan(window.edge_enhancement).any()
        assert (plane, top, left) not in window.crops
        assert len(set(window.crops) - set(clean.crops)) == 1  # the other crops stay


def test_a_probe_of_crops_that_all_hold_nan_says_so(images):
    image = images["camera"].astype(np.float32)
    image[::9, ::9] = np.nan
    window = find_window(image, thresholds=GRID)
    assert not window.found
    assert "crops hold NaN or infinite pixels: no V could be measured" in window.summary()


def test_find_window_names_bad_arguments():
    image = np.zeros((32, 32), np.uint8)
    with pytest.raises(TypeError, match="variance_threshold"):
        find_window(image, variance_threshold=0.1)
    with pytest.raises(ValueError, match="crops"):
        find_window(image, crops=0)
    with pytest.raises(ValueError, match="widen"):
        find_window(image, widen=-1)
    with pytest.raises(ValueError, match="thresholds"):
        find_window(image, thresholds=[0.2, 0.1])
    with pytest.raises(ValueError, match="thresholds must be finite and between 0 and 1e\\+06"):
        find_window(image, thresholds=[0.1, 2e6])  # was probed: its V could not render
    with pytest.raises(ValueError, match="passes"):
        find_window(image, passes=-1)



def test_the_v_probed_above_the_top_stay_within_vs_bounds():
    from napari_labyrinth.window import _above

    assert _above([0.02, 0.04], 3) == [0.08, 0.16, 0.32]
    assert _above([2.5e5, 5e5], 3) == [1e6]  # 2e6 and 4e6 are beyond V's bound
    assert _above([5e5, 1e6], 3) == []

@pytest.mark.parametrize("shape", [(2, 2), (1, 40), (5, 2, 9)])
def test_planes_too_small_to_measure_are_refused_naming_the_image(shape):
    # the message named the internal "original" and the probe's mosaic, not the image
    image = np.arange(np.prod(shape)).reshape(shape).astype(np.uint8)
    plane = " x ".join(map(str, shape[-2:]))
    with pytest.raises(ValueError, match=f"image planes must be at least 3 x 3 .* got {plane}"):
        find_window(image)
    with pytest.raises(ValueError, match="image planes must be at least 3 x 3"):
        labyrinth(image, variance_threshold="auto")
    assert labyrinth(image).shape == image.shape


def test_auto_in_the_api_renders_with_the_chosen_v(camera_window):
    image, found = camera_window
    np.testing.assert_array_equal(
        labyrinth(image, variance_threshold=AUTO), labyrinth(image, variance_threshold=found.best)
    )
    np.testing.assert_array_equal(
        labyrinth_stack(image, passes=2, variance_threshold=AUTO),
        labyrinth_stack(image, passes=2, variance_threshold=find_window(image, passes=2).best),
    )


def test_auto_on_a_grey_and_alpha_image_probes_the_grey_channel_only(camera_window):
    grey, _ = camera_window
    image = np.stack([grey, np.full_like(grey, 200)], axis=-1)
    found = find_window(image, channel_axis=-1, alpha=True)
    assert {plane for plane, _, _ in found.crops} == {0}
    assert found == find_window(grey)  # the alpha channel plays no part
    rendered = labyrinth(image, channel_axis=-1, alpha=True, variance_threshold=AUTO)
    np.testing.assert_array_equal(rendered[..., 0], labyrinth(grey, variance_threshold=found.best))
    np.testing.assert_array_equal(rendered[..., 1], image[..., 1])


def test_auto_is_a_value_of_the_table_not_of_a_parameter_set():
    parameter = PARAMETERS["variance_threshold"]
    assert parameter.automatic and parameter.parse(" Auto ") == AUTO
    assert not PARAMETERS["mean_threshold"].automatic
    with pytest.raises(ValueError, match="mean_threshold must be a number; got 'auto'"):
        PARAMETERS["mean_threshold"].parse("auto")
    with pytest.raises(ValueError, match="chosen from the image"):
        resolve_parameters(variance_threshold=AUTO)
    with pytest.raises(TypeError, match="variance_threshold must be a real number or 'auto'"):
        labyrinth(np.zeros((8, 8), np.uint8), variance_threshold="automatic")
    assert without_auto({"variance_threshold": AUTO, "passes": 2}) == {"passes": 2}


def test_the_cli_prints_the_v_it_chose_and_renders_with_it(tmp_path, capsys):
    image = small_images(64)["fluorescence-16bit"]
    source, target = tmp_path / "cells.tif", tmp_path / "out.tif"
    write_image(source, image)
    assert main(["render", str(source), "-o", str(target), "--variance-threshold", "auto"]) == 0
    found = find_window(image)
    assert f"variance threshold auto: {found.summary()}" in capsys.readouterr().err
    expected = labyrinth(image, variance_threshold=found.best)
    np.testing.assert_array_equal(read_image(target), expected)
    assert main(["reproduce", str(target)]) == 0  # the record holds the chosen V
    assert main(["render", str(source), "-o", str(tmp_path / "set.tif"), "--set",
                 "variance_threshold=auto"]) == 0  # fmt: skip
    np.testing.assert_array_equal(read_image(tmp_path / "set.tif"), expected)


def test_the_cli_prints_why_it_chose_v_as_the_widget_does(tmp_path, capsys):
    smooth = samples.nematic_schlieren((128, 128), seed=0, noise=0.0) * 255.0
    image = np.rint(smooth).astype(np.uint8)
    source, target = tmp_path / "texture.png", tmp_path / "out.png"
    write_image(source, image)
    assert main(["render", str(source), "-o", str(target), "--variance-threshold", "auto"]) == 0
    found = find_window(image)
    assert found.reason.startswith("cover ") and ", aligned " in found.reason
    assert found.choice == f"V = {found.best:.4g}: {found.reason}"  # the widget's caption
    line = f"{source}: variance threshold auto: {found.choice} (window "
    assert line in capsys.readouterr().err


def test_the_cli_chooses_v_once_for_a_lazy_input(tmp_path, capsys, monkeypatch):
    image = small_images(64)["fluorescence-16bit"]
    zarr = pytest.importorskip("zarr")
    source, target = tmp_path / "cells.zarr", tmp_path / "out.tif"
    zarr.create_array(str(source), data=image)  # a zarr store is read lazily
    calls = []

    def counted(*args, **kwargs):
        calls.append(kwargs.get("tone_limits"))
        return find_window(*args, **kwargs)

    monkeypatch.setattr(window, "find_window", counted)
    assert main(["render", str(source), "-o", str(target), "--variance-threshold", "auto"]) == 0
    limits = resolve_tone_scale(image, None)
    assert calls == [(limits.low, limits.high)]  # once, on the limits of the whole data
    chosen = find_window(image, tone_limits=calls[0]).best
    assert f"variance threshold auto: V = {chosen:.4g}" in capsys.readouterr().err
    np.testing.assert_array_equal(
        read_image(target), labyrinth(image, variance_threshold=chosen, tone_limits=calls[0])
    )
