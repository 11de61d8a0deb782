"""The one path of an image's planes through the engine: grey, or in their luminance.

Every rendering goes this way, an image in memory (the API) as each block of
a dask image (``lazy``):

1. :func:`plane_layout`: the image's planes, its colour axis and alpha, and
   (:func:`renders_luminance`) whether it is rendered in its luminance;
2. :func:`colour_planes`: its tone scale and, in the luminance mode, its
   luminance planes (``core.colour.LuminancePlanes``);
3. :func:`render_planes`: a grey image's planes (every channel its own plane)
   go to the engine on their tone scale; a colour image's luminance tones are
   rendered, one plane per position, and each change is put back into the
   colour of a copy.

Only where the tone limits come from differs: the values in memory, or the
whole dask image's, streamed once (``lazy.tone_limits``) and passed as a scale.
"""

from __future__ import annotations

from collections.abc import Generator, Sequence
from typing import Any

import numpy as np

from . import _engine
from .core.colour import TONES, LuminancePlanes
from .core.noise import tone_noise_sigma
from .core.parameters import LabyrinthParameters
from .core.planes import (
    PlaneLayout,
    normalise_channel_axis,
    resolve_alpha,
    resolve_layout_colour,
    without_alpha,
)
from .core.tone_scale import ToneScale, resolve_tone_scale


def plane_layout(shape: Sequence[int], channel_axis: Any, alpha: Any) -> PlaneLayout:
    """The planes of an image of ``shape``: its colour axis normalised, its alpha resolved.

    Raises
    ------
    TypeError, ValueError
        Naming ``channel_axis`` or ``alpha``.
    """
    axis = normalise_channel_axis(channel_axis, len(shape))
    return PlaneLayout(tuple(shape), axis, alpha=resolve_alpha(alpha, shape, axis))


def renders_luminance(colour: Any, layout: PlaneLayout, alpha: Any) -> bool:
    """Whether the image of ``layout`` is rendered in its luminance (``colour``, ``alpha``
    as given to :func:`napari_labyrinth.labyrinth`).

    Raises
    ------
    TypeError, ValueError
        Naming ``colour`` or ``alpha``.
    """
    mode = resolve_layout_colour(colour, layout.shape, layout.channel_axis, alpha)
    return mode == "luminance"


def colour_planes(
    array: np.ndarray,
    layout: PlaneLayout,
    *,
    luminance: bool,
    tone_limits: Any = None,
    scale: ToneScale | None = None,
) -> tuple[ToneScale, LuminancePlanes | None]:
    """The tone scale of ``array`` and, rendered in its luminance, its luminance planes.

    Parameters
    ----------
    array : ndarray
        The image (or a block of whole planes of it), in native byte order.
    layout : PlaneLayout
        Its planes.
    luminance : bool
        Whether it is rendered in its luminance (:func:`renders_luminance`).
    tone_limits : (float, float), optional
        As for :func:`napari_labyrinth.labyrinth`: the default limits are
        those of ``array`` (of its luminance, alpha left out).
    scale : ToneScale, optional
        The scale, already known (a block of a larger image takes the whole
        image's); it replaces ``tone_limits``.

    Returns
    -------
    scale : ToneScale
    luminance_planes : LuminancePlanes or None
        None unless ``luminance``; its scale is then ``scale``.
    """
    if luminance:
        grey = LuminancePlanes(layout.to_planes(array), tone_limits, scale=scale)
        return grey.scale, grey
    if scale is None:
        values = without_alpha(array, layout.channel_axis, layout.has_alpha)
        scale = resolve_tone_scale(values, tone_limits)
    return scale, None


