"""The noise gate: the noise estimate, the option's bounds, and the presets with and without it.

The kernel's branch is checked against the oracle in ``test_kernel.py`` (the grid
with the gate on, and a pixel just at and just above the floor).
"""

import hashlib

import numpy as np
import pytest

from napari_labyrinth import labyrinth, labyrinth_steps, resolve_parameters, samples
from napari_labyrinth.core._reference import reference_render
from napari_labyrinth.core.noise import (
    dark_field_sigma,
    noise_sigma,
    tone_noise_sigma,
    variance_floor,
)
from napari_labyrinth.core.parameters import PARAMETERS
from napari_labyrinth.core.presets import PRESETS
from napari_labyrinth.core.tone_scale import ToneScale, resolve_tone_scale


def _digest(array) -> str:
    return hashlib.sha256(np.ascontiguousarray(array).tobytes()).hexdigest()[:16]


@pytest.mark.parametrize("sigma", [2.0, 4.0, 8.0])
@pytest.mark.parametrize("dtype", [np.uint8, np.uint16, np.float32])
def test_the_estimate_finds_the_deviation_of_white_noise_within_ten_percent(sigma, dtype):
    rng = np.random.default_rng(int(sigma))
    y, x = np.mgrid[:256, :300]
    smooth = 100.0 + 0.2 * x + 40.0 * np.sin(y / 40.0)  # ramps and curves cancel, or nearly
    plane = smooth + rng.normal(0.0, sigma, smooth.shape)
    if dtype != np.float32:
        plane = np.rint(plane)
    estimate = noise_sigma(plane.astype(dtype))
    assert abs(estimate - sigma) < 0.1 * sigma, estimate


def test_the_estimate_of_a_flat_or_tiny_plane_is_zero_and_ignores_non_finite_values():
    assert noise_sigma(np.full((50, 40), 7, np.uint8)) == 0.0
    assert noise_sigma(np.ones((2, 40))) == 0.0
    rng = np.random.default_rng(0)
    plane = rng.normal(100.0, 3.0, (200, 200)).astype(np.float32)
    holed = plane.copy()
    holed[50:60, :] = np.nan
    holed[5, 5] = np.inf
    assert abs(noise_sigma(holed) - noise_sigma(plane)) < 0.1
    assert noise_sigma(np.full((9, 9), np.nan, np.float32)) == 0.0


def test_the_noise_in_tones_is_the_values_noise_times_the_gain():
    rng = np.random.default_rng(1)
    values = np.rint(rng.normal(1000.0, 20.0, (128, 128))).astype(np.uint16)
    scale = ToneScale(900.0, 1410.0)  # gain 0.5
    assert tone_noise_sigma(values, scale) == noise_sigma(values) * 0.5


def test_the_floor_is_k_sigma_squared_and_negative_when_off():
    assert variance_floor(2.0, 3.0) == 36.0
    assert variance_floor(0.0, 3.0) < 0.0
    assert variance_floor(1.5, 0.0) == 0.0


def test_the_gate_is_on_in_the_labyrinth_preset_and_off_in_the_paper_preset():
    assert PRESETS["labyrinth"]["noise_gate"] > 0
    assert PRESETS["paper"]["noise_gate"] == 0 == PARAMETERS["noise_gate"].paper


@pytest.mark.parametrize(
    "value, error", [(-0.5, ValueError), (float("inf"), ValueError), (101.0, ValueError),
                     ("2", TypeError), (True, TypeError)],
)  # fmt: skip
def test_bad_values_are_refused_naming_noise_gate(value, error):
    with pytest.raises(error, match="noise_gate"):
        resolve_parameters("labyrinth", noise_gate=value)
    with pytest.raises(error, match="noise_gate"):
        labyrinth(np.zeros((8, 8), np.uint8), noise_gate=value)


#: Digests of renderings made before the gate existed (the paper preset, and the labyrinth
#: preset with the gate off): both must stay bit for bit what they were.
BEFORE_THE_GATE = {
    "dark": "cd5d6e67640b202b",
    "fluorescence": "026a1c0de8477ec2",
    "dark_push_variance_first": "7317cd23c139f01d",
    "dark_labyrinth_gate_off": "738698b534e60e6d",
}


def test_the_paper_preset_and_a_gate_of_zero_render_as_before_the_gate():
    dark = samples.smectic_batonnets((96, 96), seed=3)
    fluorescence = samples.fluorescence_stack((64, 80), planes=2, seed=1)
    push = dict(variance_action="push_in_range", condition_order="variance_first")
    got = {
        "dark": labyrinth(dark, preset="paper", passes=2, seed=4),
        "fluorescence": labyrinth(fluorescence, preset="paper", passes=3, seed=1),
        "dark_push_variance_first": labyrinth(dark, preset="paper", passes=2, **push),
        "dark_labyrinth_gate_off": labyrinth(dark, seed=4, noise_gate=0),
    }
    assert {name: _digest(image) for name, image in got.items()} == BEFORE_THE_GATE


