"""The lower resolution levels of a rendered image: halved in Y and X by a local mean.

A labyrinth's walls are one or two pixels wide. Keeping every second pixel
(nearest neighbour) drops every second row and column, and with them whole
walls, so a zoomed-out level would show another pattern than the full one;
the mean of each 2 × 2 block keeps every wall, a one-pixel wall as a line of
half its contrast. Integer images are rounded to the nearest value of their
dtype; a side of odd length repeats its last row or column.
"""

from __future__ import annotations

from collections.abc import Iterator, Sequence
from typing import Any

import numpy as np

#: Levels are added while the last one's smaller side (Y, X) is longer than this.
SMALLEST_SIDE = 256


def level_count(shape: Sequence[int], axes: Sequence[int]) -> int:
    """How many levels (the full one included) an image of ``shape`` gets, halving the
    ``axes`` until the smaller of them is at most ``SMALLEST_SIDE`` long."""
    side, count = min(int(shape[axis]) for axis in axes), 1
    while side > SMALLEST_SIDE:
        side, count = (side + 1) // 2, count + 1
    return count


def halved_shape(shape: Sequence[int], axes: Sequence[int]) -> tuple[int, ...]:
    """The shape of an image of ``shape`` halved along ``axes`` (sides rounded up)."""
    axes = {axis % len(shape) for axis in axes}
    return tuple((size + 1) // 2 if axis in axes else size for axis, size in enumerate(shape))


def halved(image: np.ndarray, axes: Sequence[int]) -> np.ndarray:
    """``image`` halved along ``axes`` (sides rounded up): the mean of each 2 × 2 block, in
    ``image``'s dtype, computed plane by plane (the memory of one plane's mean aside from
    the result)."""
    axes = sorted({axis % image.ndim for axis in axes})
    result = np.empty(halved_shape(image.shape, axes), image.dtype)
    for where in plane_slices(image.shape, axes):
        result[where] = _halved_whole(image[where])
    return result


def plane_slices(shape: Sequence[int], axes: Sequence[int]) -> Iterator[tuple[Any, ...]]:
    """The index of each plane over ``axes`` of an array of ``shape``: every other axis at
    one position, in C order."""
    axes = {axis % len(shape) for axis in axes}
    others = [axis for axis in range(len(shape)) if axis not in axes]
    for index in np.ndindex(*(shape[axis] for axis in others)):
        where: list[Any] = [slice(None)] * len(shape)
        for axis, position in zip(others, index, strict=True):
            where[axis] = position
        yield tuple(where)


def _halved_whole(image: np.ndarray) -> np.ndarray:
    """``image`` halved along every axis (see ``halved``)."""
    pad = [(0, size % 2) for size in image.shape]
    padded = np.pad(image, pad, mode="edge") if any(after for _, after in pad) else image
    if padded.ndim == 2 and padded.dtype.kind in "iu" and padded.dtype.itemsize <= 4:
        return _halved_integers(padded)
    blocks = padded.reshape([part for size in padded.shape for part in (size // 2, 2)])
    mean = blocks.mean(axis=tuple(range(1, blocks.ndim, 2)), dtype=np.float64)
    if np.issubdtype(image.dtype, np.integer):
        info = np.iinfo(image.dtype)
        mean = np.clip(np.rint(mean), info.min, info.max)
    elif image.dtype == np.bool_:
        mean = mean >= 0.5
    return mean.astype(image.dtype)


def _halved_integers(image: np.ndarray) -> np.ndarray:
    """A 2-D integer ``image`` of even sides halved: each 2 x 2 block's mean rounded half to
    even, as ``np.rint`` of the float mean, in integers (several times faster).

    The block's sum ``s`` is exact in int64; ``s / 4`` is ``q + r / 4`` with ``q = s >> 2``
    (floor) and ``r = s & 3``, which rounds to ``q`` for r < 2, to ``q + 1`` for r > 2, and
    for r = 2 (a half) to the even one of ``q`` and ``q + 1``.
    """
    total = np.add(image[0::2, 0::2], image[1::2, 0::2], dtype=np.int64)
    total += image[0::2, 1::2]
    total += image[1::2, 1::2]
    quotient, remainder = total >> 2, total & 3
    quotient += (remainder > 2) | ((remainder == 2) & (quotient & 1 == 1))
    return quotient.astype(image.dtype)
