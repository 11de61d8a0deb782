"""The noise estimate's compiled sweep against the numpy reading it replaced, bit for bit.

``core._noise_reference`` is the numpy code the noise gate measured with before
(the oracle); ``core.noise`` now measures in one sweep of ``core._noise_loops``.
The float64 it returns, and so every pixel the gate leaves, must not change.
"""

import numpy as np
import pytest

from napari_labyrinth import labyrinth, labyrinth_steps, samples
from napari_labyrinth.core import _noise_loops, _noise_reference, noise
from napari_labyrinth.core.noise import dark_field_sigma, noise_sigma, tone_noise_sigma
from napari_labyrinth.core.tone_scale import ToneScale, resolve_tone_scale


def _same(a: float, b: float) -> bool:
    return np.float64(a).tobytes() == np.float64(b).tobytes()


def _planes():
    """Planes of every kind the gate measures: dtypes, dark fields, holes, odd shapes."""
    rng = np.random.default_rng(11)
    planes = {}
    for dtype in (np.uint8, np.uint16, np.int16, np.int8, np.uint32, np.int32):
        info = np.iinfo(dtype)
        field = rng.normal(0.3, 0.1, (97, 131))
        field[30:60, 40:90] += 0.5  # an edge
        values = info.min + np.clip(field, 0, 1) * (float(info.max) - info.min)
        planes[f"{np.dtype(dtype).name}"] = values.astype(dtype)
    for dtype in (np.float16, np.float32, np.float64):
        values = rng.normal(0.2, 0.05, (83, 140)).astype(dtype)
        planes[f"{np.dtype(dtype).name}"] = values
    holed = rng.normal(100.0, 3.0, (120, 90)).astype(np.float32)
    holed[50:60, :] = np.nan
    holed[5, 5] = np.inf
    holed[7, 80] = -np.inf
    planes["float32 holes"] = holed
    planes["all nan"] = np.full((9, 9), np.nan, np.float32)
    planes["dark field"] = samples.smectic_batonnets((160, 176), seed=3)
    planes["dark ties"] = np.clip(np.rint(rng.normal(6.0, 2.0, (150, 150))), 0, 255).astype(np.uint8)
    planes["flat"] = np.full((50, 40), 7, np.uint8)
    for shape in [(3, 3), (3, 50), (50, 3), (4, 9), (2, 40), (40, 2), (1, 1)]:
        planes[f"shape {shape}"] = rng.integers(0, 40, shape).astype(np.uint8)
    # a dark share just at and around MIN_DARK_SHARE of the sampled pixels
    for rows in (4, 5, 6):
        edge = np.full((100, 102), 200, np.uint8)
        edge[:rows] = rng.integers(0, 8, (rows, 102))
        planes[f"dark rows {rows}"] = edge
    return planes


PLANES = _planes()


@pytest.mark.parametrize("name", sorted(PLANES))
def test_the_noise_is_the_numpy_reading_s_bit_for_bit(name):
    plane = PLANES[name]
    scale = resolve_tone_scale(plane, None) if np.isfinite(plane).any() else ToneScale(0, 1)
    want = _noise_reference.tone_noise_sigma(plane, scale)
    assert _same(tone_noise_sigma(plane, scale), want)
    assert _same(noise_sigma(plane), _noise_reference.noise_sigma(plane))
    assert _same(dark_field_sigma(plane, scale), _noise_reference.dark_field_sigma(plane, scale))


@pytest.mark.parametrize("name", ["uint16", "float32 holes", "dark field", "dark ties"])
def test_other_scales_strided_views_and_bands_give_the_numpy_reading_s_noise(name):
    plane = PLANES[name]
    for scale in (ToneScale(0.0, 255.0), ToneScale(-3.5, 70.25), ToneScale(1e-3, 2e4)):
        want = _noise_reference.tone_noise_sigma(plane, scale)
        assert _same(tone_noise_sigma(plane, scale), want)
        for band_rows in (1, 2, 3, 17):
            assert _same(tone_noise_sigma(plane, scale, band_rows=band_rows), want)
    view = plane[::2, 1::3]  # not contiguous: the tones of numpy's to_tones
    scale = ToneScale(0.0, 255.0)
    assert _same(tone_noise_sigma(view, scale), _noise_reference.tone_noise_sigma(view, scale))


@pytest.mark.parametrize("workers", [2, 3, 4])
def test_threads_share_the_rows_and_give_the_number_of_one(workers):
    rng = np.random.default_rng(workers)
    plane = np.clip(rng.normal(12, 4, (1031, 300)), 0, 255).astype(np.uint8)
    plane[400:700, 100:200] = 180  # bright: the dark field's share
    for scale in (ToneScale(0.0, 255.0), ToneScale(0.0, 254.0)):  # in integers; in floats
        want = _noise_reference.tone_noise_sigma(plane, scale)
        assert _same(tone_noise_sigma(plane, scale, workers=workers), want)
        assert _same(tone_noise_sigma(plane, scale, workers=1), want)


