"""Kernels that reduce maps to per-row sums: the edges' and the added energy's, the wall
pairs' and their flips, the walls' weighted coherence and alignment with the contours.

Each writes one row of ``sums`` (or ``counts``) per row of the plane; the
caller adds the rows' sums, so that the totals do not depend on the bands.
"""

from __future__ import annotations

import numpy as np

from ...core._jit import cached_njit
from ._rows import _sum
from .tensor import _derived
from .walls import FAMILIES


@cached_njit(nogil=True, error_model="numpy", no_cfunc_wrapper=True)
def edge_sums(after, before, edges, added_mean, edges_mean, sums, y0, y1):
    """For ``a = after - before`` and ``s = edges``, ``sums[y]`` gets, over row y:
    ``sum((a - ma)(s - ms))``, ``sum((a - ma)**2)``, min(a), max(a) and ``sum((s - ms)**2)``
    (:func:`_sum` of the squares)."""
    width = after.shape[1]
    squares = np.empty((1, width))[0]
    for y in range(y0, y1):
        a = after[y]
        b = before[y]
        s = edges[y]
        cross = 0.0
        spread = 0.0
        low = np.inf
        high = -np.inf
        for x in range(width):
            added = a[x] - b[x]
            centred = added - added_mean
            cross += centred * (s[x] - edges_mean)
            spread += centred * centred
            low = min(low, added)
            high = max(high, added)
        sums[y, 0] = cross
        sums[y, 1] = spread
        sums[y, 2] = low
        sums[y, 3] = high
        for x in range(width):
            squares[x] = (s[x] - edges_mean) * (s[x] - edges_mean)
        sums[y, 4] = _sum(squares)


@cached_njit(nogil=True, error_model="numpy", no_cfunc_wrapper=True)
def wall_pair_counts(walls, positive, counts, y0, y1):
    """``counts[y, d]``, per lattice direction d: pixels p of row y with walls at p and
    p + d (wrapping, as ``np.roll``), and among them those where ``positive`` differs
    between p and p + d."""
    height, width = walls.shape
    for k in range(4):
        dy = FAMILIES[k][0]
        dx = FAMILIES[k][1]
        for y in range(y0, y1):
            ahead = (y + dy) % height
            row = walls[y]
            next_row = walls[ahead]
            signs = positive[y]
            next_signs = positive[ahead]
            lo = max(0, -dx)  # x + dx inside the row for x in [lo, hi)
            hi = min(width, width - dx)
            here, there = row[lo:hi], next_row[lo + dx : hi + dx]
            sign, next_sign = signs[lo:hi], next_signs[lo + dx : hi + dx]
            both = 0
            flips = 0
            for x in range(hi - lo):
                pair = np.uint8(here[x]) & np.uint8(there[x])
                both += pair
                flips += pair & (np.uint8(sign[x]) ^ np.uint8(next_sign[x]))
            if dx != 0:  # the wrapped end
                x = 0 if dx < 0 else width - 1
                xn = (x + dx) % width
                if row[x] and next_row[xn]:
                    both += 1
                    flips += signs[x] != next_signs[xn]
            counts[y, k, 0] = both
            counts[y, k, 1] = flips


@cached_njit(nogil=True, error_model="numpy", no_cfunc_wrapper=True)
def wall_weighted_sums(row_starts, strength, coherent, sums, y0, y1):
    """``sums[y]``: ``sum(coherent * walls)`` and ``sum(strength * walls)`` over row y, from
    maps held at the wall pixels only (row y's from index ``row_starts[y]`` to
    ``row_starts[y + 1]``, in the order of their columns)."""
    for y in range(y0, y1):
        numerator = 0.0
        denominator = 0.0
        for i in range(row_starts[y], row_starts[y + 1]):
            numerator += coherent[i]
            denominator += strength[i]
        sums[y, 0] = numerator
        sums[y, 1] = denominator


@cached_njit(nogil=True, error_model="numpy", no_cfunc_wrapper=True)
def alignment_sums(
    walls,
    row_starts,
    wall_coherent,
    wall_cos,
    wall_sin,
    contour_rr,
    contour_rc,
    contour_cc,
    sums,
    y0,
    y1,
):
    """``sums[y]``: ``sum(cos**2(angle difference) * weight)`` and ``sum(weight)`` on the
    walls of row y, weight = wall coherence * strength * contour coherence * strength.

    The walls' maps are held at the wall pixels only (as in
    :func:`wall_weighted_sums`, row y's from index ``row_starts[y]``); the
    contours' tensor components are planes, derived at the walls here as
    :func:`_derive` derives them (float32 results: the same numbers as from
    its maps). ``cos**2(a - b) = (1 + cos 2a cos 2b + sin 2a sin 2b) / 2``.
    """
    width = walls.shape[1]
    for y in range(y0, y1):
        numerator = 0.0
        denominator = 0.0
        i = row_starts[y]
        for x in range(width):
            if walls[y, x]:
                _, coherent, c, s = _derived(contour_rr[y, x], contour_rc[y, x], contour_cc[y, x])
                weight = np.float64(wall_coherent[i]) * np.float64(np.float32(coherent))
                cosine = np.float64(wall_cos[i]) * np.float64(np.float32(c)) + np.float64(
                    wall_sin[i]
                ) * np.float64(np.float32(s))
                numerator += 0.5 * (1.0 + cosine) * weight
                denominator += weight
                i += 1
        sums[y, 0] = numerator
        sums[y, 1] = denominator
