"""Colour images rendered in their luminance: the labyrinth in the brightness, the colours kept.

With ``colour="luminance"`` (the default for 3 or 4 channels) an RGB(A)
image is not rendered channel by channel: its luminance Y (Rec. 709 luma of
the values as they are) is rendered as a grey image would be, one plane per
position, and the change of luminance is put back into the colour
(:func:`recolour`). ``colour="channels"`` renders every channel as an
independent plane. Alpha is never rendered.

The steps, each a function here (numpy only; :class:`LuminancePlanes` holds
them together for the API and the lazy path):

1. :func:`luminance` of R, G and B, in float64;
2. :func:`luminance_tone_scale`: the tone limits of the luminance, as a grey
   image of the input's dtype would get them;
3. :func:`luminance_tones`: the 0-255 tones the kernel renders, computed as
   for that grey image;
4. :func:`write_changes`: for every pixel whose tone changed, the new
   luminance Y' and the new colour (:func:`recolour`), rounded to the input
   dtype; every other pixel keeps its exact input value.

A grey RGB image (R = G = B) therefore renders, channel by channel, exactly
as its grey plane does.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np

from .tone_scale import ToneScale, representable, resolve_tone_scale, validate_tone_limits

#: The ways of rendering an image with colour channels.
COLOUR_MODES = {
    "luminance": (
        "render the luminance of R, G, B as one grey plane and put its change back "
        "into the colour, keeping hue (default for 3 or 4 channels)"
    ),
    "channels": (
        "render every channel as an independent plane (default for other channel counts)"
    ),
}

#: Channel counts that the luminance mode renders: RGB and RGBA (alpha kept).
LUMINANCE_CHANNELS = (3, 4)

#: Weights of R, G and B in the luminance: Rec. 709 luma (sRGB primaries), applied to the
#: values as they are, without linearising them (``skimage.color.rgb2gray`` uses 0.2125,
#: 0.7154, 0.0721).
LUMA_WEIGHTS = (0.2126, 0.7152, 0.0722)


def resolve_colour(colour: Any, shape: Sequence[int], channel_axis: int | None) -> str:
    """The colour mode of an image of ``shape``: ``"luminance"`` or ``"channels"``.

    ``None`` chooses ``"luminance"`` for a colour axis of 3 or 4 channels
    and ``"channels"`` otherwise (no colour axis, 2 channels, more than 4).

    Raises
    ------
    TypeError, ValueError
        Naming ``colour``: an unknown mode, or ``"luminance"`` for an image
        without 3 or 4 channels.
    """
    if colour is not None and not isinstance(colour, str):
        raise TypeError(f"colour must be a string or None, got {colour!r}")
    if colour is not None and colour not in COLOUR_MODES:
        choices = ", ".join(map(repr, COLOUR_MODES))
        raise ValueError(f"colour must be one of {choices} or None, got {colour!r}")
    channels = None if channel_axis is None else int(shape[channel_axis])
    rgb = channels in LUMINANCE_CHANNELS
    if colour is None:
        return "luminance" if rgb else "channels"
    if colour == "luminance" and not rgb:
        what = "no channel_axis" if channels is None else f"{channels} channels"
        raise ValueError(
            "colour='luminance' needs a channel_axis of 3 (RGB) or 4 (RGBA) channels, "
            f"got {what}; use colour='channels' to render channels as independent planes"
        )
    return colour


def luminance(image: np.ndarray, axis: int = -1) -> np.ndarray:
    """Luminance (Rec. 709 luma) of the first three channels along ``axis``, in float64.

    ``Y = 0.2126 R + 0.7152 G + 0.0722 B``, computed as
    ``G + 0.2126 (R - G) + 0.0722 (B - G)`` so that a grey pixel
    (R = G = B) has exactly its own value as luminance. A pixel with a
    non-finite channel has a non-finite luminance.
    """
    red, green, blue = (
        np.take(image, channel, axis=axis).astype(np.float64) for channel in range(3)
    )
    weight_red, _, weight_blue = LUMA_WEIGHTS
    with np.errstate(invalid="ignore", over="ignore"):  # inf - inf: a non-finite pixel
        red -= green
        blue -= green
        red *= weight_red
        blue *= weight_blue
        green += red
        green += blue
    return green


def luminance_for_limits(luminance_values, dtype: np.dtype):
    """The luminance of an image of ``dtype`` whose percentiles are its default tone limits.

    Works on numpy and dask arrays alike (the lazy path streams its percentiles).
    """
    dtype = np.dtype(dtype)
    return luminance_values if dtype.kind in "iu" else luminance_values.astype(dtype)


def luminance_tone_scale(
    luminance_values: np.ndarray, dtype: np.dtype, tone_limits: Any
) -> ToneScale:
    """The tone scale of a luminance image computed from an image of ``dtype``.

    As for a grey image of that dtype: ``tone_limits`` if given, (0, 255)
    for uint8, otherwise the 0.5th and 99.5th percentiles of the finite
    luminance values.
    """
    if tone_limits is not None:
        return ToneScale(*validate_tone_limits(tone_limits))
    if np.dtype(dtype) == np.uint8:
        return ToneScale(0.0, 255.0)
    return resolve_tone_scale(luminance_for_limits(luminance_values, dtype), None)


def luminance_tones(luminance_values: np.ndarray, dtype: np.dtype, scale: ToneScale) -> np.ndarray:
    """float32 0-255 tones of the luminance of an image of ``dtype``.

    Mapped as a grey image of that dtype is mapped (in float32 for 8- and
    16-bit and float32 images, in float64 otherwise); non-finite luminance
    becomes NaN.
    """
    dtype = np.dtype(dtype)
    if dtype.itemsize <= 2 or dtype == np.float32:
        return scale.to_tones(luminance_values.astype(np.float32))
    return scale.to_tones(luminance_values)


def recolour(
    colours: np.ndarray,
    old_luminance: np.ndarray,
    new_luminance: np.ndarray,
    dtype: np.dtype,
    axis: int = -1,
) -> np.ndarray:
    """R, G, B of pixels whose luminance changes from Y to Y', in ``dtype``.

    Each channel c becomes ``Y' + (c - Y) f`` with ``f = min(Y'/Y, 1)``:

    - darker (Y' < Y): every channel is scaled by Y'/Y, which keeps hue and
      saturation (HSV) exactly;
    - brighter (Y' > Y), and wherever Y <= 0: Y' - Y is added to every
      channel, which keeps the hue and the colour's difference from its grey
      (c - Y): the chroma of a dark pixel, mostly noise, is not amplified;
    - a black pixel (R = G = B = 0, so Y = 0) becomes grey Y';
    - for integer dtypes, where a channel would leave the dtype's range, f is
      lowered (towards grey) until the channel reaches the range's end: hue
      and Y' are kept, saturation drops. Floats have no range to leave.

    The luminance of the result is Y' (before rounding). Integers are
    rounded half to even and clipped, as the tone scale rounds.

    Parameters
    ----------
    colours : ndarray
        The pixels' channels along ``axis``, R, G, B first (further channels
        are ignored).
    old_luminance, new_luminance : ndarray
        Y (:func:`luminance` of ``colours``) and Y', shaped as ``colours``
        without ``axis``.
    dtype : dtype
        The dtype of the result.
    axis : int, optional
        The channel axis of ``colours`` and of the result.

    Returns
    -------
    ndarray
        The three new channels along ``axis``, in ``dtype``.
    """
    rgb = np.moveaxis(np.asarray(colours), axis, -1)[..., :3].astype(np.float64)
    old = np.asarray(old_luminance, dtype=np.float64)[..., np.newaxis]
    new = np.asarray(new_luminance, dtype=np.float64)[..., np.newaxis]
    difference = rgb - old
    with np.errstate(divide="ignore", invalid="ignore"):
        factor = np.where(old > 0, np.clip(new / old, 0.0, 1.0), 1.0)
    dtype = np.dtype(dtype)
    if dtype.kind in "iu":  # never leave the dtype's range: move towards grey instead
        info = np.iinfo(dtype)
        with np.errstate(divide="ignore", invalid="ignore"):
            room = np.where(
                difference > 0,
                (info.max - new) / difference,
                np.where(difference < 0, (info.min - new) / difference, np.inf),
            )
        factor = np.clip(np.minimum(factor, room.min(axis=-1, keepdims=True)), 0.0, None)
    with np.errstate(over="ignore"):  # a brighter channel beyond float64's: clipped below
        result = new + difference * factor
    return np.moveaxis(representable(result, dtype), -1, axis)


def write_changes(
    target: np.ndarray,
    source: np.ndarray,
    luminance_values: np.ndarray,
    tones: np.ndarray,
    new_tones: np.ndarray,
    scale: ToneScale,
) -> None:
    """Put the change of tones of one plane back into its colour.

    ``target`` and ``source`` are ``(C, H, W)`` (``target`` holds the source
    values), ``luminance_values``, ``tones`` and ``new_tones`` are
    ``(H, W)``. Pixels whose tone changed get :func:`recolour` of their new
    luminance ``scale.from_tones(new_tones)``; the others, and every channel
    after B (alpha), are left as they are.
    """
    changed = tones.view(np.uint32) != new_tones.view(np.uint32)
    if not changed.any():
        return
    new_luminance = scale.from_tones(new_tones[changed], np.float64)
    colours = source[:3, changed]
    target[:3, changed] = recolour(
        colours, luminance_values[changed], new_luminance, target.dtype, axis=0
    )


#: The tone scale of arrays that already hold 0-255 tones: ``to_tones`` and
#: ``from_tones`` leave float32 tones exactly as they are. The engine renders
#: the luminance tones with it, so that the new luminance is computed once,
#: in float64, from the new tones.
TONES = ToneScale(0.0, 255.0)


class LuminancePlanes:
    """The luminance of the planes of a colour image, and its tones.

    Parameters
    ----------
    planes : ndarray
        The image with its colour axis third from last, ``leading + (C, H,
        W)`` (as ``PlaneLayout.to_planes`` gives it), C = 3 or 4.
    tone_limits : (float, float), optional
        As for :func:`napari_labyrinth.labyrinth`; the default limits are
        those of the luminance (:func:`luminance_tone_scale`).
    scale : ToneScale, optional
        The tone scale, if already known (it replaces ``tone_limits``).

    Attributes
    ----------
    planes : ndarray
    values : ndarray
        The luminance, float64, ``leading + (H, W)``.
    scale : ToneScale
    tones : ndarray
        Its tones, float32, ``leading + (1, H, W)``: what the kernel renders,
        in the layout of ``PlaneLayout.luminance_layout``.
    """

    def __init__(
        self, planes: np.ndarray, tone_limits: Any = None, *, scale: ToneScale | None = None
    ):
        self.planes = planes
        self.values = luminance(planes, axis=-3)
        if scale is None:
            scale = luminance_tone_scale(self.values, planes.dtype, tone_limits)
        self.scale = scale
        self.tones = luminance_tones(self.values, planes.dtype, scale)[..., np.newaxis, :, :]

    def put_back(self, target: np.ndarray, new_tones: np.ndarray, index: tuple = ()) -> None:
        """Write the colours of the position ``index`` whose tone changed into ``target``.

        ``target`` is shaped as ``planes`` and holds their values;
        ``new_tones`` is shaped as ``tones``.
        """
        write_changes(
            target[index],
            self.planes[index],
            self.values[index],
            self.tones[index][0],
            new_tones[index][0],
            self.scale,
        )

    def put_back_all(self, target: np.ndarray, new_tones: np.ndarray) -> None:
        """:meth:`put_back` for every position."""
        for index in np.ndindex(self.values.shape[:-2]):
            self.put_back(target, new_tones, index)
