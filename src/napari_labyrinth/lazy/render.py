"""The lazy rendering of a dask array: whole planes per block, each with its own random stream.

A block holds whole planes (and, in the luminance mode, every channel of
them), never tiles, since tiles would change the result; each plane draws the
random stream of its index in the whole array, so the lazy result equals that
of the same data in memory bit for bit.
"""

from __future__ import annotations

import numpy as np

from .._budget import refuse_unaffordable_result
from .._engine import run_to_end
from .._rendering import colour_planes, render_planes, renders_luminance
from ..core.parameters import LabyrinthParameters
from ..core.planes import PlaneLayout, validate_stream_range
from ..core.tone_scale import resolve_tone_scale
from .arrays import checked_lazy
from .tone_limits import streamed_limits


def render_lazy(
    image,
    parameters: LabyrinthParameters,
    seed: int,
    *,
    channel_axis,
    tone_limits,
    plane_offset: int,
    record_passes: bool,
    colour: str | None = None,
    alpha: bool | None = None,
):
    """A lazy dask array rendering ``image`` block by block, whole planes per block.

    In the luminance mode (``colour``) a block holds every channel of its
    planes, and the default tone limits are those of the luminance, streamed.
    A big-endian image is rendered as its native-order equivalent and the
    result cast back to its dtype.

    Raises
    ------
    TypeError, ValueError
        Naming ``image`` or the option at fault, before any block is read:
        unknown chunk sizes, or planes too large to render in this
        machine's memory (see ``_budget``).
    """
    import dask.array as da  # dask is optional: imported on first use

    given = np.dtype(image.dtype)
    image, channel_axis, has_alpha, layout = checked_lazy(image, channel_axis, alpha)
    dtype = image.dtype
    validate_stream_range(plane_offset, layout.n_planes)
    if record_passes:  # a block holds the plane and every pass of it
        what = f"each plane's stack of the input and {parameters.passes} passes"
        refuse_unaffordable_result(
            layout.plane_shape, dtype, parameters.passes + 1, what, lazy=True
        )
    in_luminance = renders_luminance(colour, layout, alpha)
    if tone_limits is None:
        tone_limits = streamed_limits(image, channel_axis, has_alpha, in_luminance)
    scale = resolve_tone_scale(np.empty(0, dtype), tone_limits)
    planes = image if channel_axis is None else da.moveaxis(image, channel_axis, -3)
    whole = {planes.ndim - 2: -1, planes.ndim - 1: -1}
    if channel_axis is not None:
        whole[planes.ndim - 3] = -1  # alpha is recognised by its position among all channels
    planes = planes.rechunk(whole)
    block_channel_axis = None if channel_axis is None else planes.ndim - 3
    leading_total = planes.shape[:-2]

    def render_block(block, block_info=None):
        location = block_info[0]["array-location"]
        layout = PlaneLayout(
            block.shape,
            block_channel_axis,
            plane_offset=plane_offset,
            leading_origin=tuple(start for start, _ in location[:-2]),
            leading_total=leading_total,
            alpha=has_alpha,
        )
        _, grey = colour_planes(block, layout, luminance=in_luminance, scale=scale)
        rendering = render_planes(
            block, layout, scale, grey, parameters, seed, record_passes=record_passes
        )
        result, _ = run_to_end(rendering)
        return result

    if record_passes:
        rendered = planes.map_blocks(
            render_block,
            new_axis=0,
            chunks=((parameters.passes + 1,),) + planes.chunks,
            dtype=dtype,
        )
        shift = 1
    else:
        rendered = planes.map_blocks(render_block, dtype=dtype)
        shift = 0
    if channel_axis is not None:
        rendered = da.moveaxis(rendered, -3, channel_axis + shift)
    return rendered if dtype == given else rendered.astype(given)
