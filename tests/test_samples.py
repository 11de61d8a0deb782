"""Sample images: synthetic liquid-crystal textures and scikit-image photographs."""

from __future__ import annotations

import subprocess
import sys

import numpy as np
import pytest

from napari_labyrinth import samples
from napari_labyrinth.samples import (
    SAMPLES,
    cholesteric_fingerprint,
    director_angle,
    nematic_schlieren,
    schlieren_defects,
)


def dark_brushes_around(image: np.ndarray, y: float, x: float, radius: float) -> int:
    """Number of separate dark arcs on a circle around (y, x)."""
    angles = np.linspace(0.0, 2.0 * np.pi, 720, endpoint=False)
    rows = np.rint(y + radius * np.sin(angles)).astype(int)
    columns = np.rint(x + radius * np.cos(angles)).astype(int)
    dark = image[rows, columns] < 0.1
    assert dark.any() and not dark.all()
    # Count the starts of dark runs on the closed circle.
    return int(np.count_nonzero(dark & ~np.roll(dark, 1)))


# -- nematic Schlieren ----------------------------------------------------------------------------


def test_schlieren_shape_dtype_and_range():
    image = nematic_schlieren((96, 128), seed=4)
    assert image.shape == (96, 128)
    assert image.dtype == np.float32
    assert 0.0 <= image.min() and image.max() <= 1.0
    assert image.std() > 0.1  # bright and dark brushes, not a flat field


def test_schlieren_is_deterministic_per_seed():
    np.testing.assert_array_equal(
        nematic_schlieren((64, 64), seed=7), nematic_schlieren((64, 64), seed=7)
    )
    assert not np.array_equal(
        nematic_schlieren((64, 64), seed=7), nematic_schlieren((64, 64), seed=8)
    )


def test_schlieren_does_not_touch_the_global_random_state():
    state = np.random.get_state()[1].copy()
    nematic_schlieren((32, 32), seed=1)
    np.testing.assert_array_equal(np.random.get_state()[1], state)


@pytest.mark.parametrize("seed", range(20))
def test_seeded_defects_have_nematic_strengths_summing_to_zero(seed):
    defects = schlieren_defects((512, 512), seed=seed)
    strengths = defects[:, 2]
    assert defects.shape[1] == 3 and len(defects) >= 2
    assert set(strengths.tolist()) <= {-1.0, -0.5, 0.5, 1.0}
    assert strengths.sum() == 0.0
    assert (defects[:, 0] >= 0).all() and (defects[:, 0] <= 511).all()
    assert (defects[:, 1] >= 0).all() and (defects[:, 1] <= 511).all()


@pytest.mark.parametrize("count", [2, 3, 5, 8])
def test_defect_count(count):
    defects = schlieren_defects((256, 256), seed=1, count=count)
    assert len(defects) == count
    assert defects[:, 2].sum() == 0.0


def test_noiseless_texture_is_sin2_of_twice_the_director_angle():
    defects = schlieren_defects((128, 160), seed=5)
    image = nematic_schlieren((128, 160), seed=5, noise=0, theta0=0.3)
    theta = director_angle((128, 160), defects, theta0=0.3)
    np.testing.assert_allclose(image, np.sin(2 * theta) ** 2, atol=1e-6)
    # Dark brushes: the film is extinct wherever the director is along a polariser.
    extinct = np.abs(np.sin(2 * theta)) < 0.02
    assert extinct.sum() > 100
    assert image[extinct].max() < 1e-3
    bright = np.abs(np.sin(2 * theta)) > 0.99
    assert image[bright].min() > 0.98


@pytest.mark.parametrize(("strength", "brushes"), [(1.0, 4), (0.5, 2)])
def test_brushes_meet_at_defects_four_for_strength_one_two_for_one_half(strength, brushes):
    defects = [(64.3, 64.3, strength), (192.3, 192.3, -strength)]
    image = nematic_schlieren((256, 256), defects=defects, noise=0, theta0=0.2)
    for y, x, _ in defects:
        assert dark_brushes_around(image, y, x, radius=20) == brushes


def test_seeded_texture_has_the_brushes_its_defects_call_for():
    defects = [
        (50.25, 60.25, 1.0),
        (60.25, 190.25, -0.5),
        (190.25, 70.25, -0.5),
        (200.25, 200.25, 0.5),
        (128.25, 128.25, -0.5),
    ]
    image = nematic_schlieren((256, 256), defects=defects, noise=0, theta0=0.1)
    for y, x, strength in defects:
        assert dark_brushes_around(image, y, x, radius=10) == 4 * abs(strength)


