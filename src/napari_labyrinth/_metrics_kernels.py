"""numba kernels behind :mod:`napari_labyrinth.metrics`.

Every kernel works on a band of output rows ``[y0, y1)`` of a 2-D plane, so
that the caller can share a plane's rows between threads; every kernel
releases the GIL and allocates its own buffers (no shared mutable state).
Sums are made row by row (the caller adds the rows' sums), so that results
do not depend on the bands.

A plane is given as the tuple of :func:`plane_tuple`: one slot per dtype a
plane may have (uint8, uint16, float32, float64), the plane in its own and
empty arrays in the others. Kernels read its rows through
:func:`_load_row`, which converts them to float64 (exactly), so that each
kernel is compiled once for every dtype, and the results are those of the
plane's float64 copy.

Precision, chosen by what each result feeds:

- The fine-scale component, the local energy, the 12 lag correlations
  behind the wall map and the local mean are float64 and follow
  ``scipy.ndimage.gaussian_filter`` operation for operation (the same 1-D
  passes, axis 0 then axis 1, the same ``reflect`` extension, the same
  order of the taps: centre first, then the outermost pair down to the
  nearest): they are scipy's floats, bit for bit, and the wall map the
  reference's.
- The structure tensors (orientations) are float32: they only feed weighted
  means, where float32 rounding moves the result by about 1e-8. The walls'
  and the contours' tensors are decimated (:func:`decimated_tensor_band`):
  the doubled grid's products filtered 1-2-1 and smoothed on the original
  grid, a window within a few per cent of the doubled grid's Gaussian at a
  quarter of its pixels; :func:`orientation_band` is the doubled grid's.

numba compiles every kernel on its first call (then keeps it in its disk
cache), and the time grows with the code it compiles: each kernel and
helper once per signature, and a helper's code once more in every kernel
or helper that calls it (linked into it, optimized and made into machine
code again). The kernels are therefore few, their helpers called by the
kernels themselves rather than by other helpers where that can be, code
used once written where it is used, one signature per helper (a plane of
any dtype in one tuple; no literal constant passed to a helper, which
would compile it once more for its value), plain loops rather than numpy
calls that bring heavy implementations (an array assigned to a slice
compiles numba's formatting of shape errors), and each call compiles only
the kernels it runs (``docs/metrics.md``, "Compile time").
"""

from __future__ import annotations

import numpy as np
from numba import njit

from .core._jit import cached_njit

#: The decorator of the helpers, which only kernels call: no entry point for Python (numba
#: compiles none) and no disk cache of their own (their code is in each kernel's).
_helper = njit(nogil=True, error_model="numpy", no_cpython_wrapper=True, no_cfunc_wrapper=True)

#: Lattice directions as families of lags: family f holds the lags k * u_f, k = 1, 2, 4.
FAMILIES = ((0, 1), (1, 0), (1, 1), (1, -1))
#: The family of the normal of each direction: (0, 1) <-> (1, 0), (1, 1) <-> (1, -1).
NORMAL_FAMILY = np.array([1, 0, 3, 2], dtype=np.int64)
#: Lag maps of the wall pass: map 3 f + q is the symmetric lag product of h at lag
#: k_q * u_f (k = 1, 2, 4).
LAG_DY = np.array([k * dy for dy, _ in FAMILIES for k in (1, 2, 4)], dtype=np.int64)
LAG_DX = np.array([k * dx for _, dx in FAMILIES for k in (1, 2, 4)], dtype=np.int64)

#: Column tiles of the wall pass and the local mean: a map's ring buffer stays in L2.
X_TILE = 512
#: Rows of a block of the local mean: blocks without walls are skipped.
Y_BLOCK = 128
#: Rows of a block of the 12 lag maps of the wall pass.
LAG_BLOCK = 64

#: The dtypes of the slots of :func:`plane_tuple`.
PLANE_DTYPES = (
    np.dtype(np.uint8),
    np.dtype(np.uint16),
    np.dtype(np.float32),
    np.dtype(np.float64),
)
_NO_PLANE = {dtype: np.empty((0, 0), dtype=dtype) for dtype in PLANE_DTYPES}


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