@pytest.mark.parametrize("preset", ["labyrinth", "paper"])
def test_a_rendering_with_the_gate_is_the_oracle_s(preset):
    dark = samples.smectic_batonnets((40, 48), seed=2)
    options = dict(preset=preset, noise_gate=1.5, passes=2, seed=3)
    result = list(labyrinth_steps(dark, **options))[-1]
    parameters = resolve_parameters(preset, noise_gate=1.5, passes=2)
    (sigma,) = result.noise_sigma
    assert sigma == tone_noise_sigma(dark, ToneScale(0.0, 255.0))  # uint8: its own tones
    want, counts = reference_render(dark.astype(np.float32), parameters, seed=3)
    np.testing.assert_array_equal(result.image, np.rint(want).astype(np.uint8))
    assert sum(c["noise_gated"] for c in counts) > 0
    diagnostics = list(labyrinth_steps(dark, **options))[-1].diagnostics
    assert [c["noise_gated"] for c in counts] == diagnostics["noise_gated"].tolist()


def test_the_gate_keeps_a_black_field_black():
    dark = samples.smectic_batonnets((128, 128), seed=0)
    field = dark < 12  # the melt around the batonnets, and its noise
    before = labyrinth(dark, noise_gate=0)
    after = labyrinth(dark)
    assert (before != dark)[field].mean() > 0.15
    assert (after != dark)[field].mean() < 0.05


def test_the_dark_field_s_noise_is_found_in_its_local_variance_even_through_a_jpeg():
    import io

    import imageio.v3 as iio

    rng = np.random.default_rng(3)
    field = np.clip(np.rint(10.0 + rng.normal(0.0, 3.0, (256, 256))), 0, 255).astype(np.uint8)
    paper = ToneScale(0.0, 255.0)
    assert abs(tone_noise_sigma(field, paper) - 3.0) < 0.3
    buffer = io.BytesIO()
    iio.imwrite(buffer, field, extension=".jpg", quality=85)
    compressed = iio.imread(buffer.getvalue(), extension=".jpg")
    # the JPEG keeps little at the highest frequencies: Immerkær reads a fraction of what
    # is left of the noise, the dark field's variance reads it
    sigma = tone_noise_sigma(compressed, paper)
    assert abs(sigma - compressed.std()) < 0.2 * compressed.std()
    assert noise_sigma(compressed) < 0.5 * sigma
    bright = compressed.astype(np.uint16) + 100  # no dark field: Immerkær's alone
    assert tone_noise_sigma(bright, paper) == noise_sigma(bright)


@pytest.mark.parametrize("band_rows", [1, 3, 17, 256, 10_000])
def test_the_noise_of_a_plane_does_not_depend_on_the_bands_it_is_read_in(band_rows):
    # a plane read band by band from a file gets the number of the plane held whole
    rng = np.random.default_rng(8)
    plane = np.clip(rng.normal(30, 9, (301, 77)), 0, 255).astype(np.uint8)
    plane[100:200, 20:60] = 220
    scale = resolve_tone_scale(plane, None)
    assert tone_noise_sigma(plane, scale, band_rows=band_rows) == tone_noise_sigma(plane, scale)


@pytest.mark.parametrize("sigma", [1.0, 2.0, 4.0])
def test_the_dark_field_s_estimate_finds_the_deviation_of_white_noise_within_ten_percent(sigma):
    rng = np.random.default_rng(int(10 * sigma))
    field = (8.0 + rng.normal(0.0, sigma, (256, 300))).astype(np.float32)
    estimate = dark_field_sigma(field, ToneScale(0.0, 255.0))
    assert abs(estimate - sigma) < 0.1 * sigma, estimate


def _jpeg(plane: np.ndarray, quality: int) -> np.ndarray:
    import io

    import imageio.v3 as iio

    buffer = io.BytesIO()
    iio.imwrite(buffer, plane, extension=".jpg", quality=quality)
    return iio.imread(buffer.getvalue(), extension=".jpg")


def test_the_dark_field_s_estimate_reads_correlated_noise_within_twenty_percent():
    # noise correlated between neighbours spreads less around the neighbours' own mean than
    # the field's values do around theirs: V's median under-read it by a quarter
    from scipy import ndimage

    rng = np.random.default_rng(5)
    paper = ToneScale(0.0, 255.0)
    blurred = (10.0 + ndimage.uniform_filter(rng.normal(0.0, 6.0, (256, 256)), 3)).astype(np.float32)
    camera = np.clip(np.rint(6.0 + rng.normal(0.0, 2.0, (256, 256))), 0, 255).astype(np.uint8)
    compressed = _jpeg(camera, quality=80)  # the blocks of a JPEG, as a browser saves it
    for field in (blurred, compressed):
        deviation = float(field.std())
        sigma = dark_field_sigma(field, paper)
        assert abs(sigma - deviation) < 0.2 * deviation, (sigma, deviation)