def noise_sigmas(
    array: np.ndarray,
    layout: PlaneLayout,
    scale: ToneScale,
    grey: LuminancePlanes | None,
    workers: int = 1,
) -> np.ndarray:
    """The noise of every plane the engine renders, in tones (``core.noise.tone_noise_sigma``):
    measured once, before the passes, for the noise gate (``noise_gate``), each plane's
    rows shared by ``workers`` threads (no more than ``_engine.idle_cores``).

    Returns
    -------
    ndarray of float64
        Shaped as the rendered planes' leading axes (the luminance layout's
        in the luminance mode); NaN for alpha planes, which are not rendered.
    """
    if grey is None:
        rendered, source = layout, layout.to_planes(array)
    else:
        rendered, scale = layout.luminance_layout(), TONES
        source = rendered.to_planes(grey.tones)
    sigmas = np.full(rendered.leading_shape, np.nan)
    threads = min(workers, _engine.idle_cores()) if workers > 1 else 1
    for index in rendered.rendered_indices():
        sigmas[index] = tone_noise_sigma(source[index], scale, workers=threads)
    return sigmas


def render_planes(
    array: np.ndarray,
    layout: PlaneLayout,
    scale: ToneScale,
    grey: LuminancePlanes | None,
    parameters: LabyrinthParameters,
    seed: int,
    *,
    record_passes: bool,
    workers: int = 1,
    sigmas: np.ndarray | None = None,
) -> Generator[tuple[int, int, np.ndarray], None, tuple[np.ndarray, np.ndarray]]:
    """Render ``array``: :func:`_engine.render`, or in its luminance when ``grey`` is given.

    ``sigmas`` are the planes' noise (:func:`noise_sigmas`), measured by the
    engine when not given and the noise gate is on.

    The same protocol as the engine: yields ``(plane, pass_number, result)``
    after each pass of each plane and returns ``(result, diagnostics)``. In
    the luminance mode ``plane`` is the flat index of the position's first
    channel among the image's planes, and the diagnostics have one plane per
    position.
    """
    if grey is None:
        return _engine.render(
            array, layout, scale, parameters, seed, record_passes=record_passes,
            workers=workers, noise_sigmas=sigmas,
        )  # fmt: skip
    return _render_luminance(
        array, layout, grey, parameters, seed, record_passes=record_passes, workers=workers,
        sigmas=sigmas,
    )  # fmt: skip


def _render_luminance(
    array: np.ndarray,
    layout: PlaneLayout,
    grey: LuminancePlanes,
    parameters: LabyrinthParameters,
    seed: int,
    *,
    record_passes: bool,
    workers: int,
    sigmas: np.ndarray | None = None,
) -> Generator[tuple[int, int, np.ndarray], None, tuple[np.ndarray, np.ndarray]]:
    """:func:`_engine.render` of a colour image in its luminance, with the same protocol.

    The engine renders the luminance tones (one plane per position, the
    stream of its first channel); the change is put back into the colour of
    a copy of ``array``: in stack mode after every pass of every plane, so
    that the array each progress event carries holds it, otherwise at the
    end. Yields ``(plane, pass_number, result)`` with ``plane`` the flat
    index of the position's first channel among the image's planes.
    """
    channels = layout.leading_shape[-1]
    positions = layout.leading_shape[:-1]
    passes = parameters.passes
    if record_passes:
        result = np.empty((passes + 1,) + array.shape, dtype=array.dtype)
        result[...] = array
    else:
        result = array.copy()
    rendering = _engine.render(
        grey.tones,
        layout.luminance_layout(),
        TONES,
        parameters,
        seed,
        record_passes=record_passes,
        workers=workers,
        noise_sigmas=sigmas,
    )
    try:
        while True:
            try:
                position, pass_number, tones = next(rendering)
            except StopIteration as finished:
                tones, diagnostics = finished.value
                break
            if record_passes:
                index = np.unravel_index(position, positions)
                target = layout.to_planes(result[pass_number])
                grey.put_back(target, tones[pass_number], index)
            yield position * channels, pass_number, result
    finally:
        rendering.close()  # cancelled: the engine's threads stop now
    if not record_passes and passes:
        grey.put_back_all(layout.to_planes(result), tones)
    return result, np.ascontiguousarray(diagnostics[..., 0])
