"""How an image splits into the independent 2-D planes the kernel renders.

One place for the layout of an image (as scikit-image keeps
``channel_as_last_axis`` in one place): every axis before the last two
spatial axes holds independent planes (time, z), the colour axis
(``channel_axis``) holds one plane per channel, and with 4 channels the last
is alpha, which is never rendered (``alpha`` says so for other channel counts: a
grey + alpha PNG has 2). Plane k of an image draws the random
stream of plane ``plane_offset + k``, k being the flat index of the plane
among the leading axes with the colour axis last, so that a part of a stack
renders exactly as it does within the whole. An RGB(A) image rendered in its
luminance (``core.colour``) renders one plane per position, with the stream
of the position's first channel. The API, the lazy (dask) path, the command
line and the widget all use this module.
"""

from __future__ import annotations

import dataclasses
import math
import numbers
from collections.abc import Iterator, Sequence
from typing import Any

import numpy as np

from .colour import resolve_colour
from .parameters import PLANE_OFFSET

#: Number of channels that makes the last channel alpha by default (RGBA).
RGBA_CHANNELS = 4

#: Largest plane offset (the random stream index of a plane is a 64-bit integer).
MAX_PLANE_OFFSET = PLANE_OFFSET.high


def normalise_channel_axis(channel_axis: Any, ndim: int) -> int | None:
    """``channel_axis`` as a non-negative axis of an ``ndim``-dimensional image, or None.

    Raises
    ------
    TypeError, ValueError
        Naming ``channel_axis``.
    """
    if channel_axis is None:
        return None
    if not isinstance(channel_axis, numbers.Integral) or isinstance(channel_axis, bool):
        raise TypeError(f"channel_axis must be an integer or None, got {channel_axis!r}")
    if ndim < 3:
        raise ValueError(f"channel_axis needs an image of at least 3 dimensions, got {ndim}")
    if not -ndim <= channel_axis < ndim:
        raise ValueError(
            f"channel_axis {channel_axis} is out of range for an image of {ndim} dimensions"
        )
    return int(channel_axis) % ndim


def validate_shape(shape: Sequence[int]) -> None:
    """Refuse an image with fewer than 2 dimensions or no pixels, naming ``image``."""
    if len(shape) < 2:
        raise ValueError(f"image must have at least 2 dimensions, got {len(shape)}")
    if 0 in shape:
        raise ValueError(f"image is empty (shape {tuple(shape)})")


def validate_plane_offset(plane_offset: Any) -> int:
    """``plane_offset`` checked: an integer from 0 to ``MAX_PLANE_OFFSET`` (the table's)."""
    return PLANE_OFFSET.validate(plane_offset)


def validate_stream_range(plane_offset: int, n_planes: int) -> None:
    """Refuse a ``plane_offset`` whose last plane's stream index passes ``MAX_PLANE_OFFSET``.

    Raises
    ------
    ValueError
        Naming ``plane_offset`` and the largest one these planes allow.
    """
    largest = MAX_PLANE_OFFSET - (n_planes - 1)
    if plane_offset > largest:
        raise ValueError(
            f"plane_offset must be between 0 and {largest} for an image of {n_planes} "
            f"planes (the last plane's stream index must stay <= 2**63 - 1), "
            f"got {plane_offset}"
        )


def resolve_alpha(alpha: Any, shape: Sequence[int], channel_axis: int | None) -> bool:
    """Whether the last channel along ``channel_axis`` is alpha (kept, never rendered).

    ``None``: only an image of 4 channels (RGBA) has one. ``True`` needs a
    colour axis of at least 2 channels (grey + alpha has 2).

    Raises
    ------
    TypeError, ValueError
        Naming ``alpha``.
    """
    if alpha is not None and not isinstance(alpha, (bool, np.bool_)):
        raise TypeError(f"alpha must be True, False or None, got {alpha!r}")
    channels = None if channel_axis is None else int(shape[channel_axis])
    if alpha is None:
        return channels == RGBA_CHANNELS
    if alpha and (channels is None or channels < 2):
        what = "no channel_axis" if channels is None else f"{channels} channel"
        raise ValueError(
            f"alpha=True needs a channel_axis of at least 2 channels (colour + alpha), got {what}"
        )
    return bool(alpha)