def test_retardance_scales_the_intensity():
    plain = nematic_schlieren((64, 64), seed=2, noise=0)
    quarter = nematic_schlieren((64, 64), seed=2, noise=0, retardance=0.25)
    np.testing.assert_allclose(quarter, 0.5 * plain, atol=1e-6)
    assert nematic_schlieren((64, 64), seed=2, noise=0, retardance=1.0).max() < 1e-6
    field = np.linspace(0.0, 0.5, 64)[None, :]  # a thickness wedge
    wedge = nematic_schlieren((64, 64), seed=2, noise=0, retardance=field)
    np.testing.assert_allclose(wedge, plain * np.sin(np.pi * field) ** 2, atol=1e-6)


def test_noise_is_mild_and_seeded():
    clean = nematic_schlieren((128, 128), seed=3, noise=0)
    noisy = nematic_schlieren((128, 128), seed=3, noise=0.03)
    middle = (clean > 0.2) & (clean < 0.8)  # away from the clipping
    assert 0.02 < np.std(noisy[middle] - clean[middle]) < 0.04


@pytest.mark.parametrize(
    ("kwargs", "error"),
    [
        ({"shape": (0, 10)}, ValueError),
        ({"shape": (10,)}, TypeError),
        ({"noise": -1}, ValueError),
        ({"defects": [(1, 2)]}, ValueError),
        ({"defects": [(1, 2, 0.3)]}, ValueError),
        ({"retardance": np.zeros(3)}, ValueError),
        ({"seed": -1}, ValueError),
        ({"theta0": "x"}, TypeError),
    ],
)
def test_schlieren_rejects_bad_arguments(kwargs, error):
    kwargs = {"shape": (16, 16), **kwargs}
    with pytest.raises(error):
        nematic_schlieren(**kwargs)


# -- cholesteric fingerprint ----------------------------------------------------------------------


def test_fingerprint_shape_range_and_determinism():
    a = cholesteric_fingerprint((128, 96), seed=1)
    assert a.shape == (128, 96) and a.dtype == np.float32
    assert 0.0 <= a.min() and a.max() <= 1.0
    np.testing.assert_array_equal(a, cholesteric_fingerprint((128, 96), seed=1))
    assert not np.array_equal(a, cholesteric_fingerprint((128, 96), seed=2))


@pytest.mark.parametrize("pitch", [12.0, 24.0])
def test_fingerprint_stripes_repeat_every_half_pitch(pitch):
    image = cholesteric_fingerprint((256, 256), seed=0, pitch=pitch, noise=0)
    spectrum = np.abs(np.fft.fft2(image - image.mean())) ** 2
    k = np.hypot(*np.meshgrid(np.fft.fftfreq(256), np.fft.fftfreq(256), indexing="ij"))
    bins = np.arange(0.0, 0.5, 1 / 256)
    power, _ = np.histogram(k, bins=bins, weights=spectrum)
    peak = bins[np.argmax(power)] + 0.5 / 256
    assert peak == pytest.approx(2.0 / pitch, rel=0.15)
    # Stripes: bright and dark in about equal parts, with strong contrast.
    assert 0.35 < (image > 0.5).mean() < 0.65
    assert image.std() > 0.3


def test_fingerprint_rejects_bad_pitch():
    with pytest.raises(ValueError):
        cholesteric_fingerprint((32, 32), pitch=1)
    with pytest.raises(TypeError):
        cholesteric_fingerprint((32, 32), pitch=float("nan"))


# -- registry and photographs ---------------------------------------------------------------------


def test_samples_registry():
    assert set(SAMPLES) == {"nematic_schlieren", "cholesteric_fingerprint", "camera", "cell"}
    assert all(callable(f) for f in SAMPLES.values())


def test_photographs():
    from skimage import data

    np.testing.assert_array_equal(SAMPLES["camera"](), data.camera())
    np.testing.assert_array_equal(SAMPLES["cell"](), data.cell())
    assert samples.camera().dtype == np.uint8


def test_default_samples_from_the_registry():
    image = SAMPLES["nematic_schlieren"]()
    assert image.shape == (512, 512) and image.dtype == np.float32
    np.testing.assert_array_equal(image, nematic_schlieren())


@pytest.mark.subprocess
def test_importing_samples_is_light():
    code = (
        "import sys, napari_labyrinth.samples; "
        "print(any(m.split('.')[0] in ('skimage', 'napari', 'numba') for m in sys.modules))"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "False"
