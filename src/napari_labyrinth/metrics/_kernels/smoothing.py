"""Kernels that smooth a plane with scipy's Gaussian: its fine-scale component ``h``,
``h``'s energy and the Sobel edges in one pass, and the plane against its local mean at
the walls.

Both follow ``scipy.ndimage.gaussian_filter`` operation for operation (the
same 1-D passes, axis 0 then axis 1, the same ``reflect`` extension, the same
order of the taps: centre first, then the outermost pair down to the
nearest): they are scipy's floats, bit for bit.
"""

from __future__ import annotations

import numpy as np

from ...core._jit import cached_njit
from ._rows import _finite_range, _gauss, _load_row, _plane_shape, _reflect, _reflect_ends, _sum

#: Column tiles of the wall pass and the local mean: a map's ring buffer stays in L2.
X_TILE = 512
#: Rows of a block of the local mean: blocks without walls are skipped.
Y_BLOCK = 128


def gaussian_weights(sigma: float, truncate: float = 4.0) -> np.ndarray:
    """Half of scipy's Gaussian kernel: ``w[j]`` is the weight of offsets +-j.

    The same expression as ``scipy.ndimage._filters._gaussian_kernel1d``, so
    the weights are the same floats.
    """
    radius = int(truncate * float(sigma) + 0.5)
    sigma2 = sigma * sigma
    x = np.arange(-radius, radius + 1)
    phi = np.exp(-0.5 / sigma2 * x**2)
    phi = phi / phi.sum()
    return np.ascontiguousarray(phi[radius:])


# --- the fine-scale component, its energy and the Sobel edges ---------------------------------


@cached_njit(nogil=True, error_model="numpy", no_cfunc_wrapper=True)
def fine_scale_band(planes, fine_weights, weights, fine, fine32, energy, edges, sums, y0, y1):
    """The fine-scale component ``h = plane - G_1 * plane`` of rows ``[y0, y1)``, its energy
    ``G_2 * h**2`` and the plane's Sobel magnitude, in one pass over the rows.

    ``fine``, ``fine32`` (``h`` in float32), ``energy`` (the Gaussian of
    ``weights``) and ``edges`` (``skimage.filters.sobel``, ``reflect``) are
    written where they have the plane's height; an array of one row stands
    for a map not asked for. With the energy, ``h`` is made row by row into
    a ring of ``h**2`` rows that the energy's Gaussian reads (scipy's order,
    ``reflect``), the rows beyond the band included.

    ``sums[y]`` gets, over row y: the sum and the largest finite value of
    ``h**2``, the count of its non-finite values, the largest finite
    ``|plane|``, the sum of ``energy[y]`` and the Sobel magnitude's min,
    max and sum (the last four where those maps are made).
    """
    height, width = _plane_shape(planes)
    fine_radius = fine_weights.shape[0] - 1
    radius = weights.shape[0] - 1
    keep_fine = fine.shape[0] == height
    keep_fine32 = fine32.shape[0] == height
    with_energy = energy.shape[0] == height
    with_edges = edges.shape[0] == height
    reach = radius if with_energy else 0  # the rows of h beyond a row that its energy reads
    # rings of rows, row v (virtual: read reflected) in slot v % (the ring's rows): the
    # plane's, as float64, and h**2's. h at a virtual row is h at the row it reflects, float
    # for float (its Gaussian's taps there pair the same values, added the other way round).
    plane_rows = np.empty((2 * (reach + fine_radius) + 1, width))
    squares = np.empty((2 * radius + 1, width))
    # :func:`_gauss`'s taps down the rings' columns, and along h's and h**2's extended lines
    taps = np.empty((3, 4, max(radius, fine_radius) + 1), dtype=np.int64)
    for j in range(taps.shape[2]):
        for k in range(3):
            taps[k, 0, j] = 0
            taps[k, 1, j] = 0
        taps[0, 2, j] = 0
        taps[0, 3, j] = 0
        taps[1, 2, j] = fine_radius - j
        taps[1, 3, j] = fine_radius + j
        taps[2, 2, j] = radius - j
        taps[2, 3, j] = radius + j
    ring_taps = taps[0]
    lines = np.empty((3, width + 2 * max(radius, fine_radius) + 2))
    ext = lines[0]  # a column pass's output, extended for the pass along the rows
    smooth = lines[1, :width]
    line = lines[2, :width]
    padded = np.empty((3, width + 2))
    first = np.int64(0)  # a literal 0 would make numba compile _load_row once more for it
    for v in range(y0 - reach - fine_radius, y1 + reach + fine_radius):
        _load_row(planes, _reflect(v, height), first, width, plane_rows[v % plane_rows.shape[0]])
        row = v - fine_radius  # the row of h whose rows of the plane the ring now holds
        if row < y0 - reach:
            continue
        for j in range(fine_radius + 1):
            ring_taps[0, j] = (row - j) % plane_rows.shape[0]
            ring_taps[1, j] = (row + j) % plane_rows.shape[0]
        _gauss(plane_rows, ring_taps, fine_weights, ext[fine_radius : fine_radius + width])
        _reflect_ends(ext, fine_radius, width)
        _gauss(lines[0:1], taps[1], fine_weights, smooth)
        tones = plane_rows[row % plane_rows.shape[0]]
        square = squares[row % squares.shape[0]]
        own = y0 <= row < y1  # not a row of another band, nor beyond the plane
        out = fine[row] if own and keep_fine else line
        for x in range(width):
            value = tones[x] - smooth[x]
            out[x] = value
            square[x] = value * value
        if own:
            if keep_fine32:
                out32 = fine32[row]
                for x in range(width):
                    out32[x] = out[x]
            _, largest, nonfinite = _finite_range(square)
            sums[row, 0] = _sum(square)
            sums[row, 1] = max(largest, 0.0)
            sums[row, 2] = nonfinite
            for x in range(width):
                smooth[x] = abs(tones[x])
            sums[row, 3] = max(_finite_range(smooth)[1], 0.0)
        y = row - reach  # the row whose energy reads h's rows up to ``row``
        if y < y0:
            continue
        if with_edges:
            # the plane's rows y - 1, y, y + 1 (in the ring), with one column a side
            # (reflect: column -1 is column 0, column W is W - 1)
            for k in range(3):
                tones = plane_rows[(y - 1 + k) % plane_rows.shape[0]]
                for x in range(width):
                    padded[k, x + 1] = tones[x]
                padded[k, 0] = tones[0]
                padded[k, width + 1] = tones[width - 1]
            up = padded[0]
            mid = padded[1]
            down = padded[2]
            out = edges[y]
            root2 = np.sqrt(2.0)
            for x in range(width):
                d_rows = 0.25 * (
                    (down[x] + 2.0 * down[x + 1] + down[x + 2])
                    - (up[x] + 2.0 * up[x + 1] + up[x + 2])
                )
                d_columns = 0.25 * (
                    (up[x + 2] + 2.0 * mid[x + 2] + down[x + 2]) - (up[x] + 2.0 * mid[x] + down[x])
                )
                out[x] = np.sqrt(d_rows * d_rows + d_columns * d_columns) / root2
            sums[y, 5], sums[y, 6], _ = _finite_range(out)
            sums[y, 7] = _sum(out)
        if with_energy:
            for j in range(radius + 1):
                ring_taps[0, j] = (y - j) % squares.shape[0]
                ring_taps[1, j] = (y + j) % squares.shape[0]
            _gauss(squares, ring_taps, weights, ext[radius : radius + width])
            _reflect_ends(ext, radius, width)
            _gauss(lines[0:1], taps[2], weights, energy[y])
            sums[y, 4] = _sum(energy[y])