def spatial_axes(ndim: int, channel_axis: int | None) -> tuple[int, int]:
    """The two spatial axes (y, x): the last two axes that are not the colour axis."""
    axes = [axis for axis in range(ndim) if axis != channel_axis]
    return axes[-2], axes[-1]


def plane_axes(ndim: int, channel_axis: int | None, extra: int = 0) -> tuple[int, ...]:
    """Axes of one plane with its channels, in a result with ``extra`` axes in front.

    A block of these axes holds everything one rendering of a plane needs
    (alpha is recognised by its position among the channels).
    """
    channel = None if channel_axis is None else channel_axis % ndim
    axes = spatial_axes(ndim, channel)
    if channel is not None:
        axes = (*axes, channel)
    return tuple(sorted(extra + axis for axis in axes))


def resolve_layout_colour(
    colour: Any, shape: Sequence[int], channel_axis: int | None, alpha: Any = None
) -> str:
    """:func:`core.colour.resolve_colour` for an image whose alpha may not be the 4th channel.

    The luminance mode renders R, G, B and keeps a 4th channel as alpha; an
    ``alpha`` that differs from that (grey + alpha, RGB without alpha but
    alpha=True, 4 channels without alpha) renders channels independently by
    default, and refuses ``colour="luminance"``.

    Raises
    ------
    TypeError, ValueError
        Naming ``colour`` or ``alpha``.
    """
    has_alpha = resolve_alpha(alpha, shape, channel_axis)
    channels = None if channel_axis is None else int(shape[channel_axis])
    if has_alpha == (channels == RGBA_CHANNELS):  # alpha where the luminance mode has it
        return resolve_colour(colour, shape, channel_axis)
    if colour != "luminance":  # checks an unknown colour too
        return resolve_colour("channels" if colour is None else colour, shape, channel_axis)
    raise ValueError(
        f"colour='luminance' needs R, G, B (and alpha as a 4th channel); alpha={alpha!r} "
        f"with {channels} channels leaves {channels - has_alpha} colour channel(s): "
        "use colour='channels'"
    )


def without_alpha(image: Any, channel_axis: int | None, alpha: bool | None = None) -> Any:
    """``image`` without its alpha channel (a view; the image itself if it has none)."""
    if channel_axis is None:
        return image
    axis = channel_axis % image.ndim
    if not resolve_alpha(alpha, image.shape, axis):
        return image
    return image[(slice(None),) * axis + (slice(0, image.shape[axis] - 1),)]


def first_plane_index(
    shape: Sequence[int], index: Sequence[int], channel_axis: int | None = None
) -> int:
    """Flat index, among the planes of an image of ``shape``, of the first plane at ``index``.

    ``index`` addresses the leading axes of the image (the colour axis, if
    any, must come after them). Rendering ``image[index]`` with this
    ``plane_offset`` gives what rendering the whole image gives there.
    """
    index = tuple(int(i) for i in index)
    if not index:
        return 0
    layout = PlaneLayout(tuple(shape), normalise_channel_axis(channel_axis, len(shape)))
    leading = layout.leading_shape
    per_index = math.prod(leading[len(index) :])
    return int(np.ravel_multi_index(index, leading[: len(index)])) * per_index


def step_count(
    shape: Sequence[int],
    channel_axis: int | None,
    passes: Sequence[int] | int,
    colour: str | None = None,
    alpha: bool | None = None,
) -> int:
    """Progress steps of rendering an image of ``shape``: rendered planes × passes.

    ``passes`` is the passes of one rendering, or a sequence with those of
    each rendering of a sweep. Alpha planes are not rendered and not counted;
    in the luminance mode (``colour``, see :func:`core.colour.resolve_colour`:
    the default for 3 or 4 channels) one plane is rendered per position, not
    one per channel.
    """
    layout = PlaneLayout(tuple(shape), normalise_channel_axis(channel_axis, len(shape)), alpha=alpha)
    if resolve_layout_colour(colour, layout.shape, layout.channel_axis, alpha) == "luminance":
        layout = layout.luminance_layout()
    total_passes = passes if isinstance(passes, numbers.Integral) else sum(passes)
    return layout.n_rendered * int(total_passes)


