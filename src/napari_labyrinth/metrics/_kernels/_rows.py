"""Helpers the metrics kernels share: a plane's shape and rows, sums of a row, a Gaussian
down a ring of rows or along a line, scipy's ``reflect`` extension.

A plane is given as the tuple of :func:`plane_tuple`: one slot per dtype a
plane may have (uint8, uint16, float32, float64), the plane in its own and
empty arrays in the others. Kernels read its rows through
:func:`_load_row`, which converts them to float64 (exactly), so that each
kernel is compiled once for every dtype, and the results are those of the
plane's float64 copy.

The helpers (:data:`_helper`) are called by the kernels, not by one another
where that can be, with one signature each and no literal constant
(``docs/metrics.md``, "Compile time"). numba links a helper's code into each
kernel that calls it, and its disk cache of a kernel is keyed on the kernel's
own file: after a change here, clear the kernels' caches (``__pycache__``)
or numba runs the kernels compiled with the old helpers.
"""

from __future__ import annotations

import numpy as np
from numba import njit

#: The decorator of the helpers, which only kernels call: no entry point for Python (numba
#: compiles none) and no disk cache of their own (their code is in each kernel's).
_helper = njit(nogil=True, error_model="numpy", no_cpython_wrapper=True, no_cfunc_wrapper=True)

#: The dtypes of the slots of :func:`plane_tuple`.
PLANE_DTYPES = (
    np.dtype(np.uint8),
    np.dtype(np.uint16),
    np.dtype(np.float32),
    np.dtype(np.float64),
)
_NO_PLANE = {dtype: np.empty((0, 0), dtype=dtype) for dtype in PLANE_DTYPES}


def plane_tuple(plane: np.ndarray) -> tuple[np.ndarray, ...]:
    """The kernels' form of a C-contiguous plane of one of :data:`PLANE_DTYPES`: the plane
    in the slot of its dtype, empty arrays in the others."""
    if plane.dtype not in PLANE_DTYPES or not plane.flags.c_contiguous:
        raise TypeError(
            f"a plane of the kernels is C-contiguous {PLANE_DTYPES}, not {plane.dtype}"
        )
    return tuple(plane if plane.dtype == dtype else _NO_PLANE[dtype] for dtype in PLANE_DTYPES)


@_helper
def _plane_shape(planes):
    """Height and width of the plane of a :func:`plane_tuple` (the others are empty)."""
    height = planes[0].shape[0] + planes[1].shape[0] + planes[2].shape[0] + planes[3].shape[0]
    width = planes[0].shape[1] + planes[1].shape[1] + planes[2].shape[1] + planes[3].shape[1]
    return height, width


@_helper
def _load_row(planes, row, x0, x1, out):
    """``out[x - x0]`` = the plane's value at (``row``, x) as a float64, for x in ``[x0, x1)``."""
    if planes[0].shape[0] > 0:
        source8 = planes[0][row]
        for x in range(x0, x1):
            out[x - x0] = source8[x]
    elif planes[1].shape[0] > 0:
        source16 = planes[1][row]
        for x in range(x0, x1):
            out[x - x0] = source16[x]
    elif planes[2].shape[0] > 0:
        source32 = planes[2][row]
        for x in range(x0, x1):
            out[x - x0] = source32[x]
    else:
        source64 = planes[3][row]
        for x in range(x0, x1):
            out[x - x0] = source64[x]


@_helper
def _sum(values):
    """The sum of a line: eight interleaved partial sums (independent chains), then those."""
    n = values.shape[0]
    a0 = a1 = a2 = a3 = a4 = a5 = a6 = a7 = 0.0
    end = n - n % 8
    for x in range(0, end, 8):
        a0 += values[x]
        a1 += values[x + 1]
        a2 += values[x + 2]
        a3 += values[x + 3]
        a4 += values[x + 4]
        a5 += values[x + 5]
        a6 += values[x + 6]
        a7 += values[x + 7]
    for x in range(end, n):
        a0 += values[x]
    return ((a0 + a1) + (a2 + a3)) + ((a4 + a5) + (a6 + a7))


@_helper
def _finite_range(values):
    """Smallest and largest finite value of a line (inf, -inf if none) and the count of others."""
    low = np.inf
    high = -np.inf
    others = 0
    for x in range(values.shape[0]):
        value = values[x]
        if abs(value) < np.inf:
            low = min(low, value)
            high = max(high, value)
        else:
            others += 1
    return low, high, others


@_helper
def _reflect(i, n):
    """Index of virtual position ``i`` of a line of ``n`` under scipy's ``reflect``."""
    period = 2 * n
    i = i % period
    if i >= n:
        i = period - 1 - i
    return i


@_helper
def _gauss(rows, taps, weights, out):
    """``out[i]`` = a Gaussian of ``weights`` at column i, in scipy's order of operations for
    a symmetric kernel: the centre times ``w[0]``, then ``+= (a_j + b_j) w[j]`` for j = r ..
    1, four taps per sweep over ``out`` (the same order, fewer loads and stores).

    Tap j's values ``a_j``, ``b_j`` are rows ``taps[0, j]`` and ``taps[1, j]`` of ``rows``
    from columns ``taps[2, j]`` and ``taps[3, j]`` on (the centre: ``taps[0, 0]``,
    ``taps[2, 0]``): a ring of rows read down a column (axis 0: rows y - j and y + j from
    column 0), or one extended line read at shifts along itself (axis 1: columns
    ``start - j`` and ``start + j`` of one row, output column 0 at ``start``).
    """
    n = out.shape[0]
    middle = rows[taps[0, 0], taps[2, 0] :]
    w0 = weights[0]
    for i in range(n):
        out[i] = middle[i] * w0
    j = weights.shape[0] - 1
    while j >= 4:
        a1, b1 = rows[taps[0, j], taps[2, j] :], rows[taps[1, j], taps[3, j] :]
        a2, b2 = rows[taps[0, j - 1], taps[2, j - 1] :], rows[taps[1, j - 1], taps[3, j - 1] :]
        a3, b3 = rows[taps[0, j - 2], taps[2, j - 2] :], rows[taps[1, j - 2], taps[3, j - 2] :]
        a4, b4 = rows[taps[0, j - 3], taps[2, j - 3] :], rows[taps[1, j - 3], taps[3, j - 3] :]
        w1, w2, w3, w4 = weights[j], weights[j - 1], weights[j - 2], weights[j - 3]
        for i in range(n):
            value = out[i]
            value += (a1[i] + b1[i]) * w1
            value += (a2[i] + b2[i]) * w2
            value += (a3[i] + b3[i]) * w3
            value += (a4[i] + b4[i]) * w4
            out[i] = value
        j -= 4
    while j >= 1:
        a, b, w = rows[taps[0, j], taps[2, j] :], rows[taps[1, j], taps[3, j] :], weights[j]
        for i in range(n):
            out[i] += (a[i] + b[i]) * w
        j -= 1


@_helper
def _reflect_ends(ext, radius, n):
    """Extends the line ``ext[radius : radius + n]`` by ``radius`` values on each side under
    scipy's ``reflect``."""
    for i in range(radius):
        ext[i] = ext[radius + _reflect(i - radius, n)]
        ext[radius + n + i] = ext[radius + _reflect(n + i, n)]
