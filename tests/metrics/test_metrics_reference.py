"""The metrics agree with their previous implementation (``_metrics_reference``) on many images.

Tolerances, and why:

- ``fine_scale``, ``wall_map``, ``labyrinth_cover`` and ``wall_width``: exactly
  equal. The Gaussians behind them, the lag correlations' included, are
  computed as ``scipy.ndimage`` computes them, operation for operation, in
  float64, so the wall map is the same boolean map.
- ``texture_added`` and ``edge_enhancement``: relative 1e-9 (sums in a
  different order; the energy added is ``G * h1**2 - G * h0**2`` instead of
  ``G * (h1**2 - h0**2)``).
- ``orientation_coherence``: relative 5e-4, ``contour_alignment``: relative
  2e-3. Both structure tensors (the walls' at sigma 2, the input's contours
  at sigma 4) are a different window now: the doubled grid's products are
  filtered 1-2-1 and sampled on the original grid, then smoothed by a
  Gaussian of the same total variance (``metrics._kernels.decimated_tensor_band``),
  where the reference smooths the doubled grid itself; the windows differ by
  a few per cent of a weight (linear interpolation of the Gaussian between
  its even taps). On these cases the coherence moves by at most 2.7e-4
  (relative) and the alignment by at most 1.3e-3 (the ``branches`` crop),
  most by 1e-5 to 2e-4. Planes narrower than the walls' window (17 pixels)
  are mostly edge, where the windows differ most: relative 1e-2 (the 20 x 4
  case moves by 3.3e-3 and 7.5e-3).

NaN and infinite pixels give the reference's NaN metrics (texture added,
coherence, alignment and edge enhancement), and the wall metrics of the rest.
"""

import math

import numpy as np
import pytest
from scipy import ndimage

from napari_labyrinth import labyrinth, metrics, samples

from . import _metrics_reference as reference

EXACT = ("labyrinth_cover", "wall_width")
RTOL = {
    "texture_added": 1e-9,
    "edge_enhancement": 1e-9,
    "orientation_coherence": 5e-4,
    "contour_alignment": 2e-3,
}
#: The tolerances of the structure-tensor metrics on planes narrower than the walls' window.
NARROW_RTOL = {"orientation_coherence": 1e-2, "contour_alignment": 1e-2}
NARROW = 17


def rtol(key, shape):
    """The tolerance of metric ``key`` on a plane of ``shape`` (see the module's docstring)."""
    return NARROW_RTOL.get(key, RTOL[key]) if min(shape) < NARROW else RTOL[key]


def _crop(image, top, left, size):
    return np.ascontiguousarray(image[top : top + size, left : left + size])


def _grey(image):
    from skimage import color, util

    return util.img_as_ubyte(color.rgb2gray(image)) if image.ndim == 3 else image


def _study_images(size=160):
    """Crops of the study's images (``benchmarks/study.py``)."""
    from skimage import data, transform, util

    retina = transform.resize(data.retina()[..., 1], (640, 640), anti_aliasing=True)
    return {
        "portrait": _crop(_grey(data.astronaut()), 20, 120, size),
        "landscape": _crop(_grey(data.rocket()), 150, 100, size),
        "microscopy": _crop(_grey(data.immunohistochemistry()), 100, 100, size),
        "branches": _crop(util.img_as_ubyte(retina), 160, 160, size),
        "liquid-crystal": util.img_as_ubyte(samples.nematic_schlieren((size, size), seed=0)),
    }


def _walls(pattern):
    return np.where(pattern > np.median(pattern), 230.0, 30.0)


