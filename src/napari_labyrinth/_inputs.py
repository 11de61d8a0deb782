"""The arguments and images the API and the window of V share, checked and prepared.

:func:`prepare_image` turns what a caller passes to
:func:`napari_labyrinth.labyrinth` or :func:`napari_labyrinth.find_window` into
an array in native byte order, its layout of planes, its tone scale and, in
the luminance mode, its luminance planes (``_rendering``), naming the argument
at fault; :func:`validate_workers` resolves the ``workers`` option of both.
"""

from __future__ import annotations

import os
from typing import Any

import numpy as np

from ._rendering import colour_planes, plane_layout, renders_luminance
from .core.colour import LuminancePlanes
from .core.parameters import WORKERS
from .core.planes import PlaneLayout, validate_shape
from .core.tone_scale import ToneScale, validate_dtype


def prepare_image(
    image: Any, channel_axis: Any, tone_limits: Any, colour: Any, alpha: Any = None
) -> tuple[np.ndarray, PlaneLayout, ToneScale, LuminancePlanes | None]:
    """The image as an array, its planes, its tone scale (alpha excluded) and, rendered in
    its luminance, the luminance planes (the scale is then the luminance's)."""
    array = validate_image(image)
    layout = plane_layout(array.shape, channel_axis, alpha)
    luminance = renders_luminance(colour, layout, alpha)
    scale, grey = colour_planes(array, layout, luminance=luminance, tone_limits=tone_limits)
    return array, layout, scale, grey


def validate_image(image: Any) -> np.ndarray:
    """``image`` as an array of a supported dtype, in native byte order (a copy if not).

    Raises
    ------
    TypeError, ValueError
        Naming ``image`` and what was expected.
    """
    if isinstance(image, (str, bytes)) or image is None:
        raise TypeError(f"image must be an array, got {type(image).__name__}")
    if np.ma.is_masked(image):  # its data would be rendered and its mask lost
        raise TypeError(
            "image is a masked array with masked pixels, whose mask the rendering would "
            "lose: pass image.filled(np.nan) (a float image: NaN pixels are kept as they are "
            "and never count as neighbours) or image.data"
        )
    try:
        array = np.asarray(image)
    except (ValueError, TypeError) as exc:  # ragged nested lists, objects numpy refuses
        raise ValueError(
            f"image must be a rectangular array of numbers (nested lists of equal "
            f"lengths); numpy cannot make one of it: {' '.join(str(exc).split())}"
        ) from None
    if array.dtype.kind == "O":
        raise TypeError(
            "image must be an array of numbers, got an array of Python objects (a ragged "
            "nested list, or values of mixed types?)"
        )
    validate_dtype(native_dtype(array.dtype))
    validate_shape(array.shape)
    if not array.dtype.isnative:
        array = array.astype(native_dtype(array.dtype))
    return array


def native_dtype(dtype: np.dtype) -> np.dtype:
    """``dtype`` in the machine's byte order (``>u2`` -> ``uint16`` on a little-endian one)."""
    dtype = np.dtype(dtype)
    return dtype if dtype.isnative else dtype.newbyteorder("=")


def validate_workers(workers: Any) -> int:
    """The threads of a run: ``workers`` checked, every core (at most ``WORKERS.high``) if
    None.

    Raises
    ------
    TypeError, ValueError
        Naming ``workers``.
    """
    if workers is None:
        return min(os.cpu_count() or 1, WORKERS.high)
    return WORKERS.validate(workers)
