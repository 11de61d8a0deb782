"""The default tone limits of a lazy image: streamed, and equal to numpy's bit for bit.

Every dtype, masses of equal values, NaN and infinities, subnormal values and
far outliers, with bins split again and again (``GATHER_LIMIT``).
"""

from __future__ import annotations

import numpy as np
import pytest

from napari_labyrinth.lazy import default_tone_limits, streamed_percentiles

from ..cli.test_cli_chunked import textured

da = pytest.importorskip("dask.array")


def random_values(rng, dtype, size):
    dtype = np.dtype(dtype)
    if dtype.kind in "iu":
        info = np.iinfo(dtype)
        wide = rng.integers(info.min, int(info.max) + 1, size, dtype=dtype)
        narrow = rng.integers(0, 40, size).astype(dtype)
        return wide if rng.random() < 0.5 else narrow
    values = (rng.standard_normal(size) * 10.0 ** rng.integers(-3, 4)).astype(dtype)
    values[rng.random(size) < 0.05] = np.nan
    values[rng.random(size) < 0.02] = np.inf
    values[: size // 3] = 0  # a mass of equal values
    return values


@pytest.mark.parametrize(
    "dtype", ["uint16", "int16", "int8", "uint32", "int32", "float16", "float32", "float64"]
)
@pytest.mark.parametrize("gather_limit", [1 << 18, 3])
def test_streamed_percentiles_equal_numpy_bit_for_bit(monkeypatch, dtype, gather_limit):
    # 3: every bin is split again
    monkeypatch.setattr(streamed_percentiles, "GATHER_LIMIT", gather_limit)
    rng = np.random.default_rng(abs(hash((dtype, gather_limit))) % 2**32)
    for _ in range(4):
        size = int(rng.integers(1, 1500))
        values = random_values(rng, dtype, size).reshape(1, size)
        lazy = da.from_array(values, chunks=(1, max(1, size // 4)))
        finite = values[np.isfinite(values)]
        expected = [float(v) for v in np.percentile(finite, (0.5, 99.5))] if finite.size else None
        assert streamed_percentiles.percentiles(lazy, (0.5, 99.5)) == expected


@pytest.mark.parametrize(
    "offset, span",
    [
        (0.0, 1e-310),
        (0.0, 5e-320),
        (-3e-308, 1e-308),
        (1e-300, 1e-300),
        (1.0, 1e-15),
        (0.0, 1e-250),
    ],
)
@pytest.mark.parametrize("gather_limit", [1 << 18, 3])
def test_streamed_percentiles_of_values_closer_than_normal_floats(
    monkeypatch, offset, span, gather_limit
):
    """Subnormal values, and spans so small that the histograms' scale would overflow
    float64 after a few levels: still numpy's percentiles, bit for bit."""
    monkeypatch.setattr(streamed_percentiles, "GATHER_LIMIT", gather_limit)
    rng = np.random.default_rng(11)
    values = (offset + rng.random((1, 997)) * span).astype(np.float64)
    values[0, :300] = values[0, 0]  # a mass of equal values
    lazy = da.from_array(values, chunks=(1, 250))
    expected = [float(v) for v in np.percentile(values, (0.5, 99.5))]
    assert streamed_percentiles.percentiles(lazy, (0.5, 99.5)) == expected


@pytest.mark.parametrize(
    "dtype, outliers",
    [("float32", [-3.4028235e38]), ("float64", [1e300]), ("float64", [-1e308, 1e308]),
     ("float32", [3e38, -3e38, 2e38])],  # fmt: skip
)
@pytest.mark.parametrize("gather_limit", [1 << 18, 3])
def test_streamed_percentiles_of_values_beside_far_outliers(
    monkeypatch, dtype, outliers, gather_limit
):
    """A NoData value of -3.4e38 beside values in [0, 1] left the values one bin of every
    histogram over the whole range: 8 levels gave up ("cannot find the default tone
    limits"). Each split histogram spans its own values' range."""
    monkeypatch.setattr(streamed_percentiles, "GATHER_LIMIT", gather_limit)
    values = np.random.default_rng(3).random((4, 4096)).astype(dtype)
    values[:, : len(outliers)] = outliers
    lazy = da.from_array(values, chunks=(1, 4096))
    expected = [float(v) for v in np.percentile(values, (0.5, 99.5))]
    assert streamed_percentiles.percentiles(lazy, (0.5, 99.5)) == expected


def test_default_tone_limits_match_the_api(monkeypatch):
    from napari_labyrinth.core.tone_scale import resolve_tone_scale

    rng = np.random.default_rng(3)
    cases = [
        textured(dtype=np.uint16),
        textured(dtype=np.float32),
        np.full((2, 8, 8), 7, np.int32),  # constant: high = low + 1
        np.full((2, 8, 8), np.nan, np.float32),  # nothing finite: (0, 1)
        rng.integers(0, 2**31, (3, 16, 16), dtype=np.int32),
    ]
    for image in cases:
        scale = resolve_tone_scale(image, None)
        lazy = da.from_array(image, chunks=(1,) + image.shape[1:])
        assert default_tone_limits(lazy) == (scale.low, scale.high)
        assert default_tone_limits(image) == (scale.low, scale.high)
    rgba = rng.integers(0, 4000, (2, 8, 8, 4), dtype=np.uint16)
    rgba[..., 3] = 65535  # alpha does not count
    scale = resolve_tone_scale(rgba[..., :3], None)
    lazy = da.from_array(rgba, chunks=(1, 8, 8, 4))
    assert default_tone_limits(lazy, channel_axis=-1) == (scale.low, scale.high)