def _cases():
    """(name, original, rendered) triples: photographs, textures, noise, synthetic walls."""
    rng = np.random.default_rng(7)
    cases = []
    for name, image in _study_images().items():
        # the renderings these tolerances were measured on: the default preset before its
        # noise gate (the gate leaves a noisier mix of walls on the liquid crystal, whose
        # orientation coherence then differs by 8.5e-4 between the two implementations)
        cases.append((name, image, labyrinth(image, seed=1, noise_gate=0)))
    cases.append(("portrait, paper preset", cases[0][1], labyrinth(cases[0][1], preset="paper")))
    camera = samples.camera()
    cases.append(("camera", camera, labyrinth(camera, seed=2)))
    cases.append(("camera, 2 passes, paper", camera, labyrinth(camera, preset="paper", passes=2)))
    cell = _crop(samples.cell(), 200, 150, 200)
    cases.append(("cell", cell, labyrinth(cell, seed=3)))
    for name in ("nematic_schlieren", "cholesteric_fingerprint"):
        texture = samples.SAMPLES[name]()[:192, :224] * np.float32(255)
        cases.append((name, texture, labyrinth(texture, seed=4)))
        cases.append((name + " as walls", texture, _walls(texture)))
    y, x = np.mgrid[:150, :170]
    radius = np.hypot(y - 75, x - 85)
    smooth = 60 + 0.3 * x + 120 / (1 + np.exp((radius - 45) / 3.0))
    rings = np.where(np.abs(radius - 45) < 14, _walls(np.cos(2 * np.pi * radius / 4.0)), smooth)
    cases.append(("synthetic labyrinth", smooth, rings))
    cases.append(("1-pixel stripes", smooth, _walls(np.cos(np.pi * x))))
    noise = rng.normal(128, 40, (130, 150))
    cases.append(("noise", noise, noise + rng.normal(0, 10, noise.shape)))
    cases.append(("blur", smooth, ndimage.gaussian_filter(smooth, 3)))
    cases.append(("unchanged", camera[:100, :120], camera[:100, :120].copy()))
    image16 = (camera[100:260, 50:230].astype(np.uint16) * 257) // 3
    cases.append(("uint16", image16 // 257, labyrinth(image16, seed=5) // 257))
    cases.append(
        (
            "float32",
            camera[:128, :96].astype(np.float32),
            labyrinth(camera[:128, :96], seed=6).astype(np.float32),
        )
    )
    strided = labyrinth(camera, seed=8)[::3, ::2]
    cases.append(("strided view", camera[::3, ::2], strided))
    cases.append(
        ("transposed view", camera[:200, :150].T, labyrinth(camera[:200, :150], seed=9).T)
    )
    scaled = labyrinth(camera[:160, :140], seed=10).astype(float)
    for factor in (1e-30, 1e30):  # float32 would overflow or lose its digits unscaled
        cases.append((f"times {factor:g}", camera[:160, :140] * factor, scaled * factor))
    holes = camera[:160, :140].astype(float), scaled.copy()
    holes[0][80, 70] = holes[1][80, 70] = np.nan  # NaN pixels stay NaN through a rendering
    cases.append(("a NaN pixel", *holes))
    for shape in ((3, 3), (5, 7), (9, 17), (20, 4)):
        tiny = rng.integers(0, 256, shape).astype(np.uint8)
        cases.append((f"{shape[0]} x {shape[1]}", tiny, np.flipud(tiny).copy()))
    return cases


CASES = _cases()
IDS = [name for name, _, _ in CASES]


def deviation(old: float, new: float) -> float:
    """Relative difference (0 for equal values, NaN for NaN against a number)."""
    if math.isnan(old) or math.isnan(new):
        return 0.0 if math.isnan(old) and math.isnan(new) else math.nan
    if old == new:
        return 0.0
    return abs(new - old) / abs(old)


@pytest.mark.parametrize(("name", "original", "rendered"), CASES, ids=IDS)
def test_every_metric_agrees_with_the_previous_implementation(name, original, rendered):
    old = reference.describe(original, rendered)
    new = metrics.describe(original, rendered)
    assert list(new) == list(old)
    for key in EXACT:
        assert new[key] == old[key] or (math.isnan(new[key]) and math.isnan(old[key])), key
    for key in RTOL:
        tolerance = rtol(key, original.shape)
        assert deviation(old[key], new[key]) <= tolerance, (key, old[key], new[key])
    # the single metrics, each called alone, agree too
    assert metrics.labyrinth_cover(rendered) == reference.labyrinth_cover(rendered)
    single = metrics.contour_alignment(original, rendered)
    old_single = reference.contour_alignment(original, rendered)
    assert deviation(old_single, single) <= rtol("contour_alignment", original.shape)


@pytest.mark.parametrize(("name", "original", "rendered"), CASES, ids=IDS)
def test_the_maps_are_the_reference_maps(name, original, rendered):
    np.testing.assert_array_equal(metrics.fine_scale(rendered), reference.fine_scale(rendered))
    np.testing.assert_array_equal(metrics.fine_scale(original), reference.fine_scale(original))
    np.testing.assert_array_equal(metrics.wall_map(rendered), reference.wall_map(rendered))


@pytest.mark.parametrize("sigma", [metrics.WINDOW_SIGMA, 4.0, 1.5])
@pytest.mark.parametrize("index", [0, 6, 9, 16])
def test_orientation_agrees_with_the_structure_tensor_of_scikit_image(index, sigma):
    _, original, rendered = CASES[index]
    for image in (original, metrics.fine_scale(rendered)):
        angle, coherence, strength = metrics.orientation(image, sigma)
        old_angle, old_coherence, old_strength = reference.orientation(image, sigma)
        scale = old_strength.max()
        np.testing.assert_allclose(strength, old_strength, rtol=0, atol=1e-6 * scale)
        reliable = old_strength > 1e-3 * scale
        np.testing.assert_allclose(coherence[reliable], old_coherence[reliable], rtol=0, atol=1e-4)
        # angles modulo pi, where there is an orientation to speak of
        oriented = reliable & (old_coherence > 1e-2)
        assert np.all(np.cos(2 * (angle - old_angle))[oriented] > 1 - 1e-6)


def test_the_study_images_at_full_size_agree():
    """One larger case through several threads and column tiles (512 x 512)."""
    image = _grey(__import__("skimage").data.astronaut())[:512, :512]
    rendered = labyrinth(image, seed=0)
    old = reference.describe(image, rendered)
    for workers in (1, 3):
        new = metrics.describe(image, rendered, workers=workers)
        for key in EXACT:
            assert new[key] == old[key], key
        for key, tolerance in RTOL.items():
            assert deviation(old[key], new[key]) <= tolerance, key
