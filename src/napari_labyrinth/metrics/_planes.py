"""The planes the metrics take: checked, and copied or viewed as the kernels read them."""

from __future__ import annotations

import math
import sys

import numpy as np


def _plane(image, name="image") -> np.ndarray:
    array = np.asarray(image)
    if array.ndim != 2:
        raise ValueError(f"{name} must be a 2-D grayscale plane, got shape {array.shape}")
    if array.dtype.kind not in "uif" or array.dtype == np.bool_:
        raise TypeError(f"{name} must hold real numbers, got dtype {array.dtype}")
    if min(array.shape) < 3:
        raise ValueError(f"{name} must be at least 3 x 3 pixels, got shape {array.shape}")
    return array


def _float_plane(array: np.ndarray, *, copy: bool = False) -> np.ndarray:
    """A C-contiguous float64 copy of (or, with ``copy=False``, view on) a checked plane."""
    if copy:
        return np.array(array, dtype=np.float64, order="C", copy=True)
    return np.ascontiguousarray(array, dtype=np.float64)


#: Dtypes the kernels read as they are: every value is exact in float64, and every
#: kernel's arithmetic on a plane's value starts by combining it with a float64 (a
#: sum of two of them is taken in 64-bit integers, also exact), so the maps are those
#: of the plane's float64 copy, bit for bit. A copy of such a plane takes 1 or 2 bytes
#: a pixel instead of float64's 8 (new memory, whose first touch is slow: ``_Pool``).
#: Signed integers are not among them (``abs`` of the most negative value overflows),
#: nor float32 (a sum of two float32 values is rounded to float32).
_KERNEL_DTYPES = (np.dtype(np.uint8), np.dtype(np.uint16))


def _kernel_dtype(dtype) -> np.dtype:
    """The dtype of the copy of a plane of ``dtype`` that the kernels read."""
    dtype = np.dtype(dtype)
    return dtype if dtype in _KERNEL_DTYPES else np.dtype(np.float64)


def _kernel_plane(array: np.ndarray, *, copy: bool = False) -> np.ndarray:
    """A checked plane as the kernels read it: C-contiguous, in :func:`_kernel_dtype`; a
    view when it already is, unless ``copy``."""
    dtype = _kernel_dtype(array.dtype)
    if copy:
        return np.array(array, dtype=dtype, order="C", copy=True)
    return np.ascontiguousarray(array, dtype=dtype)


def _same_shape(before: np.ndarray, after: np.ndarray) -> None:
    if before.shape != after.shape:
        raise ValueError(f"original {before.shape} and rendered {after.shape} differ in shape")


def _float32_scale(largest: float) -> float:
    """A power of two that brings values up to ``largest`` where float32 squares are safe.

    The scale is at most ``2**1023``, float64's largest power of two: a
    subnormal ``largest`` (below ``2**-1022``) comes up to between ``2**-51``
    and 2, still safe. Its square may leave float64's range: divide by the
    scale twice, never by ``scale**2``.
    """
    if not 0.0 < largest < math.inf or 2.0**-40 <= largest <= 2.0**40:
        return 1.0
    return math.ldexp(1.0, min(-math.frexp(largest)[1], _LARGEST_EXPONENT))


#: The exponent of float64's largest power of two.
_LARGEST_EXPONENT = sys.float_info.max_exp - 1
