"""Orientations from the structure tensor: of a plane, how parallel its walls are, how well
a rendering's walls run along the contours of its input."""

from __future__ import annotations

import math

import numpy as np

from ._definitions import (
    CONTOUR_SIGMA,
    CONTOUR_SIGMA_PARAMETER,
    MIN_COVER,
    SIGMA,
    WINDOW_SIGMA,
)
from ._lazy_kernels import _numba_kernels
from ._maps import _Maps, _maps_of
from ._planes import _float32_scale, _float_plane, _kernel_plane, _plane, _same_shape
from ._tensor import _orientation_maps


def orientation(image, sigma: float = WINDOW_SIGMA):
    """Dominant local orientation and its coherence from the structure tensor.

    The plane is first upsampled twice (linear interpolation): the central
    differences of the structure tensor cannot see a pattern at the Nyquist
    frequency (1-pixel walls), its double can. The tensor of
    ``skimage.feature.structure_tensor`` with a window of ``sigma`` original
    pixels is then sampled back on the original grid. Returns
    ``(angle, coherence, strength)``: the angle (radians, modulo pi) of the
    local gradient direction, the coherence ``((l1 - l2) / (l1 + l2))**2`` in
    [0, 1] of the eigenvalues ``l1 >= l2``, and ``l1 + l2``.

    The upsampling is ``scipy.ndimage.zoom(plane, 2, order=1, grid_mode=True,
    mode="nearest")``; only the tensor's samples on the original grid are
    computed, in float32 (relative error about 1e-7), on the plane times a
    power of two: the angle and the coherence of a plane of any magnitude
    are those of a plane of tones, and the strength is divided back by the
    power's square (infinite, or 0, where it leaves float64's range).

    Parameters
    ----------
    image : array_like
        A 2-D plane of real numbers, at least 3 x 3.
    sigma : float, optional
        The window's Gaussian sigma, in original pixels, within the bounds
        of :data:`SIGMA`.

    Returns
    -------
    angle, coherence, strength : ndarray
        float64 planes shaped as ``image``.

    Raises
    ------
    TypeError, ValueError
        For an ``image`` that is not such a plane or a ``sigma`` out of bounds.
    """
    sigma = SIGMA.validate(sigma)
    plane = _float_plane(_plane(image))
    largest = float(np.max(np.abs(plane), where=np.isfinite(plane), initial=0.0))
    scale = _float32_scale(largest)
    if scale != 1.0:
        # scaled in float64 first: exact, where the kernel's interpolation of subnormal
        # values would round them to a few bits
        plane = plane * scale
    outputs = tuple(np.empty(plane.shape, dtype=np.float32) for _ in range(4))
    _orientation_maps(plane, 1.0, sigma, _numba_kernels().TENSOR_COMPONENTS, None, None, outputs)
    # the angle and the coherence do not depend on the scale: taken before it is undone
    jrr, jrc, jcc = (component.astype(np.float64) for component in outputs[:3])
    trace = jrr + jcc
    difference = np.sqrt((jrr - jcc) ** 2 + 4 * jrc**2)
    coherence = np.divide(difference, trace, out=np.zeros_like(trace), where=trace > 0) ** 2
    # a window of one pixel makes a rank-one tensor, whose float32 rounding can put the
    # ratio a few ulps above 1
    np.minimum(coherence, 1.0, out=coherence)
    angle = 0.5 * np.arctan2(2 * jrc, jrr - jcc)
    with np.errstate(over="ignore", under="ignore"):  # beyond float64's range: inf or 0
        trace = trace / scale / scale
    return angle, coherence, trace


def orientation_coherence(image) -> float:
    """How parallel the walls are: mean structure-tensor coherence on the wall map.

    The coherence of :func:`orientation` of the fine-scale component,
    averaged over the pixels of :func:`wall_map` with the tensor's strength
    as weight: near 1 for long parallel walls (a fingerprint texture), lower
    for a maze of short turning walls. NaN where there are no walls.

    The tensor's window is :func:`orientation`'s decimated (the doubled
    grid's products filtered 1-2-1, then a Gaussian of the same variance on
    the original grid): the value moves by less than 3e-4 (relative) from
    the doubled grid's on the study images.
    """
    return _orientation_coherence(_maps_of(image))


def _orientation_coherence(maps: _Maps) -> float:
    if maps.cover() < MIN_COVER or not maps.finite:
        return math.nan  # NaN or infinity in h: the weighted sum is NaN
    row_starts, strength, coherent, _, _ = maps.wall_orientation()
    sums = maps._row_sums(2)
    maps._bands(_numba_kernels().wall_weighted_sums, row_starts, strength, coherent, sums)
    numerator = math.fsum(sums[:, 0])
    denominator = math.fsum(sums[:, 1])
    return numerator / denominator if denominator > 0 else math.nan


def contour_alignment(original, rendered, *, contour_sigma: float = CONTOUR_SIGMA) -> float:
    """How well the rendered walls run along the contours of the input.

    The weighted mean, over the walls of ``rendered`` (:func:`wall_map`), of
    ``cos**2`` of the angle between the local orientation of the walls and
    that of the input's contours (structure tensor at ``contour_sigma``),
    weighted by both coherences and strengths. 1: walls parallel to the
    contours; 0.5: no relation; 0: walls across the contours. NaN where walls
    cover less than ``MIN_COVER`` of the image or the input has no contours.

    Both tensors are decimated (see :func:`orientation_coherence`; a
    ``contour_sigma`` below ``_DECIMATED_SIGMA`` = 1 pixel takes the doubled
    grid's): the value moves by less than 1.5e-3 (relative) from the
    doubled grid's on the study images.

    ``contour_sigma`` (pixels) is checked first, against the bounds of
    :data:`SIGMA`: a TypeError or ValueError names it.
    """
    contour_sigma = CONTOUR_SIGMA_PARAMETER.validate(contour_sigma)
    before = _plane(original, "original")
    after = _plane(rendered, "rendered")
    _same_shape(before, after)
    maps = _maps_of(after, "rendered")
    if maps.cover() < MIN_COVER:
        return math.nan  # before the contours are computed for nothing
    return _contour_alignment(_Maps(_kernel_plane(before)), maps, contour_sigma)


def _contour_alignment(before: _Maps, after: _Maps, contour_sigma: float = CONTOUR_SIGMA) -> float:
    if after.cover() < MIN_COVER or not (after.finite and before.finite):
        return math.nan  # NaN or infinity in either image: the weighted sum is NaN
    walls, _, _ = after.walls()
    row_starts, _, wall_coherent, wall_cos, wall_sin = after.wall_orientation()
    contour_rr, contour_rc, contour_cc = before.contours(contour_sigma, walls)
    sums = after._row_sums(2)
    after._bands(
        _numba_kernels().alignment_sums,
        walls,
        row_starts,
        wall_coherent,
        wall_cos,
        wall_sin,
        contour_rr,
        contour_rc,
        contour_cc,
        sums,
    )
    numerator = math.fsum(sums[:, 0])
    total = math.fsum(sums[:, 1])
    if not total > 0:
        return math.nan
    return numerator / total