def plane_tuple(plane: np.ndarray) -> tuple[np.ndarray, ...]:
    """The kernels' form of a C-contiguous plane of one of :data:`PLANE_DTYPES`: the plane
    in the slot of its dtype, empty arrays in the others."""
    if plane.dtype not in PLANE_DTYPES or not plane.flags.c_contiguous:
        raise TypeError(
            f"a plane of the kernels is C-contiguous {PLANE_DTYPES}, not {plane.dtype}"
        )
    return tuple(plane if plane.dtype == dtype else _NO_PLANE[dtype] for dtype in PLANE_DTYPES)


# --- helpers shared by the kernels ------------------------------------------------------------


@_helper
def _plane_shape(planes):
    """Height and width of the plane of a :func:`plane_tuple` (the others are empty)."""
    height = planes[0].shape[0] + planes[1].shape[0] + planes[2].shape[0] + planes[3].shape[0]
    width = planes[0].shape[1] + planes[1].shape[1] + planes[2].shape[1] + planes[3].shape[1]
    return height, width


@_helper
def _load_row(planes, row, x0, x1, out):
    """``out[x - x0]`` = the plane's value at (``row``, x) as a float64, for x in ``[x0, x1)``."""
    if planes[0].shape[0] > 0:
        source8 = planes[0][row]
        for x in range(x0, x1):
            out[x - x0] = source8[x]
    elif planes[1].shape[0] > 0:
        source16 = planes[1][row]
        for x in range(x0, x1):
            out[x - x0] = source16[x]
    elif planes[2].shape[0] > 0:
        source32 = planes[2][row]
        for x in range(x0, x1):
            out[x - x0] = source32[x]
    else:
        source64 = planes[3][row]
        for x in range(x0, x1):
            out[x - x0] = source64[x]


@_helper
def _sum(values):
    """The sum of a line: eight interleaved partial sums (independent chains), then those."""
    n = values.shape[0]
    a0 = a1 = a2 = a3 = a4 = a5 = a6 = a7 = 0.0
    end = n - n % 8
    for x in range(0, end, 8):
        a0 += values[x]
        a1 += values[x + 1]
        a2 += values[x + 2]
        a3 += values[x + 3]
        a4 += values[x + 4]
        a5 += values[x + 5]
        a6 += values[x + 6]
        a7 += values[x + 7]
    for x in range(end, n):
        a0 += values[x]
    return ((a0 + a1) + (a2 + a3)) + ((a4 + a5) + (a6 + a7))


@_helper
def _finite_range(values):
    """Smallest and largest finite value of a line (inf, -inf if none) and the count of others."""
    low = np.inf
    high = -np.inf
    others = 0
    for x in range(values.shape[0]):
        value = values[x]
        if abs(value) < np.inf:
            low = min(low, value)
            high = max(high, value)
        else:
            others += 1
    return low, high, others


@_helper
def _reflect(i, n):
    """Index of virtual position ``i`` of a line of ``n`` under scipy's ``reflect``."""
    period = 2 * n
    i = i % period
    if i >= n:
        i = period - 1 - i
    return i


