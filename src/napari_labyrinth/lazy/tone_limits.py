"""The default tone limits of a lazy image, exact and streamed.

``default_tone_limits`` gives the tone limits :func:`napari_labyrinth.labyrinth`
would choose for the whole image (the 0.5th and 99.5th percentiles of its
finite values, alpha left out), for a numpy or a dask array, without loading a
dask array whole (``streamed_percentiles``); ``rendering_tone_limits`` those a
lazy rendering uses, the luminance's in the luminance mode.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from .._rendering import renders_luminance
from ..core.colour import luminance, luminance_for_limits
from ..core.planes import without_alpha
from ..core.tone_scale import DEFAULT_PERCENTILES, resolve_tone_scale, separated_limits
from .arrays import checked_lazy, is_lazy
from .streamed_percentiles import percentiles


def default_tone_limits(
    image: Any, channel_axis: int | None = None, alpha: bool | None = None
) -> tuple[float, float]:
    """The tone limits :func:`~napari_labyrinth.labyrinth` uses by default, for any array.

    Parameters
    ----------
    image : ndarray or dask array
        The image, as it will be passed to ``labyrinth``.
    channel_axis : int, optional
        Its colour axis; with 4 channels the last (alpha) is left out, as the
        API does.
    alpha : bool, optional
        Whether the last channel is alpha (see ``core.planes.resolve_alpha``).

    Returns
    -------
    (low, high) : tuple of float
        (0, 255) for uint8; otherwise the 0.5th and 99.5th percentiles of the
        finite values, equal bit for bit to ``numpy.percentile`` on the same
        values held in memory ((0, 1) without finite values, ``high = low + 1``
        for a constant image, see ``core.tone_scale.separated_limits``).
        Passing them as ``tone_limits`` renders exactly what ``labyrinth``
        renders without them.

    Notes
    -----
    A dask array is never loaded whole: 8- and 16-bit integers take one pass
    over the data (a count of every value); other types take a min/max pass,
    a histogram pass and a pass that gathers the distinct values of the bins
    holding the order statistics (more only for extremely concentrated data,
    or values beside far outliers: then a min/max pass of a bin's own values
    and a histogram over their range).
    Memory stays within a few blocks and a few MB of partial results.
    """
    values = without_alpha(image, channel_axis, alpha)
    if not is_lazy(values):
        scale = resolve_tone_scale(np.asarray(values), None)
        return scale.low, scale.high
    if np.dtype(values.dtype) == np.uint8:
        return 0.0, 255.0
    result = percentiles(values, DEFAULT_PERCENTILES)
    if result is None:
        return 0.0, 1.0
    return separated_limits(*result)


def rendering_tone_limits(image, *, channel_axis=None, alpha=None, colour=None):
    """The tone limits :func:`render_lazy` finds for a dask ``image`` given none: exact and
    streamed (those of its luminance in the luminance mode), or None for uint8 (the
    paper's scale, no scan). What ``variance_threshold="auto"`` measures its probe on, so
    that a dask image gets the V its numpy array gets.

    Raises
    ------
    TypeError, ValueError
        As :func:`render_lazy`, before any block is read.
    """
    image, channel_axis, has_alpha, layout = checked_lazy(image, channel_axis, alpha)
    in_luminance = renders_luminance(colour, layout, alpha)
    return streamed_limits(image, channel_axis, has_alpha, in_luminance)


def streamed_limits(image, channel_axis, has_alpha, in_luminance):
    """The default tone limits of a native-order dask image, None for uint8."""
    if image.dtype == np.uint8:
        return None
    if in_luminance:
        values = luminance_for_limits(lazy_luminance(image, channel_axis), image.dtype)
        return default_tone_limits(values)  # exact, streamed
    return default_tone_limits(image, channel_axis, has_alpha)  # exact, streamed


def lazy_luminance(image, channel_axis: int):
    """The luminance (float64, ``core.colour.luminance``) of a dask array's R, G, B, lazily.

    Shaped as ``image`` without its colour axis; each block is computed from
    the same block's channels.
    """
    axis = channel_axis % image.ndim
    channels = image.rechunk({axis: -1})
    return channels.map_blocks(
        luminance,
        axis=axis,
        drop_axis=axis,
        dtype=np.float64,
        meta=np.empty((0,) * (image.ndim - 1)),
    )
