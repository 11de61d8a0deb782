"""The metrics' numba kernels, imported on first use, and the Gaussian weights they are given.

``import napari_labyrinth`` imports neither numba nor the kernels
(:mod:`._kernels`): the metrics reach them through :func:`_numba_kernels`,
looking each kernel up on the package when they call it.
"""

from __future__ import annotations

import threading

import numpy as np


def _numba_kernels():
    """The package of the kernels (:mod:`napari_labyrinth.metrics._kernels`)."""
    from . import _kernels  # numba is imported on first use only

    return _kernels


_WEIGHTS: dict[tuple[float, str], np.ndarray] = {}
_WEIGHTS_LOCK = threading.Lock()


def _weights(sigma: float, dtype=np.float64) -> np.ndarray:
    """scipy's Gaussian weights for ``sigma`` (half of the kernel), cached: not to be changed."""
    key = (float(sigma), np.dtype(dtype).str)
    with _WEIGHTS_LOCK:
        if key not in _WEIGHTS:
            _WEIGHTS[key] = _numba_kernels().gaussian_weights(sigma).astype(dtype)
        return _WEIGHTS[key]