# --- the local mean at the walls ---------------------------------------------------------------


@cached_njit(nogil=True, error_model="numpy", no_cfunc_wrapper=True)
def local_mean_band(planes, weights, where, flags, y0, y1):
    """``flags = plane > G * plane`` (scipy's Gaussian of ``weights``, ``reflect``: its
    floats) on rows ``[y0, y1)``, at the True pixels of ``where``; False on the others.

    Axis 0 first (a ring of rows, as :func:`wall_band`), in blocks of
    ``Y_BLOCK`` rows of column tiles (``X_TILE``), on the rows that hold a
    True pixel of ``where`` (blocks without one are skipped); then axis 1 at
    those pixels only (the operations of :func:`_gauss` along a line, in its order).
    """
    height, width = _plane_shape(planes)
    radius = weights.shape[0] - 1
    ring_rows = 2 * radius + 1
    span = X_TILE + 2 * radius
    ring = np.empty((ring_rows, span))
    lines = np.empty((2, span))
    column = lines[0]
    ext = lines[1]
    taps = np.empty((1, 4, radius + 1), dtype=np.int64)  # :func:`_gauss`'s, down the ring
    for j in range(radius + 1):
        for k in range(4):
            taps[0, k, j] = 0
    ring_taps = taps[0]
    needed = np.empty(Y_BLOCK, dtype=np.bool_)
    for x0 in range(0, width, X_TILE):
        x1 = min(width, x0 + X_TILE)
        tile = x1 - x0
        s0 = max(0, x0 - radius)
        s1 = min(width, x1 + radius)
        interior = x0 - radius >= 0 and x1 + radius <= width
        for b0 in range(y0, y1, Y_BLOCK):
            b1 = min(y1, b0 + Y_BLOCK)
            any_row = False
            for y in range(b0, b1):
                row = flags[y]
                for x in range(x0, x1):
                    row[x] = False
                found = False
                walls = where[y]
                for x in range(x0, x1):
                    if walls[x]:
                        found = True
                        break
                needed[y - b0] = found
                any_row = any_row or found
            for v in range(b0 - radius, b1 + radius if any_row else b0 - radius):
                _load_row(planes, _reflect(v, height), s0, s1, ring[v % ring_rows])
                y = v - radius  # the row the ring now holds every row of
                if y < b0 or not needed[y - b0]:
                    continue
                for j in range(radius + 1):
                    ring_taps[0, j] = (y - j) % ring_rows
                    ring_taps[1, j] = (y + j) % ring_rows
                _gauss(ring, ring_taps, weights, column[: s1 - s0])
                line = column
                if not interior:
                    for k in range(tile + 2 * radius):
                        x = x0 - radius + k
                        if x < 0 or x >= width:
                            x = _reflect(x, width)
                        ext[k] = column[x - s0]
                    line = ext
                tones = ring[y % ring_rows]
                for i in range(tile):
                    if where[y, x0 + i]:
                        centre = radius + i
                        value = line[centre] * weights[0]
                        for j in range(radius, 0, -1):
                            value += (line[centre - j] + line[centre + j]) * weights[j]
                        flags[y, x0 + i] = tones[x0 + i - s0] > value