@_helper
def _gauss(rows, taps, weights, out):
    """``out[i]`` = a Gaussian of ``weights`` at column i, in scipy's order of operations for
    a symmetric kernel: the centre times ``w[0]``, then ``+= (a_j + b_j) w[j]`` for j = r ..
    1, four taps per sweep over ``out`` (the same order, fewer loads and stores).

    Tap j's values ``a_j``, ``b_j`` are rows ``taps[0, j]`` and ``taps[1, j]`` of ``rows``
    from columns ``taps[2, j]`` and ``taps[3, j]`` on (the centre: ``taps[0, 0]``,
    ``taps[2, 0]``): a ring of rows read down a column (axis 0: rows y - j and y + j from
    column 0), or one extended line read at shifts along itself (axis 1: columns
    ``start - j`` and ``start + j`` of one row, output column 0 at ``start``).
    """
    n = out.shape[0]
    middle = rows[taps[0, 0], taps[2, 0] :]
    w0 = weights[0]
    for i in range(n):
        out[i] = middle[i] * w0
    j = weights.shape[0] - 1
    while j >= 4:
        a1, b1 = rows[taps[0, j], taps[2, j] :], rows[taps[1, j], taps[3, j] :]
        a2, b2 = rows[taps[0, j - 1], taps[2, j - 1] :], rows[taps[1, j - 1], taps[3, j - 1] :]
        a3, b3 = rows[taps[0, j - 2], taps[2, j - 2] :], rows[taps[1, j - 2], taps[3, j - 2] :]
        a4, b4 = rows[taps[0, j - 3], taps[2, j - 3] :], rows[taps[1, j - 3], taps[3, j - 3] :]
        w1, w2, w3, w4 = weights[j], weights[j - 1], weights[j - 2], weights[j - 3]
        for i in range(n):
            value = out[i]
            value += (a1[i] + b1[i]) * w1
            value += (a2[i] + b2[i]) * w2
            value += (a3[i] + b3[i]) * w3
            value += (a4[i] + b4[i]) * w4
            out[i] = value
        j -= 4
    while j >= 1:
        a, b, w = rows[taps[0, j], taps[2, j] :], rows[taps[1, j], taps[3, j] :], weights[j]
        for i in range(n):
            out[i] += (a[i] + b[i]) * w
        j -= 1


@_helper
def _reflect_ends(ext, radius, n):
    """Extends the line ``ext[radius : radius + n]`` by ``radius`` values on each side under
    scipy's ``reflect``."""
    for i in range(radius):
        ext[i] = ext[radius + _reflect(i - radius, n)]
        ext[radius + n + i] = ext[radius + _reflect(n + i, n)]


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


# --- the wall map -----------------------------------------------------------------------------


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


# --- structure tensor of the plane upsampled twice (float32) ---------------------------

#: What :func:`orientation_band` writes.
TENSOR_COMPONENTS = 0  # jrr, jrc, jcc
TENSOR_DERIVED = 1  # strength, coherence * strength, cos(2 angle), sin(2 angle)

#: Bytes of :func:`orientation_band`'s ring of smoothed rows per column tile when only
#: the walls' pixels are asked for: narrow tiles skip more rows without walls.
TENSOR_RING_BYTES = 256 * 1024
#: Least width of those tiles (2048 x 2048 walls of a labyrinth: 4 tiles are fastest).
TENSOR_MIN_TILE = 512


#: Rows of the float32 scratch array of :func:`_doubled_products` (21 rows of n + 2): the
#: doubled rows it keeps (slot r % 3, even then odd columns), the products ``d_r**2``,
#: ``d_r d_c``, ``d_c**2`` at the even then the odd columns, its work rows, and the
#: vertical interpolation of a doubled row.
_ROWS_E = 0
_ROWS_O = 3
_PRODUCTS_E = 6
_PRODUCTS_O = 9
_WORK = 12
_LINE = 20
_SCRATCH_ROWS = 21


