"""The walls of a rendering: where they are, how much of it they cover, how wide they are."""

from __future__ import annotations

import math

import numpy as np

from ._definitions import MIN_COVER
from ._lazy_kernels import _numba_kernels
from ._maps import _Maps, _maps_of

# Lag vectors (dy, dx) of the four lattice directions (their normals: (1, 0), (0, 1),
# (1, -1), (1, 1); see _kernels.FAMILIES).
_DIRECTIONS = ((0, 1), (1, 0), (1, 1), (1, -1))


def wall_map(image) -> np.ndarray:
    """Boolean map of pixels covered by oriented, wall-like fine texture.

    A pixel is on a wall where, for one of the four lattice directions d
    with normal n, the fine-scale component h is locally correlated along d
    (``C(d) > ALONG_THRESHOLD``: walls continue) and alternates across it
    (``C(w n) < -ALTERNATION_THRESHOLD`` and ``C(2 w n) > ALTERNATION_THRESHOLD``
    for a wall width w of 1 or 2 pixels), in a region that is not flat (local
    RMS of h above ``ENERGY_FLOOR`` tones). ``C`` is the local lag
    correlation over a Gaussian window of sigma ``WINDOW_SIGMA``. White and
    salt-and-pepper noise are not correlated along any direction; smooth
    edges and blur do not alternate.

    The local lag correlation is ``C(d) = G * (h(p) h(p + d)) / G * h**2``,
    symmetric in d (the product averaged over d and -d), with G the Gaussian
    window and lags wrapping around the plane. The result is read-only and
    shared between callers.
    """
    walls, _, _ = _maps_of(image).walls()
    return _read_only(walls)


def labyrinth_cover(image) -> float:
    """Fraction of the image covered by labyrinth walls (see :func:`wall_map`)."""
    return _maps_of(image).cover()


def wall_width(image) -> float:
    """Characteristic width of the walls, in pixels, from how often tones cross over.

    Walls and gaps are the signs of ``g - G_2 * g`` (the image minus its local
    mean). Along a line at angle phi across walls of width w running at angle
    theta the sign changes ``|sin(phi - theta)| / w`` times per pixel, on
    average ``2 / (pi w)`` over all phi (Cauchy-Crofton). The rate is counted
    between neighbours on the wall map along the four lattice directions
    (diagonal steps are sqrt(2) long), averaged, and inverted:
    ``w = 2 / (pi * rate)``. NaN when walls cover less than ``MIN_COVER`` of
    the image: there is no wall to measure.
    """
    return _wall_width(_maps_of(image))


def _wall_width(maps: _Maps) -> float:
    if maps.cover() < MIN_COVER:
        return math.nan
    walls, _, _ = maps.walls()
    counts = np.empty((walls.shape[0], len(_DIRECTIONS), 2), dtype=np.int64)
    maps._bands(_numba_kernels().wall_pair_counts, walls, maps.above_local_mean(), counts)
    counts = counts.sum(axis=0)
    rates = [
        flips / both / math.hypot(dy, dx) if both else math.nan
        for (both, flips), (dy, dx) in zip(counts.tolist(), _DIRECTIONS)
    ]
    rate = float(np.mean(rates))
    return 2.0 / (math.pi * rate) if rate > 0 else math.inf


def _read_only(array: np.ndarray) -> np.ndarray:
    """A read-only view: what a caller gets of a shared map.

    The maps themselves stay writeable (numba compiles a kernel once per
    kind of array it is given; read-only arrays would double the kernels).
    """
    view = array.view()
    view.flags.writeable = False
    return view
