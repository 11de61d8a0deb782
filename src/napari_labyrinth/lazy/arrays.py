"""Lazy arrays: recognised without importing dask, checked before any block is read.

``is_lazy`` tells the API to render an image lazily, ``is_in_memory`` tells the
widget to render only the plane on screen; ``checked_lazy`` refuses a dask
image the rendering cannot take (masked, unknown chunk sizes, an unsupported
dtype or shape, planes too large for this machine's memory), naming it, and
gives its native-order equivalent and its layout of planes.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from .._budget import refuse_unaffordable
from .._rendering import plane_layout
from ..core.planes import validate_shape
from ..core.tone_scale import validate_dtype


def is_lazy(image: Any) -> bool:
    """Whether ``image`` is a dask array (checked without importing dask): the API renders
    it lazily."""
    return type(image).__module__.split(".")[0] == "dask" and hasattr(image, "chunks")


def is_in_memory(data: Any) -> bool:
    """Whether ``data`` is a numpy array; other array-likes (dask, zarr, ...) load planes on
    demand, so the widget renders only the plane on screen and leaves the rest lazy."""
    return isinstance(data, np.ndarray)


def checked_lazy(image, channel_axis, alpha):
    """A dask image checked before any block is read, in native byte order; its channel
    axis (normalised), whether it has alpha, and its layout of planes.

    Raises
    ------
    TypeError, ValueError
        Naming ``image`` or the option at fault.
    """
    if isinstance(getattr(image, "_meta", None), np.ma.MaskedArray):
        raise TypeError(
            "image is a dask masked array, whose mask the rendering would lose: pass "
            "dask.array.ma.filled(image, np.nan) (a float image: NaN pixels are kept as they "
            "are and never count as neighbours) or dask.array.ma.getdata(image)"
        )
    given = np.dtype(image.dtype)
    dtype = validate_dtype(given if given.isnative else given.newbyteorder("="))
    _check_known_shape(image)
    validate_shape(image.shape)
    layout = plane_layout(image.shape, channel_axis, alpha)
    refuse_unaffordable("image", layout.plane_shape, dtype, planes=1, what="each plane")
    if dtype != given:
        image = image.astype(dtype)
    return image, layout.channel_axis, layout.has_alpha, layout


def _check_known_shape(image) -> None:
    """Refuse a dask array whose chunk sizes are unknown (NaN), naming ``image``."""
    if any(math.isnan(size) for size in image.shape):
        raise ValueError(
            f"image is a dask array with unknown chunk sizes (shape {image.shape}, e.g. after "
            "boolean indexing): call image.compute_chunk_sizes() first"
        )