@_helper
def _doubled_products(planes, scale, i, origin, scratch, tones, kept):
    """The tensor products of doubled row ``i`` of the extended plane (any ``i``: a row
    outside the plane reads its nearest rows) into the rows ``_PRODUCTS_E`` and
    ``_PRODUCTS_O`` of ``scratch``.

    The doubled rows i - 1, i, i + 1 are rows of ``zoom(plane, 2, order=1,
    grid_mode=True, mode="nearest")`` times ``scale`` (a power of two:
    exact, keeping float32 products in range), split by parity: even and
    odd doubled columns 2 X and 2 X + 1 at local index k, X = ``origin +
    k``; where X is outside the plane, the doubled row's nearest column (the
    doubled plane extended by its edge values: the structure tensor sees no
    edge at the frame). Doubled pixel 2 k samples the plane at k - 1/4 and
    2 k + 1 at k + 1/4: weights 1/4 and 3/4, clamped at the edges (rows
    too). Each is kept in slot ``r % 3`` (``kept[:3]`` says which doubled
    rows the slots hold), the plane's rows it reads in ``tones`` (row r in
    slot r % 4, ``kept[3:7]``). The products of the Sobel derivatives
    ``d_r**2``, ``d_r d_c``, ``d_c**2`` go to doubled columns 2 X
    (``_PRODUCTS_E``) and 2 X + 1 (``_PRODUCTS_O``) for k in [1, n - 1),
    inside the plane and outside it (the Gaussian reads the extended
    plane's products there).
    """
    height, width = _plane_shape(planes)
    n = scratch.shape[1] - 2
    # local index j holds phase column origin + j; the plane's columns are j in [j0, j1)
    j0 = min(max(0, -origin), n)
    j1 = max(min(n, width - origin), j0)
    lo = origin + j0
    hi = origin + j1
    left = max(lo - 1, 0)  # the plane's columns read, clamped
    right = min(hi, width - 1)
    quarter = np.float32(0.25)
    three_quarters = np.float32(0.75)
    line = scratch[_LINE]
    for q in range(3):
        r = min(max(i - 1 + q, 0), 2 * height - 1)
        kept[7 + q] = r % 3  # the slot of doubled row i - 1 + q
        if kept[r % 3] == r:
            continue
        kept[r % 3] = r
        even = scratch[_ROWS_E + r % 3, :n]
        odd = scratch[_ROWS_O + r % 3, :n]
        if j1 == j0:
            for j in range(n):  # no column of the plane (never asked for)
                even[j] = 0.0
                odd[j] = 0.0
            continue
        k = r // 2
        other = min(max(k - 1 if r % 2 == 0 else k + 1, 0), height - 1)
        for row in (k, other):
            if kept[3 + row % 4] != row:
                _load_row(planes, row, left, right + 1, tones[row % 4])
                kept[3 + row % 4] = row
        near = tones[k % 4]
        far = tones[other % 4]
        # line[j - j0 + 1] = vertical interpolation at column origin + j, for j in
        # [j0 - 1, j1 + 1), clamped
        for x in range(lo, hi):
            line[x - lo + 1] = (0.75 * near[x - left] + 0.25 * far[x - left]) * scale
        line[0] = (0.75 * near[0] + 0.25 * far[0]) * scale
        line[hi - lo + 1] = (0.75 * near[right - left] + 0.25 * far[right - left]) * scale
        for x in range(j1 - j0):
            even[j0 + x] = quarter * line[x] + three_quarters * line[x + 1]
            odd[j0 + x] = three_quarters * line[x + 1] + quarter * line[x + 2]
        # doubled columns before 0 take doubled column 0's value, after 2 W - 1 that one's
        first = even[j0]
        last = odd[j1 - 1]
        for j in range(j0):
            even[j] = first
            odd[j] = first
        for j in range(j1, n):
            even[j] = last
            odd[j] = last
    up_e, up_o = scratch[_ROWS_E + kept[7], :n], scratch[_ROWS_O + kept[7], :n]
    mid_e, mid_o = scratch[_ROWS_E + kept[8], :n], scratch[_ROWS_O + kept[8], :n]
    down_e, down_o = scratch[_ROWS_E + kept[9], :n], scratch[_ROWS_O + kept[9], :n]
    dv_e, dv_o = scratch[_WORK, :n], scratch[_WORK + 1, :n]  # down - up
    sv_e, sv_o = scratch[_WORK + 2, :n], scratch[_WORK + 3, :n]  # up + 2 mid + down
    two = np.float32(2.0)  # float32 arithmetic: a float64 constant would widen the loop
    for k in range(n):
        dv_e[k] = down_e[k] - up_e[k]
        dv_o[k] = down_o[k] - up_o[k]
        sv_e[k] = up_e[k] + two * mid_e[k] + down_e[k]
        sv_o[k] = up_o[k] + two * mid_o[k] + down_o[k]
    rr_e, rc_e, cc_e = scratch[_PRODUCTS_E], scratch[_PRODUCTS_E + 1], scratch[_PRODUCTS_E + 2]
    rr_o, rc_o, cc_o = scratch[_PRODUCTS_O], scratch[_PRODUCTS_O + 1], scratch[_PRODUCTS_O + 2]
    for k in range(1, n - 1):
        dr_e = dv_o[k - 1] + two * dv_e[k] + dv_o[k]
        dr_o = dv_e[k] + two * dv_o[k] + dv_e[k + 1]
        dc_e = sv_o[k] - sv_o[k - 1]
        dc_o = sv_e[k + 1] - sv_e[k]
        rr_e[k] = dr_e * dr_e
        rc_e[k] = dr_e * dc_e
        cc_e[k] = dc_e * dc_e
        rr_o[k] = dr_o * dr_o
        rc_o[k] = dr_o * dc_o
        cc_o[k] = dc_o * dc_o


