"""The diagnostics of a render: counts per pass and plane, per thread on cache lines of their own.

A pass increments one int64 count per field of ``codes.DIAGNOSTIC_FIELDS``
(pixels kept by Eq. 2, left by Eq. 4, pushed, redrawn, out of tries, skipped).
The render keeps them per pass and plane; the threads of one pass keep their
own, each on whole cache lines, and add them up when the pass is done.
"""

from __future__ import annotations

import math

import numpy as np

from ..core.codes import DIAGNOSTIC_FIELDS, SKIPPED
from ..core.planes import PlaneLayout

#: dtype of the per-pass diagnostics: one count per field of ``DIAGNOSTIC_FIELDS``.
DIAGNOSTICS_DTYPE = np.dtype([(name, np.int64) for name in DIAGNOSTIC_FIELDS])

#: Bytes of a cache line: per-thread counters are padded to whole lines.
_CACHE_LINE = 64


def diagnostic_counts(layout: PlaneLayout, passes: int) -> np.ndarray:
    """Zeroed counts per pass and plane; alpha planes count every pixel as skipped."""
    counts = np.zeros((passes,) + layout.leading_shape + (len(DIAGNOSTIC_FIELDS),), np.int64)
    for index in np.ndindex(layout.leading_shape):
        if layout.is_alpha(index):
            counts[(slice(None),) + index + (SKIPPED,)] = math.prod(layout.plane_shape)
    return counts


def padded_counts(rows: int) -> np.ndarray:
    """Zeroed ``(rows, 8)`` int64 counts, each row a whole, aligned cache line.

    Threads that write counts of their own never share a cache line.
    """
    stride = max(len(DIAGNOSTIC_FIELDS), _CACHE_LINE // 8)
    raw = np.zeros(rows * stride + _CACHE_LINE // 8, dtype=np.int64)
    offset = (-raw.ctypes.data % _CACHE_LINE) // 8
    return raw[offset : offset + rows * stride].reshape(rows, stride)


def add_padded_counts(counts: np.ndarray, padded: np.ndarray) -> None:
    """Add to ``counts`` the threads' own counts (rows of :func:`padded_counts`)."""
    counts += padded[:, : len(DIAGNOSTIC_FIELDS)].sum(axis=0)
