"""Test images shared by the tests of planes rendered band by band."""

from __future__ import annotations

import numpy as np


def smooth(dtype, shape, seed=0, stripes=(30, 29, 5)) -> np.ndarray:
    """A smooth random texture with sharp stripes, on most of the dtype's range.

    ``stripes``: their height over the texture, and the period and width of the
    diagonal stripes, in pixels.
    """
    height, period, width = stripes
    rng = np.random.default_rng(seed)
    walk = rng.standard_normal(shape).cumsum(0).cumsum(1)
    walk += height * (np.add.outer(np.arange(shape[0]), np.arange(shape[1])) % period < width)
    unit = (walk - walk.min()) / np.ptp(walk)
    if np.dtype(dtype).kind == "f":
        return unit.astype(dtype)
    return (unit * 0.9 * np.iinfo(dtype).max).astype(dtype)