@_helper
def _gauss_even(line_e, line_o, pad, weights, out):
    """Gaussian of a doubled line at its even columns, from its two phases.

    Doubled column 2 X + t is ``line_e[pad + X + t / 2]`` for even t and
    ``line_o[pad + X + (t - 1) / 2]`` for odd t.
    """
    n = out.shape[0]
    radius = weights.shape[0] - 1
    middle = line_e[pad:]
    w0 = weights[0]
    for i in range(n):
        out[i] = middle[i] * w0
    for t in range(radius, 0, -1):
        if t % 2 == 0:
            a = line_e[pad - t // 2 :]
            b = line_e[pad + t // 2 :]
        else:
            a = line_o[pad - (t - 1) // 2 - 1 :]
            b = line_o[pad + (t - 1) // 2 :]
        w = weights[t]
        for i in range(n):
            out[i] += (a[i] + b[i]) * w


@_helper
def _derive(rr, rc, cc, strength, coherent, cosine, sine):
    """Strength ``l1 + l2``, coherence times strength, cos and sin of twice the angle."""
    for x in range(strength.shape[0]):
        trace, weight, c, s = _derived(rr[x], rc[x], cc[x])
        strength[x] = trace
        coherent[x] = weight
        cosine[x] = c
        sine[x] = s


@_helper
def _derived(rr, rc, cc):
    """:func:`_derive` at one pixel, in float64 (stored in float32 by the callers)."""
    jrr = np.float64(rr)
    jrc = np.float64(rc)
    jcc = np.float64(cc)
    trace = jrr + jcc
    along = jrr - jcc
    across = 2.0 * jrc
    difference = np.sqrt(along * along + across * across)
    coherence = 0.0
    if trace > 0:
        coherence = (difference / max(trace, 1e-12)) ** 2
    c = 1.0
    s = 0.0
    if difference > 0:
        c = along / difference
        s = across / difference
    return trace, coherence * trace, c, s


@cached_njit(nogil=True, error_model="numpy", no_cfunc_wrapper=True)
def orientation_band(planes, scale, weights, mode, needed, out0, out1, out2, out3, y0, y1):
    """Structure tensor of ``zoom(plane, 2)`` at the even doubled pixels of rows ``[y0, y1)``.

    ``skimage.feature.structure_tensor(doubled, sigma, order="rc")[::2, ::2]``
    of the doubled plane extended by its edge values (``np.pad(doubled, p,
    mode="edge")`` for any ``p`` beyond the Gaussian's reach, cropped back):
    Sobel derivatives and a Gaussian (``weights``, on the doubled grid) that
    see no edge at the frame, in float32; only the samples on the original
    grid are computed (the Gaussian's passes at even columns, then at even
    rows).
    ``mode`` TENSOR_COMPONENTS writes jrr, jrc, jcc to ``out0..out2``;
    TENSOR_DERIVED writes the strength ``l1 + l2``, coherence times strength,
    and cos, sin of twice the angle to ``out0..out3``. The plane is first
    multiplied by ``scale``, a power of two (the strengths by its square).

    The columns are cut into ``n = needed.shape[1]`` tiles (tile k: columns
    ``[k W // n, (k + 1) W // n)``); row y of tile k is computed where
    ``needed[y, k]``, the other pixels of the outputs are left as they were
    (see :func:`tensor_tiles` and :func:`mask_counts`).
    """
    height, width = _plane_shape(planes)
    doubled_height = 2 * height
    radius = weights.shape[0] - 1
    ring_rows = 2 * radius + 1
    # every doubled row above the plane has the products of the one just above it, and
    # every row below that of the one just below: one slot each
    top_slot = ring_rows
    bottom_slot = ring_rows + 1
    pad = radius // 2 + 2  # the Gaussian's reach on both phases, and the Sobel's column
    count = needed.shape[1]
    for tile_index in range(count):
        x0 = (tile_index * width) // count
        x1 = ((tile_index + 1) * width) // count
        tile = x1 - x0
        origin = x0 - pad  # phase column of local index 0
        n = tile + 2 * pad
        scratch = np.zeros((_SCRATCH_ROWS, n + 2), dtype=np.float32)
        tones = np.empty((4, n + 2))
        kept = np.empty(10, dtype=np.int64)
        for slot in range(10):
            kept[slot] = -1
        ring = np.zeros((3, ring_rows + 2, tile), dtype=np.float32)
        tensor = np.empty((3, tile), dtype=np.float32)
        taps = np.empty((1, 4, radius + 1), dtype=np.int64)  # :func:`_gauss`'s, down the ring
        for j in range(radius + 1):
            for k in range(4):
                taps[0, k, j] = 0
        next_row = max(0, 2 * y0 - radius)
        # y0 - 2 and y0 - 1 stand for the doubled rows above and below the plane (one row
        # each, made first where this band reads them), then the rows of the band
        for y in range(y0 - 2, y1):
            if y >= y0 and not needed[y, tile_index]:
                continue  # nothing asked for in this row of the tile
            if y == y0 - 2:
                first = -1
                last = -1 if 2 * y0 - radius < 0 else -2
            elif y == y0 - 1:
                first = doubled_height
                last = doubled_height if 2 * (y1 - 1) + radius >= doubled_height else first - 1
            else:
                first = max(next_row, 2 * y - radius)
                last = min(2 * y + radius, doubled_height - 1)
            for i in range(first, last + 1):
                _doubled_products(planes, scale, i, origin, scratch, tones, kept)
                slot = i % ring_rows
                if i < 0 or i >= doubled_height:
                    slot = top_slot if i < 0 else bottom_slot
                else:
                    next_row = i + 1
                for c in range(3):
                    _gauss_even(scratch[_PRODUCTS_E + c], scratch[_PRODUCTS_O + c], pad, weights,
                                ring[c, slot])  # fmt: skip
            if y < y0:
                continue
            centre = 2 * y
            for j in range(radius + 1):
                r = centre - j
                taps[0, 0, j] = r % ring_rows if r >= 0 else top_slot
                r = centre + j
                taps[0, 1, j] = r % ring_rows if r < doubled_height else bottom_slot
            for c in range(3):
                _gauss(ring[c], taps[0], weights, tensor[c])
            if mode == TENSOR_COMPONENTS:
                for x in range(tile):
                    out0[y, x0 + x] = tensor[0, x]
                    out1[y, x0 + x] = tensor[1, x]
                    out2[y, x0 + x] = tensor[2, x]
            else:
                _derive(
                    tensor[0],
                    tensor[1],
                    tensor[2],
                    out0[y, x0:x1],
                    out1[y, x0:x1],
                    out2[y, x0:x1],
                    out3[y, x0:x1],
                )


#: Variance (original pixels squared) of the 1-2-1 filter on the doubled grid that
#: :func:`decimated_tensor_band` applies before sampling the products on the original grid.
PREFILTER_VARIANCE = 0.125


def decimated_sigma(sigma: float) -> float:
    """The Gaussian sigma (original pixels) that :func:`decimated_tensor_band` applies after its
    prefilter: the two together have the variance of a Gaussian of ``sigma``."""
    return float(np.sqrt(sigma * sigma - PREFILTER_VARIANCE))


@cached_njit(nogil=True, error_model="numpy", no_cfunc_wrapper=True)
def decimated_tensor_band(
    planes, scale, weights, mode, needed, starts, mask, out0, out1, out2, out3, y0, y1
):
    """The contours' structure tensor on rows ``[y0, y1)``, decimated.

    The Sobel products of ``zoom(plane, 2)`` extended by its edge values (as
    :func:`orientation_band` computes them, inside the plane and out) are
    filtered with the 1-2-1 kernel / 4 along both axes of the doubled grid
    and sampled at its even pixels (the original grid); a Gaussian of
    ``weights`` (original pixels, over the extended products) follows.
    Filter and Gaussian have the variance of the doubled-grid Gaussian of
    :func:`orientation_band` when ``weights`` are those of
    :func:`decimated_sigma`; the kernels differ by a few per cent
    of a weight (about 1 % at sigma 4, 3 % at sigma 2: the doubled grid's
    Gaussian linearly interpolated between its even taps), and the
    Gaussian has half the taps, on a quarter of the pixels. ``mode``,
    ``needed`` and the outputs as in :func:`orientation_band`.

    With ``starts`` of shape ``needed.shape`` (not empty; ``TENSOR_DERIVED``), the maps are
    written at the True pixels of ``mask`` only, one after the other in
    row-major order: the outputs are single rows, and the pixels of row y
    in tile k begin at index ``starts[y, k]`` (see :func:`mask_starts`).
    """
    height, width = _plane_shape(planes)
    radius = weights.shape[0] - 1
    ring_rows = 2 * radius + 1
    # rows before 0 read doubled rows before 0 only, whose products are alike, as rows after
    # ``height``: one slot each
    top_slot = ring_rows
    bottom_slot = ring_rows + 1
    pad = radius + 2
    quarter = np.float32(0.0625)  # (1/4) * (1/4): the two 1-2-1 filters' norms
    two = np.float32(2.0)
    count = needed.shape[1]
    for tile_index in range(count):
        x0 = (tile_index * width) // count
        x1 = ((tile_index + 1) * width) // count
        tile = x1 - x0
        origin = x0 - pad  # phase column of local index 0
        n = tile + 2 * pad
        scratch = np.zeros((_SCRATCH_ROWS, n + 2), dtype=np.float32)
        tones = np.empty((4, n + 2))
        kept = np.empty(10, dtype=np.int64)
        for slot in range(10):
            kept[slot] = -1
        # a row of the products filtered 1-2-1 along both axes, and its last doubled row's part
        filtered = np.zeros((2, 3, n), dtype=np.float32)
        sampled = filtered[0]
        below = filtered[1]
        below_row = np.int64(-3)  # the doubled row whose part ``below`` holds
        ring = np.zeros((3, ring_rows + 2, tile), dtype=np.float32)
        tensor = np.empty((3, tile), dtype=np.float32)
        # :func:`_gauss`'s taps: down the ring, along a filtered row (output column x0 + i is
        # local index pad + i)
        taps = np.empty((2, 4, radius + 1), dtype=np.int64)
        for j in range(radius + 1):
            taps[0, 2, j] = 0
            taps[0, 3, j] = 0
            taps[1, 0, j] = 0
            taps[1, 1, j] = 0
            taps[1, 2, j] = pad - j
            taps[1, 3, j] = pad + j
        next_row = max(0, y0 - radius)
        # y0 - 2 and y0 - 1 stand for the rows before 0 and after ``height`` (made first where
        # this band reads them), then the rows of the band
        for y in range(y0 - 2, y1):
            if y >= y0 and not needed[y, tile_index]:
                continue
            if y == y0 - 2:
                first = -1
                last = -1 if y0 - radius < 0 else -2
            elif y == y0 - 1:
                first = height + 1
                last = height + 1 if y1 - 1 + radius > height else height
            else:
                first = max(next_row, y - radius)
                # row ``height`` reads doubled row 2 height - 1 of the plane, and two after it
                last = min(y + radius, height)
            for row in range(first, last + 1):
                # a row of the plane sums its doubled rows 2 row - 1, 2 row, 2 row + 1 with
                # weights 1, 2, 1, the first kept in ``below`` when it was the last row's
                # last; a row outside it one doubled row with the weights' sum
                inside = row >= 0 and row <= height
                for t in range(3 if inside else 1):
                    doubled = 2 * row - 1 + t
                    weight = quarter + quarter if t == 1 else quarter
                    if not inside:
                        doubled = -1 if row < 0 else 2 * height
                        weight = np.float32(4.0) * quarter
                    target = below if t == 2 else sampled
                    if t == 0 and inside and below_row == doubled:
                        for c in range(3):
                            for k in range(n):
                                sampled[c, k] = below[c, k]
                        continue
                    if t != 1:
                        for c in range(3):
                            for k in range(n):
                                target[c, k] = 0.0
                    _doubled_products(planes, scale, doubled, origin, scratch, tones, kept)
                    for c in range(3):  # the 1-2-1 filter across columns, at the even ones
                        even = scratch[_PRODUCTS_E + c]
                        odd = scratch[_PRODUCTS_O + c]
                        part = target[c]
                        for k in range(1, n):
                            part[k] += weight * ((odd[k - 1] + odd[k]) + two * even[k])
                slot = top_slot if row < 0 else bottom_slot
                if inside:
                    for c in range(3):
                        for k in range(n):
                            sampled[c, k] += below[c, k]
                    below_row = 2 * row + 1
                    slot = row % ring_rows
                    next_row = row + 1
                for c in range(3):
                    _gauss(sampled[c : c + 1], taps[1], weights, ring[c, slot])
            if y < y0:
                continue
            for j in range(radius + 1):
                r = y - j
                taps[0, 0, j] = r % ring_rows if r >= 0 else top_slot
                r = y + j
                taps[0, 1, j] = r % ring_rows if r <= height else bottom_slot
            for c in range(3):
                _gauss(ring[c], taps[0], weights, tensor[c])
            if mode == TENSOR_COMPONENTS:
                for x in range(tile):
                    out0[y, x0 + x] = tensor[0, x]
                    out1[y, x0 + x] = tensor[1, x]
                    out2[y, x0 + x] = tensor[2, x]
                continue
            # the derived maps, of the whole row or (``starts``) of the mask's pixels only,
            # their components gathered first (one after the other; count <= x: a component
            # is read before it is overwritten)
            start = 0
            end = tile
            if starts.shape[0] > 0:
                end = 0
                for x in range(tile):
                    if mask[y, x0 + x]:
                        for c in range(3):
                            tensor[c, end] = tensor[c, x]
                        end += 1
                start = starts[y, tile_index]
                end += start
            rows = y if starts.shape[0] == 0 else 0
            columns = x0 if starts.shape[0] == 0 else start
            _derive(
                tensor[0, : end - start],
                tensor[1, : end - start],
                tensor[2, : end - start],
                out0[rows, columns : columns + end - start],
                out1[rows, columns : columns + end - start],
                out2[rows, columns : columns + end - start],
                out3[rows, columns : columns + end - start],
            )


def tensor_tiles(width: int, radius: int) -> int:
    """Column tiles of :func:`orientation_band` when only some pixels are asked for.

    Narrow tiles skip more rows without a pixel asked for, but their short
    loops cost more per pixel: tiles hold a ring of smoothed rows of
    ``TENSOR_RING_BYTES`` and are at least ``TENSOR_MIN_TILE`` columns wide.
    """
    tile = max(TENSOR_MIN_TILE, TENSOR_RING_BYTES // (3 * (2 * radius + 2) * 4))
    return max(1, (width + tile - 1) // tile)


@cached_njit(nogil=True, error_model="numpy", no_cfunc_wrapper=True)
def mask_counts(mask, counts, y0, y1):
    """``counts[y, k]`` = the True pixels of ``mask`` in row y of column tile k (see
    :func:`orientation_band`), for rows ``[y0, y1)``."""
    width = mask.shape[1]
    count = counts.shape[1]
    for y in range(y0, y1):
        row = mask[y]
        for k in range(count):
            total = 0
            for x in range((k * width) // count, ((k + 1) * width) // count):
                total += row[x]
            counts[y, k] = total


def mask_starts(counts: np.ndarray) -> np.ndarray:
    """Where the pixels of each row of each tile begin when a mask's pixels are written one
    after the other in row-major order (``counts`` from :func:`mask_counts`)."""
    ends = np.cumsum(counts.ravel()).reshape(counts.shape)
    return ends - counts


# --- reductions --------------------------------------------------------------------------


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
