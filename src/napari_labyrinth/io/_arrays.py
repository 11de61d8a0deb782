"""The arrays read and written: native byte order, blocks of whole planes, plane counts.

A lazily read image is a dask array cut into blocks of whole planes
(:func:`block_chunks`); its dtype, as every array the readers return, is in
the machine's byte order (:func:`native`); progress counts planes
(:func:`plane_count`).
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

#: Upper bound on the bytes of the block a lazily read image is cut into:
#: whole planes, as many as the store's chunks hold along the stack axes
#: (so each chunk is read once), but no more than fit in this.
BLOCK_BYTES = 256 << 20


def native(image):
    """The image with its dtype in the machine's byte order (the API's dtypes are native)."""
    if image.dtype.isnative:
        return image
    return image.astype(image.dtype.newbyteorder("="))


def block_chunks(
    shape: tuple[int, ...],
    store_chunks: tuple[int, ...],
    dtype: np.dtype,
    channel_axis: int | None,
) -> tuple[int, ...]:
    """dask chunks of whole planes, following the store's chunks along the stack axes."""
    ndim = len(shape)
    whole = set()
    if ndim >= 2:
        axes = [
            axis for axis in range(ndim) if channel_axis is None or axis != channel_axis % ndim
        ]
        whole = set(axes[-2:])
        if channel_axis is not None and ndim >= 3:
            whole.add(channel_axis % ndim)
    plane_bytes = int(np.prod([shape[axis] for axis in whole])) * np.dtype(dtype).itemsize
    room = max(1, BLOCK_BYTES // max(plane_bytes, 1))
    chunks = list(shape)
    for axis in reversed(range(ndim)):
        if axis in whole:
            continue
        size = max(1, min(int(store_chunks[axis]), shape[axis], room))
        chunks[axis] = size
        room = max(1, room // size)
    return tuple(chunks)


def plane_count(shape: tuple[int, ...], plane_axes: Sequence[int]) -> int:
    """The number of planes (of the axes ``plane_axes``) of an array of ``shape``."""
    axes = {axis % len(shape) for axis in plane_axes}
    return int(np.prod([size for axis, size in enumerate(shape) if axis not in axes]))