@dataclasses.dataclass(frozen=True)
class PlaneLayout:
    """The planes of an image of ``shape`` (or of a block of a larger array).

    Attributes
    ----------
    shape : tuple of int
        Shape of the image.
    channel_axis : int or None
        Its colour axis, non-negative (see :func:`normalise_channel_axis`).
    plane_offset : int
        Random stream index of the image's first plane.
    leading_origin, leading_total : tuple of int, optional
        For a block of a larger array: where the block's leading axes start
        in it, and the array's leading shape (its planes' stream indices
        follow the whole array).
    alpha : bool, optional
        Whether the last channel is alpha (see :func:`resolve_alpha`; None:
        with 4 channels).
    """

    shape: tuple[int, ...]
    channel_axis: int | None = None
    plane_offset: int = 0
    leading_origin: tuple[int, ...] | None = None
    leading_total: tuple[int, ...] | None = None
    alpha: bool | None = None

    @property
    def leading_shape(self) -> tuple[int, ...]:
        """Shape of the plane axes, colour last: the layout of :meth:`to_planes`."""
        if self.channel_axis is None:
            return self.shape[:-2]
        y, x = spatial_axes(len(self.shape), self.channel_axis)
        others = [n for axis, n in enumerate(self.shape) if axis not in (y, x, self.channel_axis)]
        return (*others, self.shape[self.channel_axis])

    @property
    def plane_shape(self) -> tuple[int, int]:
        y, x = spatial_axes(len(self.shape), self.channel_axis)
        return self.shape[y], self.shape[x]

    @property
    def n_planes(self) -> int:
        return math.prod(self.leading_shape)

    @property
    def has_alpha(self) -> bool:
        return resolve_alpha(self.alpha, self.shape, self.channel_axis)

    @property
    def n_rendered(self) -> int:
        """Planes the kernel renders: every plane but alpha."""
        if self.has_alpha:
            channels = self.shape[self.channel_axis]
            return self.n_planes // channels * (channels - 1)
        return self.n_planes

    def is_alpha(self, index: tuple[int, ...]) -> bool:
        """Whether the plane at ``index`` (of :meth:`to_planes`) is an alpha channel."""
        return self.has_alpha and index[-1] == self.shape[self.channel_axis] - 1

    def rendered_indices(self) -> Iterator[tuple[int, ...]]:
        """Indices (of :meth:`to_planes`) of the planes to render, in stream order."""
        return (index for index in np.ndindex(self.leading_shape) if not self.is_alpha(index))

    def stream_index(self, index: tuple[int, ...]) -> int:
        """Index of the random stream of the plane at ``index`` of :meth:`to_planes`."""
        if self.leading_total is None:
            flat = np.ravel_multi_index(index, self.leading_shape) if index else 0
        else:
            where = tuple(o + i for o, i in zip(self.leading_origin, index))
            flat = np.ravel_multi_index(where, self.leading_total) if where else 0
        return self.plane_offset + int(flat)

    def luminance_layout(self) -> PlaneLayout:
        """Layout of the luminance of this image, in the layout of :meth:`to_planes`.

        The luminance array has the shape ``leading_shape[:-1] + (1, H, W)``:
        one plane per position, its colour axis reduced to one, and each
        plane draws the random stream of the position's first channel, so
        that a part of a stack (``plane_offset``) renders as within it.
        """
        if self.channel_axis is None:
            raise ValueError("an image without channel_axis has no luminance layout")
        leading = self.leading_shape
        return PlaneLayout(
            (*leading[:-1], 1, *self.plane_shape),
            len(leading) - 1,
            plane_offset=self.plane_offset,
            leading_origin=self.leading_origin or (0,) * len(leading),
            leading_total=self.leading_total or leading,
            alpha=False,
        )

    def to_planes(self, array):
        """View of an array shaped like the image as ``leading_shape + (H, W)``."""
        if self.channel_axis is None:
            return array
        return np.moveaxis(array, self.channel_axis, -3)

    def to_image_layout(self, leading: np.ndarray) -> np.ndarray:
        """View of ``(k,) + leading_shape`` data with the colour axis back in its place."""
        if self.channel_axis is None:
            return leading
        spatial = spatial_axes(len(self.shape), self.channel_axis)
        position = sum(1 for axis in range(self.channel_axis) if axis not in spatial)
        return np.moveaxis(leading, -1, 1 + position)
