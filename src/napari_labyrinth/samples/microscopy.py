"""Microscopy-like samples: a noisy 16-bit fluorescence time-lapse, and scikit-image's camera
and cell images (imported on first use)."""

from __future__ import annotations

import numbers

import numpy as np

from ._shared import _box, _validate_seed, _validate_shape


def fluorescence_stack(
    shape: tuple[int, int] = (512, 512), *, planes: int = 4, seed: int = 0
) -> np.ndarray:
    """A noisy 16-bit time-lapse of fluorescent cells.

    Parameters
    ----------
    shape : (int, int), optional
        Plane shape ``(rows, columns)``.
    planes : int, optional
        Time points (>= 1); the cells drift and dim slowly between them.
    seed : int, optional
        Seed of the random generator; the same seed gives the same stack.

    Returns
    -------
    stack : (planes, rows, columns) uint16 ndarray
        Camera counts: an offset of 100, a dim uneven background, cells of a
        few hundred counts with bright nuclei and filaments, Poisson (shot)
        and Gaussian read noise.

    Examples
    --------
    >>> from napari_labyrinth.samples import fluorescence_stack
    >>> stack = fluorescence_stack((96, 96), planes=2)
    >>> stack.shape, stack.dtype
    ((2, 96, 96), dtype('uint16'))
    """
    from scipy import ndimage

    rows, columns = _validate_shape(shape)
    if not isinstance(planes, numbers.Integral) or isinstance(planes, bool) or planes < 1:
        raise ValueError(f"planes must be an integer >= 1, got {planes!r}")
    rng = np.random.default_rng(_validate_seed(seed))
    count = max(2, int(round(rows * columns / 90.0**2)))
    centres = np.column_stack([rng.uniform(0, rows, count), rng.uniform(0, columns, count)])
    radii = rng.uniform(14, 30, count)
    drift = rng.normal(0.0, 1.5, (count, 2))
    fibres = ndimage.gaussian_filter(rng.normal(size=(rows, columns)), 3.0)
    fibres = np.abs(fibres) < 0.08 * fibres.std() * 4  # thin meandering lines
    background = 30.0 * ndimage.gaussian_filter(rng.random((rows, columns)), 40.0, mode="wrap")
    stack = np.empty((int(planes), rows, columns), np.uint16)
    for t in range(int(planes)):
        signal = background.copy()
        for (cy, cx), radius, (dy, dx) in zip(centres, radii, drift):
            cy, cx = cy + t * dy, cx + t * dx
            box = _box(cy, cx, 2.0 * radius, rows, columns)
            y, x = np.mgrid[box].astype(np.float64)
            distance = np.hypot(y - cy, x - cx) / radius
            cytoplasm = 1.0 / (1.0 + np.exp(np.minimum((distance - 1.0) * 10.0, 50.0)))
            nucleus = 1.0 / (1.0 + np.exp(np.minimum((distance - 0.4) * 14.0, 50.0)))
            signal[box] += cytoplasm * (150.0 + 250.0 * fibres[box]) + nucleus * 700.0
        signal *= 0.97**t  # photobleaching
        counts = rng.poisson(signal) + rng.normal(100.0, 6.0, signal.shape)
        stack[t] = np.clip(np.rint(counts), 0, 65535).astype(np.uint16)
    return stack


def camera() -> np.ndarray:
    """The ``camera`` photograph of scikit-image (512 x 512, uint8).

    Returns
    -------
    image : (512, 512) uint8 ndarray
    """
    from skimage import data

    return np.asarray(data.camera())


def cell() -> np.ndarray:
    """The ``cell`` micrograph of scikit-image (uint8, grey).

    Returns
    -------
    image : 2-D uint8 ndarray
    """
    from skimage import data

    return np.asarray(data.cell())
