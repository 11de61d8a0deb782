"""The kernel of the wall map: 12 lag correlations of the fine-scale component, smoothed
in float64 as scipy smooths them, decide which pixels are on walls."""

from __future__ import annotations

import numpy as np

from ...core._jit import cached_njit
from ._rows import _gauss, _reflect
from .smoothing import X_TILE

#: Lattice directions as families of lags: family f holds the lags k * u_f, k = 1, 2, 4.
FAMILIES = ((0, 1), (1, 0), (1, 1), (1, -1))
#: The family of the normal of each direction: (0, 1) <-> (1, 0), (1, 1) <-> (1, -1).
NORMAL_FAMILY = np.array([1, 0, 3, 2], dtype=np.int64)
#: Lag maps of the wall pass: map 3 f + q is the symmetric lag product of h at lag
#: k_q * u_f (k = 1, 2, 4).
LAG_DY = np.array([k * dy for dy, _ in FAMILIES for k in (1, 2, 4)], dtype=np.int64)
LAG_DX = np.array([k * dx for _, dx in FAMILIES for k in (1, 2, 4)], dtype=np.int64)

#: Rows of a block of the 12 lag maps of the wall pass.
LAG_BLOCK = 64


@cached_njit(nogil=True, error_model="numpy", no_cfunc_wrapper=True)
def wall_band(
    fine, weights, energy_floor2, along_threshold, alternation_threshold, energy, flags, y0, y1
):
    """The wall map ``flags`` on rows ``[y0, y1)``, from ``h`` (``fine``) and its energy
    ``E = G * h**2`` (every row: :func:`fine_scale_band`'s); returns the count of walls.

    The 12 lag correlations ``C(d) = G * ((h(p) h(p + d) + h(p - d) h(p)) / 2) / E``, the
    lags wrapping around the plane (``np.roll``), are smoothed in float64 as scipy smooths
    (axis 0, then axis 1, ``reflect``, the same operations in the same order) and divided
    by ``E`` (at least 1e-12): the reference's floats, so its wall map. They are smoothed in
    column tiles of ``X_TILE`` and blocks of ``LAG_BLOCK`` rows, each map on the rows where
    some pixel's decision reads it: a pixel above the energy floor is on a wall where, for a
    direction f with normal g, ``C(u_f) > along`` and (``C(u_g) < -alternation`` and
    ``C(2 u_g) > alternation``, or ``C(2 u_g) < -alternation`` and ``C(4 u_g) >
    alternation``), the maps read in this order.
    """
    height, width = fine.shape
    radius = weights.shape[0] - 1
    ring_rows = 2 * radius + 1
    span = X_TILE + 2 * radius
    ring = np.empty((ring_rows, span))  # rows of a lag product, by virtual row
    lines = np.empty((2, span))  # a column pass's output, its extension
    lags = np.empty((12, LAG_BLOCK, X_TILE))  # the smoothed products of a block
    textured = np.empty(LAG_BLOCK, dtype=np.bool_)  # rows with a pixel above the energy floor
    needed = np.empty(LAG_BLOCK, dtype=np.bool_)  # rows whose pixels read the map smoothed
    taps = np.empty((2, 4, radius + 1), dtype=np.int64)  # :func:`_gauss`'s: down, along
    for j in range(radius + 1):
        taps[0, 2, j] = 0
        taps[0, 3, j] = 0
        taps[1, 0, j] = 0
        taps[1, 1, j] = 0
        taps[1, 2, j] = radius - j
        taps[1, 3, j] = radius + j
    count = 0
    for x0 in range(0, width, X_TILE):
        x1 = min(width, x0 + X_TILE)
        tile = x1 - x0
        s0 = max(0, x0 - radius)
        s1 = min(width, x1 + radius)
        interior = x0 - radius >= 0 and x1 + radius <= width
        column = lines[0, : s1 - s0]
        ext = lines[1, : tile + 2 * radius]
        for b0 in range(y0, y1, LAG_BLOCK):
            b1 = min(y1, b0 + LAG_BLOCK)
            any_textured = False
            for y in range(b0, b1):
                found = False
                for x in range(x0, x1):
                    if energy[y, x] > energy_floor2:
                        found = True
                        break
                textured[y - b0] = found
                any_textured = any_textured or found
            if not any_textured:
                for y in range(b0, b1):
                    for x in range(x0, x1):
                        flags[y, x] = False
                continue
            # the maps of lag 1, then 2, then 4: lag 2 of family g is read where C > along
            # along the direction whose normal is g, lag 4 where C(2 u_g) < -alternation too
            for step in range(3):
                for family in range(4):
                    m = 3 * family + step
                    along_map = 3 * NORMAL_FAMILY[family]
                    any_row = False
                    for y in range(b0, b1):
                        found = textured[y - b0] and step == 0
                        for i in range(tile if textured[y - b0] and step > 0 else 0):
                            e = energy[y, x0 + i]
                            if not e > energy_floor2:
                                continue
                            e = e if not e < 1e-12 else 1e-12
                            if lags[along_map, y - b0, i] / e > along_threshold and (
                                step == 1 or lags[m - 1, y - b0, i] / e < -alternation_threshold
                            ):
                                found = True
                                break
                        needed[y - b0] = found
                        any_row = any_row or found
                    if not any_row:
                        continue
                    dy = LAG_DY[m]
                    dx = LAG_DX[m]
                    e1 = min(max(abs(dx), s0), s1)
                    e2 = max(min(width - abs(dx), s1), e1)
                    for v in range(b0 - radius, b1 + radius):
                        row = _reflect(v, height)
                        out = ring[v % ring_rows]
                        centre = fine[row]
                        ahead = fine[(row + dy) % height]
                        behind = fine[(row - dy) % height]
                        # the products' rows: columns [e1, e2) need no modulo, the others wrap
                        for k in range((e1 - s0) + (s1 - e2)):
                            x = s0 + k if k < e1 - s0 else e2 + k - (e1 - s0)
                            out[x - s0] = 0.5 * (
                                centre[x] * ahead[(x + dx) % width]
                                + behind[(x - dx) % width] * centre[x]
                            )
                        if e2 > e1:
                            middle = centre[e1:e2]
                            ahead_middle = ahead[e1 + dx : e2 + dx]
                            behind_middle = behind[e1 - dx : e2 - dx]
                            out_middle = out[e1 - s0 : e2 - s0]
                            for i in range(e2 - e1):
                                out_middle[i] = 0.5 * (
                                    middle[i] * ahead_middle[i] + behind_middle[i] * middle[i]
                                )
                        y = v - radius  # the row the ring now holds every row of
                        if y < b0 or not needed[y - b0]:
                            continue
                        for j in range(radius + 1):
                            taps[0, 0, j] = (y - j) % ring_rows
                            taps[0, 1, j] = (y + j) % ring_rows
                        _gauss(ring, taps[0], weights, column)
                        line = lines[0:1]
                        if not interior:
                            for k in range(tile + 2 * radius):
                                x = x0 - radius + k
                                if x < 0 or x >= width:
                                    x = _reflect(x, width)
                                ext[k] = column[x - s0]
                            line = lines[1:2]
                        _gauss(line, taps[1], weights, lags[m, y - b0, :tile])
            for y in range(b0, b1):
                for i in range(tile):
                    e = energy[y, x0 + i]
                    wall = False
                    if e > energy_floor2:
                        e = e if not e < 1e-12 else 1e-12
                        for direction in range(4):
                            if not lags[3 * direction, y - b0, i] / e > along_threshold:
                                continue
                            n = 3 * NORMAL_FAMILY[direction]
                            c2 = lags[n + 1, y - b0, i] / e
                            if (
                                lags[n, y - b0, i] / e < -alternation_threshold
                                and c2 > alternation_threshold
                            ) or (
                                c2 < -alternation_threshold
                                and lags[n + 2, y - b0, i] / e > alternation_threshold
                            ):
                                wall = True
                                break
                    flags[y, x0 + i] = wall
                    count += wall
    return count