def test_a_large_plane_sampled_with_a_stride_gives_the_numpy_reading_s_noise():
    rng = np.random.default_rng(4)
    plane = np.clip(rng.normal(10, 3, (1500, 1100)), 0, 255).astype(np.uint8)
    plane[:, 700:] = 140
    assert noise.dark_stride(*plane.shape) > 1
    for scale in (ToneScale(0.0, 255.0), ToneScale(0.0, 254.0)):
        want = _noise_reference.tone_noise_sigma(plane, scale)
        for workers in (1, 2):
            assert _same(tone_noise_sigma(plane, scale, workers=workers), want)


class _CountedBands:
    """A plane that reads its rows itself and notes every read (as ``io.bands.PlaneBands``)."""

    def __init__(self, plane):
        self.plane, self.shape, self.ndim, self.dtype = plane, plane.shape, 2, plane.dtype
        self.reads = []

    def __getitem__(self, rows):
        self.reads.append(rows)
        return self.plane[rows].copy()


def test_a_plane_read_band_by_band_is_read_once_for_its_noise():
    # before, the dark field read its sampled rows again after Immerkær's sweep
    plane = samples.smectic_batonnets((301, 77), seed=1)
    bands = _CountedBands(plane)
    scale = ToneScale(0.0, 255.0)
    sigma = tone_noise_sigma(bands, scale, band_rows=64)
    assert _same(sigma, _noise_reference.tone_noise_sigma(plane, scale, band_rows=64))
    assert all(isinstance(rows, slice) for rows in bands.reads)
    read = np.concatenate([np.arange(301)[rows] for rows in bands.reads])
    assert np.array_equal(read, np.arange(301))  # each row once, in order


@pytest.mark.parametrize("width", [*range(3, 42), 129, 130, 131, 257, 258, 259, 1002, 2048, 40_002])
def test_a_row_is_summed_as_numpy_sums_it(width):
    # numpy sums a row pairwise (8 lanes in blocks of 128, halves of a multiple of 8):
    # residuals of very different sizes show any other order
    rng = np.random.default_rng(width)
    plane = rng.standard_cauchy((5, width)) * rng.choice([1e-6, 1.0, 1e6], (5, width))
    plane[2, ::7] = np.nan
    residuals = np.abs(_noise_reference._mask_residual(plane))
    want = np.where(np.isfinite(residuals), residuals, 0.0).sum(axis=1)
    row_sums, counts = np.zeros(5), np.zeros(3, np.int64)
    histogram = np.zeros(_noise_loops.HISTOGRAM_BINS, np.int64)
    _noise_loops.band_noise(plane, 0, 0, row_sums, np.empty(1), histogram, counts)
    assert [_same(got, sum_) for got, sum_ in zip(row_sums[1:4], want)] == [True] * 3
    assert counts[0] == np.isfinite(residuals).sum()


@pytest.mark.parametrize("n", [1, 2, 3, 9, 10, 11, 12, 100, 1001, 5000])
@pytest.mark.parametrize("kind", ["spread", "ties", "one value"])
def test_the_dark_quantile_is_numpy_s_bit_for_bit(n, kind):
    rng = np.random.default_rng(n)
    if kind == "spread":
        values = rng.chisquare(7, n) * rng.choice([1e-3, 1.0, 400.0], n)
    elif kind == "ties":
        values = rng.integers(0, 30, n) / 64.0  # V of integer tones: multiples of 1/64
    else:
        values = np.full(n, 2.375)
    values[: n // 7] = 0.0
    want = float(np.quantile(values, noise.DARK_QUANTILE))
    assert _same(_measures_of(values)._quantile(), want)


def _measures_of(values):
    """A sweep's measures holding ``values`` as its dark V's, split in two shares."""
    histogram = np.zeros(_noise_loops.HISTOGRAM_BINS, np.int64)
    np.add.at(histogram, values.view(np.int64) >> _noise_loops.HISTOGRAM_SHIFT, 1)
    half = values.size // 2
    buffer = np.concatenate([values[:half], [7.0, 7.0], values[half:]])  # a gap between
    return noise._Measures(
        np.zeros(3), dark=values.size, variances=buffer, starts=np.array([0, half + 2]),
        ends=np.array([half, buffer.size]), histogram=histogram,
    )  # fmt: skip


def test_the_loops_dark_tone_is_the_noise_gate_s():
    assert _noise_loops.DARK_TONE == noise.DARK_TONE


def test_renderings_with_the_gate_are_those_of_the_numpy_reading_s_sigma(monkeypatch):
    from napari_labyrinth import _engine
    from napari_labyrinth._engine import passes, render_loop

    for module in (passes, render_loop, _engine):
        monkeypatch.setattr(module, "idle_cores", lambda: 2)  # as on an idle machine
    image = samples.smectic_batonnets((600, 480), seed=5)
    scale = ToneScale(0.0, 255.0)
    sigma = _noise_reference.tone_noise_sigma(image, scale)
    for workers in (1, 2):
        result = list(labyrinth_steps(image, passes=2, seed=1, workers=workers))[-1]
        assert result.noise_sigma == (sigma,)
        assert np.array_equal(result.image, labyrinth(image, passes=2, seed=1, workers=1))
    stack = np.stack([image, image[::-1].copy()])
    result = list(labyrinth_steps(stack, passes=1, workers=2))[-1]
    want = tuple(_noise_reference.tone_noise_sigma(plane, scale) for plane in stack)
    assert result.noise_sigma == want
    assert np.array_equal(result.image, labyrinth(stack, passes=1, workers=1))
