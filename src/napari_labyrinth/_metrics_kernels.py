"""numba kernels behind :mod:`napari_labyrinth.metrics`.

Every kernel works on a band of output rows ``[y0, y1)`` of a 2-D plane, so
that the caller can share a plane's rows between threads; every kernel
releases the GIL and allocates its own buffers (no shared mutable state).
Sums are made row by row (the caller adds the rows' sums), so that results
do not depend on the bands. A plane may be float64, uint8 or uint16: each
value enters the arithmetic through an exact float64 operation (or a sum of
two values in 64-bit integers), so the results do not depend on which.

Precision, chosen by what each result feeds:

- The fine-scale component, the local energy and the local mean are
  float64 and follow ``scipy.ndimage.gaussian_filter`` operation for
  operation (the same 1-D passes, axis 0 then axis 1, the same ``reflect``
  extension, the same order of the taps: centre first, then the outermost
  pair down to the nearest): they are scipy's floats, bit for bit.
- The 12 lag correlations behind the wall map are smoothed in float32 with
  a bound on their error; the few pixels whose wall decision the bound
  leaves open are recomputed in float64 in scipy's order
  (:func:`smooth_band`). The wall map is the float64 one.
- The structure tensors (orientations) are float32: they only feed weighted
  means, where float32 rounding moves the result by about 1e-8. The walls'
  and the contours' tensors are decimated (:func:`decimated_tensor_band`):
  the doubled grid's products filtered 1-2-1 and smoothed on the original
  grid, a window within a few per cent of the doubled grid's Gaussian at a
  quarter of its pixels; :func:`orientation_band` is the doubled grid's.
"""

from __future__ import annotations

import numpy as np

from .core._jit import cached_njit

#: Lattice directions as families of lags: family f holds the lags k * u_f, k = 1, 2, 4.
FAMILIES = ((0, 1), (1, 0), (1, 1), (1, -1))
#: The family of the normal of each direction: (0, 1) <-> (1, 0), (1, 1) <-> (1, -1).
NORMAL_FAMILY = np.array([1, 0, 3, 2], dtype=np.int64)
#: Smoothed maps of the wall pass: map 0 is the energy h**2, map 1 + 3 f + q the
#: symmetric lag product of h at lag k_q * u_f (k = 1, 2, 4).
LAG_DY = np.array([0] + [k * dy for dy, _ in FAMILIES for k in (1, 2, 4)], dtype=np.int64)
LAG_DX = np.array([0] + [k * dx for _, dx in FAMILIES for k in (1, 2, 4)], dtype=np.int64)

#: What :func:`smooth_band` computes.
MODE_WALLS = 0  # energy and the 12 lag correlations -> energy map and wall map
MODE_ENERGY = 1  # energy map only
MODE_LOCAL_MEAN = 2  # the plane's Gaussian mean -> plane > mean

#: Blocks of :func:`smooth_band`: a map's ring buffer stays in L1, a block's values in L2.
X_TILE = 512
Y_BLOCK = 128
#: Rows of a block of the 12 float32 lag maps (they then fit in L2 together).
LAG_BLOCK = 64


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


@cached_njit(nogil=True)
def _sum(values):
    """Sum of a line: eight interleaved partial sums (independent chains), then those."""
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


@cached_njit(nogil=True)
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


@cached_njit(nogil=True)
def _any_above(values, threshold):
    for x in range(values.shape[0]):
        if values[x] > threshold:
            return True
    return False


@cached_njit(nogil=True)
def _reflect(i, n):
    """Index of virtual position ``i`` of a line of ``n`` under scipy's ``reflect``."""
    period = 2 * n
    i = i % period
    if i >= n:
        i = period - 1 - i
    return i


@cached_njit(nogil=True)
def _scale(out, centre, w0):
    for i in range(out.shape[0]):
        out[i] = centre[i] * w0


@cached_njit(nogil=True)
def _add_taps4(out, a1, b1, w1, a2, b2, w2, a3, b3, w3, a4, b4, w4):
    """``out += (a1 + b1) w1``, then ``+= (a2 + b2) w2`` ... in this order, elementwise."""
    for i in range(out.shape[0]):
        value = out[i]
        value += (a1[i] + b1[i]) * w1
        value += (a2[i] + b2[i]) * w2
        value += (a3[i] + b3[i]) * w3
        value += (a4[i] + b4[i]) * w4
        out[i] = value


@cached_njit(nogil=True)
def _add_tap(out, a, b, w):
    for i in range(out.shape[0]):
        out[i] += (a[i] + b[i]) * w


@cached_njit(nogil=True)
def _gauss_rows(rows, lower, upper, centre, weights, out):
    """``out = rows[centre] w0``, then ``+= (rows[lower[j]] + rows[upper[j]]) w[j]``, j = r .. 1.

    scipy's order of operations for a symmetric kernel; four taps per sweep
    over ``out`` (same order, fewer loads and stores).
    """
    radius = weights.shape[0] - 1
    _scale(out, rows[centre], weights[0])
    j = radius
    while j >= 4:
        _add_taps4(
            out,
            rows[lower[j]],
            rows[upper[j]],
            weights[j],
            rows[lower[j - 1]],
            rows[upper[j - 1]],
            weights[j - 1],
            rows[lower[j - 2]],
            rows[upper[j - 2]],
            weights[j - 2],
            rows[lower[j - 3]],
            rows[upper[j - 3]],
            weights[j - 3],
        )
        j -= 4
    while j >= 1:
        _add_tap(out, rows[lower[j]], rows[upper[j]], weights[j])
        j -= 1


@cached_njit(nogil=True)
def _gauss_line(ext, radius, weights, out):
    """``out[i]`` = Gaussian of the extended line ``ext`` at ``ext[radius + i]``, scipy's order."""
    n = out.shape[0]
    _scale(out, ext[radius : radius + n], weights[0])
    j = radius
    while j >= 4:
        _add_taps4(
            out,
            ext[radius - j : radius - j + n],
            ext[radius + j : radius + j + n],
            weights[j],
            ext[radius - j + 1 : radius - j + 1 + n],
            ext[radius + j - 1 : radius + j - 1 + n],
            weights[j - 1],
            ext[radius - j + 2 : radius - j + 2 + n],
            ext[radius + j - 2 : radius + j - 2 + n],
            weights[j - 2],
            ext[radius - j + 3 : radius - j + 3 + n],
            ext[radius + j - 3 : radius + j - 3 + n],
            weights[j - 3],
        )
        j -= 4
    while j >= 1:
        _add_tap(
            out, ext[radius - j : radius - j + n], ext[radius + j : radius + j + n], weights[j]
        )
        j -= 1


@cached_njit(nogil=True)
def _extend(line, radius, ext):
    """``ext`` = ``line`` with ``radius`` values on each side under scipy's ``reflect``."""
    n = line.shape[0]
    for i in range(n):
        ext[radius + i] = line[i]
    for i in range(radius):
        ext[i] = line[_reflect(i - radius, n)]
        ext[radius + n + i] = line[_reflect(n + i, n)]


@cached_njit(nogil=True)
def fine_scale_band(plane, weights, fine, fine32, sums, y0, y1):
    """``fine = plane - G * plane`` on rows ``[y0, y1)``, and its float32 copy ``fine32``
    (unless ``fine32`` is a single row: then it is not written).

    ``sums[y]`` gets, over row y: the sum and the largest finite value of
    ``fine**2``, the count of non-finite values of ``fine`` and the largest
    finite ``|plane|``.
    """
    width = plane.shape[1]
    radius = weights.shape[0] - 1
    column = np.empty(width)
    ext = np.empty(width + 2 * radius)
    smooth = np.empty(width)
    lower = np.empty(radius + 1, dtype=np.int64)
    upper = np.empty(radius + 1, dtype=np.int64)
    copy32 = fine32.shape[0] == fine.shape[0]
    for y in range(y0, y1):
        for j in range(radius + 1):
            lower[j] = _reflect(y - j, plane.shape[0])
            upper[j] = _reflect(y + j, plane.shape[0])
        _gauss_rows(plane, lower, upper, y, weights, column)
        _extend(column, radius, ext)
        _gauss_line(ext, radius, weights, smooth)
        row = plane[y]
        out = fine[y]
        if copy32:
            out32 = fine32[y]
            for x in range(width):
                value = row[x] - smooth[x]
                out[x] = value
                out32[x] = value
        else:
            for x in range(width):
                out[x] = row[x] - smooth[x]
        for x in range(width):
            smooth[x] = out[x] * out[x]
        sums[y, 0] = _sum(smooth)
        _, largest, nonfinite = _finite_range(smooth)
        sums[y, 1] = max(largest, 0.0)
        sums[y, 2] = nonfinite
        for x in range(width):
            smooth[x] = abs(row[x])
        sums[y, 3] = max(_finite_range(smooth)[1], 0.0)


@cached_njit(nogil=True)
def _fine_row(plane, weights, y, lower, upper, column, ext, smooth, out):
    """Row y of ``h = plane - G * plane`` into ``out``, as :func:`fine_scale_band` computes it."""
    height, width = plane.shape
    radius = weights.shape[0] - 1
    for j in range(radius + 1):
        lower[j] = _reflect(y - j, height)
        upper[j] = _reflect(y + j, height)
    _gauss_rows(plane, lower, upper, y, weights, column)
    _extend(column, radius, ext)
    _gauss_line(ext, radius, weights, smooth)
    row = plane[y]
    for x in range(width):
        out[x] = row[x] - smooth[x]


@cached_njit(nogil=True)
def energy_band(plane, fine_weights, weights, energy, edges, sums, y0, y1):
    """The energy ``G * h**2`` of rows ``[y0, y1)`` without keeping ``h``, and the Sobel
    magnitude ``edges`` (:func:`sobel_band`): an original's maps in one pass.

    ``h`` is made row by row (:func:`fine_scale_band`'s operations) into a
    ring of ``h**2`` rows that the Gaussian of ``weights`` reads (scipy's
    order, ``reflect``, as :func:`smooth_band`): the same floats as
    ``fine_scale_band`` then ``smooth_band``'s ``MODE_ENERGY``. ``sums[y]``
    gets :func:`fine_scale_band`'s four sums of row y, the sum of
    ``energy[y]``, then :func:`sobel_band`'s three sums of ``edges[y]``.
    """
    height, width = plane.shape
    fine_radius = fine_weights.shape[0] - 1
    radius = weights.shape[0] - 1
    ring_rows = 2 * radius + 1
    squares = np.empty((ring_rows, width))
    virtual_row = np.full(ring_rows, -(2 * height + ring_rows), dtype=np.int64)
    column = np.empty(width)
    fine_ext = np.empty(width + 2 * fine_radius)
    smooth = np.empty(width)
    fine = np.empty(width)
    ext = np.empty(width + 2 * radius)
    lower = np.empty(max(radius, fine_radius) + 1, dtype=np.int64)
    upper = np.empty(max(radius, fine_radius) + 1, dtype=np.int64)
    padded = np.empty((3, width + 2))
    for y in range(y0, y1):
        _sobel_row(plane, y, padded, column, smooth, edges[y], sums[y, 5:])
        for v in range(y - radius, y + radius + 1):  # the rows the window reads, reflected
            slot = v % ring_rows
            if virtual_row[slot] == v:
                continue
            row = _reflect(v, height)
            _fine_row(plane, fine_weights, row, lower, upper, column, fine_ext, smooth, fine)
            square = squares[slot]
            for x in range(width):
                square[x] = fine[x] * fine[x]
            virtual_row[slot] = v
            if v == row and y0 <= row < y1:
                sums[row, 0] = _sum(square)
                _, largest, nonfinite = _finite_range(square)
                sums[row, 1] = max(largest, 0.0)
                sums[row, 2] = nonfinite
                tones = plane[row]
                for x in range(width):
                    smooth[x] = abs(tones[x])
                sums[row, 3] = max(_finite_range(smooth)[1], 0.0)
        for j in range(radius + 1):
            lower[j] = (y - j) % ring_rows
            upper[j] = (y + j) % ring_rows
        _gauss_rows(squares, lower, upper, y % ring_rows, weights, column)
        _extend(column, radius, ext)
        _gauss_line(ext, radius, weights, energy[y])
        sums[y, 4] = _sum(energy[y])


@cached_njit(nogil=True)
def _source_row(fine, plane, mode, dy, dx, half, row, s0, s1, out):
    """Row ``row``, columns ``[s0, s1)``, of the map that the wall pass smooths.

    ``mode`` MODE_LOCAL_MEAN: the plane itself; ``dy == dx == 0``: ``h**2``;
    otherwise ``half * (h(p) h(p + d) + h(p - d) h(p))`` (``half`` = 1/2 in
    the arrays' precision) with the lags
    wrapping around the plane (``np.roll``), as the reference computes it.
    """
    height, width = fine.shape
    if mode == MODE_LOCAL_MEAN:
        source = plane[row, s0:s1]
        for i in range(s1 - s0):
            out[i] = source[i]
        return
    centre = fine[row]
    if dy == 0 and dx == 0:
        source = centre[s0:s1]
        for i in range(s1 - s0):
            out[i] = source[i] * source[i]
        return
    ahead = fine[(row + dy) % height]
    behind = fine[(row - dy) % height]
    reach = abs(dx)
    e1 = min(max(reach, s0), s1)
    e2 = max(min(width - reach, s1), e1)
    for x in range(s0, e1):
        out[x - s0] = half * (
            centre[x] * ahead[(x + dx) % width] + behind[(x - dx) % width] * centre[x]
        )
    if e2 > e1:
        middle = centre[e1:e2]
        ahead_middle = ahead[e1 + dx : e2 + dx]
        behind_middle = behind[e1 - dx : e2 - dx]
        out_middle = out[e1 - s0 : e2 - s0]
        for i in range(e2 - e1):
            out_middle[i] = half * (middle[i] * ahead_middle[i] + behind_middle[i] * middle[i])
    for x in range(e2, s1):
        out[x - s0] = half * (
            centre[x] * ahead[(x + dx) % width] + behind[(x - dx) % width] * centre[x]
        )


@cached_njit(nogil=True)
def _smooth_block(
    fine, plane, mode, dy, dx, half, weights, b0, b1, x0, x1, ring, column, ext, result, needed
):
    """``result[y - b0, x - x0]`` = Gaussian of one source map on rows ``[b0, b1)``, columns ``[x0, x1)``.

    The source rows (:func:`_source_row`) go through a ring buffer of
    ``2 r + 1`` rows; axis 0 first, then axis 1, ``reflect`` on both. Rows y
    with ``needed[y - b0]`` False are left as they were.
    """
    height, width = fine.shape
    radius = weights.shape[0] - 1
    ring_rows = 2 * radius + 1
    tile = x1 - x0
    s0 = max(0, x0 - radius)
    s1 = min(width, x1 + radius)
    span = s1 - s0
    interior = x0 - radius >= 0 and x1 + radius <= width
    rows = ring  # whole rows: a column slice would lose numba's C layout (and SIMD)
    col = column[:span]
    lower = np.empty(radius + 1, dtype=np.int64)
    upper = np.empty(radius + 1, dtype=np.int64)
    for v in range(b0 - radius, b0 + radius):
        _source_row(
            fine, plane, mode, dy, dx, half, _reflect(v, height), s0, s1, rows[v % ring_rows]
        )
    for y in range(b0, b1):
        v = y + radius
        _source_row(
            fine, plane, mode, dy, dx, half, _reflect(v, height), s0, s1, rows[v % ring_rows]
        )
        if not needed[y - b0]:
            continue
        for j in range(radius + 1):
            lower[j] = (y - j) % ring_rows
            upper[j] = (y + j) % ring_rows
        _gauss_rows(rows, lower, upper, y % ring_rows, weights, col)
        out = result[y - b0, :tile]
        if interior:
            _gauss_line(col, radius, weights, out)
        else:
            for k in range(tile + 2 * radius):
                x = x0 - radius + k
                if x < 0 or x >= width:
                    x = _reflect(x, width)
                ext[k] = col[x - s0]
            _gauss_line(ext[: tile + 2 * radius], radius, weights, out)


@cached_njit(nogil=True)
def local_mean_band(plane, weights, where, flags, y0, y1):
    """``flags = plane > G * plane`` (scipy's Gaussian of ``weights``, ``reflect``: its
    floats) on rows ``[y0, y1)``, at the True pixels of ``where``; False on the others.

    Axis 0 first (a ring of rows, as :func:`_smooth_block`), on the rows of
    the wall pass's column tiles (``X_TILE``) that hold a True pixel of
    ``where``; then axis 1 at those pixels only (:func:`_gauss_at_pixel`,
    the same operations in the same order as :func:`_gauss_line`).
    """
    height, width = plane.shape
    radius = weights.shape[0] - 1
    ring_rows = 2 * radius + 1
    span = X_TILE + 2 * radius
    ring = np.empty((ring_rows, span))
    column = np.empty(span)
    ext = np.empty(span)
    needed = np.empty(Y_BLOCK, dtype=np.bool_)
    lower = np.empty(radius + 1, dtype=np.int64)
    upper = np.empty(radius + 1, dtype=np.int64)
    no_lag = LAG_DY[0]  # not a compile-time constant (see smooth_band)
    mode = no_lag + MODE_LOCAL_MEAN
    for x0 in range(0, width, X_TILE):
        x1 = min(width, x0 + X_TILE)
        tile = x1 - x0
        s0 = max(0, x0 - radius)
        s1 = min(width, x1 + radius)
        interior = x0 - radius >= 0 and x1 + radius <= width
        col = column[: s1 - s0]
        for b0 in range(y0, y1, Y_BLOCK):
            b1 = min(y1, b0 + Y_BLOCK)
            any_row = False
            for y in range(b0, b1):
                needed[y - b0] = _any_above(where[y, x0:x1], False)
                any_row = any_row or needed[y - b0]
            flags[b0:b1, x0:x1] = False
            if not any_row:
                continue
            for v in range(b0 - radius, b0 + radius):
                _source_row(
                    plane, plane, mode, no_lag, no_lag, 0.5, _reflect(v, height), s0, s1,
                    ring[v % ring_rows],
                )  # fmt: skip
            for y in range(b0, b1):
                v = y + radius
                _source_row(
                    plane, plane, mode, no_lag, no_lag, 0.5, _reflect(v, height), s0, s1,
                    ring[v % ring_rows],
                )  # fmt: skip
                if not needed[y - b0]:
                    continue
                for j in range(radius + 1):
                    lower[j] = (y - j) % ring_rows
                    upper[j] = (y + j) % ring_rows
                _gauss_rows(ring, lower, upper, y % ring_rows, weights, col)
                line = col
                if not interior:
                    for k in range(tile + 2 * radius):
                        x = x0 - radius + k
                        if x < 0 or x >= width:
                            x = _reflect(x, width)
                        ext[k] = col[x - s0]
                    line = ext
                walls = where[y, x0:x1]
                source = plane[y, x0:x1]
                out = flags[y, x0:x1]
                for i in range(tile):
                    if walls[i]:
                        out[i] = source[i] > _gauss_at_pixel(line, i, weights)


@cached_njit(nogil=True)
def _gauss_at_pixel(line, i, weights):
    """:func:`_gauss_line`'s output ``i``: ``line[r + i] w0``, then ``+= (line[r + i - j] +
    line[r + i + j]) w[j]`` for j = r .. 1, in this order (the same float)."""
    radius = weights.shape[0] - 1
    centre = radius + i
    value = line[centre] * weights[0]
    for j in range(radius, 0, -1):
        value += (line[centre - j] + line[centre + j]) * weights[j]
    return value


#: Bound on the float32 error of a smoothed lag product, in units of ``G * |product|``:
#: the products and both 1-D passes accumulate about 28 roundings of 2**-24; twice that.
FLOAT32_ERROR = 64 * 2.0**-24
#: Pixels this close to an edge get a bound that holds there too (lags wrap, windows reflect).
EDGE = 12


@cached_njit(nogil=True, error_model="numpy")
def smooth_band(
    fine,
    fine32,
    mode,
    weights,
    weights32,
    energy_floor2,
    along_threshold,
    alternation_threshold,
    largest_square,
    lag_scale,
    energy,
    flags,
    sums,
    y0,
    y1,
):
    """The wall pass (or one of its parts) on rows ``[y0, y1)``.

    ``MODE_WALLS``: ``energy = G * h**2`` and ``flags`` = the wall map;
    ``MODE_ENERGY``: ``energy`` only (:func:`local_mean_band` makes ``MODE_LOCAL_MEAN``'s).
    Returns the count of True flags and the number of pixels whose wall
    decision was recomputed exactly; ``sums[y, 0]`` gets the sum of ``energy[y]``.

    The energy and the local mean are scipy's Gaussian (``reflect``, axis 0
    then axis 1, the same operations in the same order: the same floats).
    The 12 lag products are smoothed in float32 from ``fine32`` (``h`` times
    a power of two whose square is ``1 / lag_scale``, to keep float32 away
    from overflow); their
    correlations ``C = S / E`` decide the wall map wherever they are
    farther from the thresholds than the float32 error can reach, a bound
    ``FLOAT32_ERROR * B / E`` with ``B >= G * |product|`` (:func:`_margins`); the other
    pixels are recomputed exactly in float64 (:func:`_exact_smoothed`), as
    the reference computes them. The wall map is therefore the reference's.

    ``|h(p) h(p + d) + h(p - d) h(p)| / 2 <= h(p)**2 / 2 + h(p + d)**2 / 4 + h(p - d)**2 / 4``,
    so ``G * |product| <= E(p) / 2 + E(p + d) / 4 + E(p - d) / 4`` away from
    the edges (``EDGE`` pixels: there the shifted window is the window at
    p + d), and ``<= E(p) / 2 + max(h**2) / 2`` everywhere.
    """
    height, width = fine.shape
    radius = weights.shape[0] - 1
    span = X_TILE + 2 * radius
    ring = np.empty((2 * radius + 1, span))
    column = np.empty(span)
    ext = np.empty(span)
    result = np.empty((Y_BLOCK, X_TILE))
    every_row = np.ones(Y_BLOCK, dtype=np.bool_)
    # integers that are not compile-time constants: a constant argument would make numba
    # compile a helper once more for it
    no_lag = LAG_DY[0]
    energy_mode = mode - mode + MODE_ENERGY
    count = 0
    exact = 0
    half = 0.5
    # the energy of the band, and (for the bound) of the 4 rows on each side (the longest
    # lag), which belong to the neighbouring bands: in ``halo`` (rows e0 + k and y1 + k)
    reach = 4
    e0 = max(0, y0 - reach) if mode == MODE_WALLS else y0
    e1 = min(height, y1 + reach) if mode == MODE_WALLS else y1
    halo = np.empty((2 * reach, width))
    for x0 in range(0, width, X_TILE):
        x1 = min(width, x0 + X_TILE)
        for b0 in range(e0, e1, Y_BLOCK):
            b1 = min(e1, b0 + Y_BLOCK)
            _smooth_block(
                fine,
                fine,  # the plane: not read in these modes
                energy_mode,
                no_lag,
                no_lag,
                half,
                weights,
                b0,
                b1,
                x0,
                x1,
                ring,
                column,
                ext,
                result,
                every_row,
            )
            for y in range(b0, b1):
                row = _energy_row(energy, halo, e0, y0, y1, y)
                row[x0:x1] = result[y - b0, : x1 - x0]
    for y in range(y0, y1):
        sums[y, 0] = _sum(energy[y])
    if mode == MODE_ENERGY:
        return count, exact
    ring32 = np.empty((2 * radius + 1, span), dtype=np.float32)
    column32 = np.empty(span, dtype=np.float32)
    ext32 = np.empty(span, dtype=np.float32)
    lags = np.empty((13, LAG_BLOCK, X_TILE), dtype=np.float32)
    textured = np.empty(LAG_BLOCK, dtype=np.bool_)
    needed = np.empty(LAG_BLOCK, dtype=np.bool_)
    inverse = np.empty((LAG_BLOCK, X_TILE))
    margins = np.empty((LAG_BLOCK, X_TILE))
    half32 = np.float32(0.5)
    for x0 in range(0, width, X_TILE):
        x1 = min(width, x0 + X_TILE)
        tile = x1 - x0
        for b0 in range(y0, y1, LAG_BLOCK):
            b1 = min(y1, b0 + LAG_BLOCK)
            # rows of the tile with no pixel above the energy floor have no wall: skipped
            any_textured = False
            for y in range(b0, b1):
                textured[y - b0] = _any_above(energy[y, x0:x1], energy_floor2)
                any_textured = any_textured or textured[y - b0]
            if not any_textured:
                flags[b0:b1, x0:x1] = False
                continue
            _margins(energy, halo, e0, y0, y1, b0, b1, x0, x1, largest_square, inverse, margins)
            # the lag maps in the order the decision reads them, each on the rows where some
            # pixel's decision reads it (see _needed_rows): the lag-1 maps, then lag 2, lag 4
            for step in range(3):
                for family in range(4):
                    m = 1 + 3 * family + step
                    if step == 0:
                        needed[:] = textured
                    elif not _needed_rows(
                        lags,
                        energy,
                        inverse,
                        margins,
                        b0,
                        b1,
                        x0,
                        x1,
                        family,
                        step,
                        energy_floor2,
                        lag_scale,
                        along_threshold,
                        alternation_threshold,
                        needed,
                    ):
                        continue
                    _smooth_block(
                        fine32,
                        fine,  # the plane: not read in this mode
                        mode,
                        LAG_DY[m],
                        LAG_DX[m],
                        half32,
                        weights32,
                        b0,
                        b1,
                        x0,
                        x1,
                        ring32,
                        column32,
                        ext32,
                        lags[m],
                        needed,
                    )
            for y in range(b0, b1):
                row_energy = energy[y, x0:x1]
                row_inverse = inverse[y - b0]
                row_margin = margins[y - b0]
                out = flags[y, x0:x1]
                for i in range(tile):
                    e = row_energy[i]
                    wall = False
                    if e > energy_floor2:
                        decided, wall = _decide(
                            lags,
                            y - b0,
                            i,
                            row_inverse[i] * lag_scale,
                            row_margin[i],
                            along_threshold,
                            alternation_threshold,
                        )
                        if not decided:
                            wall = _exact_wall(
                                fine, weights, y, x0 + i, e, along_threshold, alternation_threshold
                            )
                            exact += 1
                    out[i] = wall
                    count += wall
    return count, exact


@cached_njit(nogil=True, error_model="numpy")
def _needed_rows(
    lags,
    energy,
    inverse,
    margins,
    b0,
    b1,
    x0,
    x1,
    family,
    step,
    energy_floor2,
    lag_scale,
    along,
    alternation,
    needed,
):
    """Rows of a block where :func:`_decide` reads the lag map of ``family`` at lag ``2**step``.

    That map (lag ``2 u_g`` or ``4 u_g``, g = ``family``) is read only for
    the direction f whose normal is g, at pixels above the energy floor
    where ``C(u_f) > along`` is not ruled out; lag ``4 u_g`` only where, in
    addition, the first alternation (lags ``u_g``, ``2 u_g``) is not settled
    true and ``C(2 u_g) < -alternation`` is not ruled out. The maps these
    tests read are those of smaller lags, already smoothed on these rows.
    Sets ``needed[y - b0]`` and returns whether any row is needed.
    """
    direction = NORMAL_FAMILY[family]
    along_map = 1 + 3 * direction
    n = 1 + 3 * family
    any_row = False
    for y in range(b0, b1):
        row = y - b0
        row_energy = energy[y, x0:x1]
        found = False
        for i in range(x1 - x0):
            if not row_energy[i] > energy_floor2:
                continue
            scale = inverse[row, i] * lag_scale
            margin = margins[row, i]
            if _compare(lags[along_map, row, i] * scale, along, margin) == 0:
                continue
            if step == 1:
                found = True
                break
            first = _compare(lags[n, row, i] * scale, -alternation, margin)
            c2 = lags[n + 1, row, i] * scale
            if first != 0:
                first = _and(first, _compare(c2, alternation, margin))
            if first != 1 and _compare(c2, -alternation, margin) != 0:
                found = True
                break
        needed[row] = found
        any_row = any_row or found
    return any_row


@cached_njit(nogil=True)
def _compare(c, threshold, margin):
    """Whether ``C > threshold``: 0 (no), 1 (yes), or 2 when ``C``'s error bound leaves it open.

    A negative ``threshold`` -t asks whether ``C < -t`` instead.
    """
    if not abs(c - threshold) > margin:  # NaN included
        return 2
    if threshold < 0:
        return 1 if c < threshold else 0
    return 1 if c > threshold else 0


@cached_njit(nogil=True, error_model="numpy")
def _energy_row(energy, halo, e0, y0, y1, y):
    """Row y of the energy: the band's own rows ``[y0, y1)`` or the halo's."""
    if y < y0:
        return halo[y - e0]
    if y >= y1:
        return halo[halo.shape[0] // 2 + y - y1]
    return energy[y]


@cached_njit(nogil=True, inline="always")
def _larger(a, b):
    """``max(a, b)`` (``a`` if ``b`` is NaN), in a form the compiler turns into SIMD."""
    return b if b > a else a


@cached_njit(nogil=True, inline="always")
def _larger_or_nan(a, b):
    """``max(a, b)``, NaN if either is NaN, in a form the compiler turns into SIMD."""
    return b if (b > a or b != b) else a


#: Rows and columns of the groups of pixels that share one bound in :func:`_margins`.
MARGIN_GROUP = 4


@cached_njit(nogil=True, error_model="numpy")
def _margins(energy, halo, e0, y0, y1, b0, b1, x0, x1, largest_square, inverse, margins):
    """``1 / E`` and the float32 error bound of the correlations, for a block.

    ``G * |product| <= E(p) / 2 + max(E(p + d), E(p - d)) / 2`` away from the
    edges, bounded over every lag (|dy|, |dx| <= 4) by the largest energy
    around p; ``<= E(p) / 2 + max(h**2) / 2`` everywhere. Pixels share that
    largest energy by groups of ``MARGIN_GROUP`` x ``MARGIN_GROUP``: the
    largest over the group grown by 4 on every side (12 x 12 pixels, the
    9 x 9 neighbourhood of each of its pixels and a little more), NaN if
    any is NaN. A looser bound only sends a few more pixels to the exact
    decision: the wall map does not change.
    """
    height, width = energy.shape
    reach = 4
    group = MARGIN_GROUP
    tile = x1 - x0
    lo = max(0, x0 - reach)
    hi = min(width, x1 + reach)
    column_max = np.empty(hi - lo)
    largest = np.empty(tile)
    # inner columns of the tile: x in [i0 + x0, i1 + x0), their 9 neighbours in [lo, hi)
    i0 = min(max(EDGE - x0, 0), tile)
    i1 = max(min(width - EDGE - x0, tile), i0)
    for g0 in range(b0, b1, group):
        g1 = min(b1, g0 + group)
        for i in range(tile):
            largest[i] = largest_square
        if g0 - reach >= EDGE and g1 + reach <= height - EDGE and i1 > i0:
            first = _energy_row(energy, halo, e0, y0, y1, g0 - reach)[lo:hi]
            for k in range(hi - lo):
                column_max[k] = first[k]
            for r in range(g0 - reach + 1, g1 + reach):
                other = _energy_row(energy, halo, e0, y0, y1, r)[lo:hi]
                for k in range(hi - lo):
                    column_max[k] = _larger_or_nan(column_max[k], other[k])
            for c0 in range(i0, i1, group):
                c1 = min(i1, c0 + group)
                # columns x0 + c0 - 4 .. x0 + c1 + 3, as indices of column_max
                start = x0 + c0 - reach - lo
                value = column_max[start]
                for k in range(start + 1, x0 + c1 + reach - lo):
                    value = _larger_or_nan(value, column_max[k])
                for i in range(c0, c1):
                    largest[i] = value
        for y in range(g0, g1):
            row_inverse = inverse[y - b0]
            row_margin = margins[y - b0]
            energy_row = energy[y, x0:x1]
            inner = y >= EDGE and y < height - EDGE
            for i in range(tile):
                row_inverse[i] = 1.0 / energy_row[i]
                bound = largest[i] if inner else largest_square
                row_margin[i] = FLOAT32_ERROR * (0.5 + 0.5 * bound * row_inverse[i]) + 1e-12


@cached_njit(nogil=True)
def _and(a, b):
    if a == 0 or b == 0:
        return 0
    if a == 2 or b == 2:
        return 2
    return 1


@cached_njit(nogil=True)
def _or(a, b):
    if a == 1 or b == 1:
        return 1
    if a == 2 or b == 2:
        return 2
    return 0


@cached_njit(nogil=True)
def _decide(lags, row, i, inverse, margin, along, alternation):
    """``(decided, wall)``: the wall decision at a pixel from the float32 maps, if they settle it.

    A wall: for a direction f with normal g, C(u_f) > along and
    (C(u_g) < -alt and C(2 u_g) > alt, or C(2 u_g) < -alt and C(4 u_g) > alt).
    Comparisons are made only as far as the decision needs them.
    """
    wall = 0
    for direction in range(4):
        m = 1 + 3 * direction
        along_ = _compare(lags[m, row, i] * inverse, along, margin)
        if along_ == 0:
            continue
        n = 1 + 3 * NORMAL_FAMILY[direction]
        c1 = lags[n, row, i] * inverse
        c2 = lags[n + 1, row, i] * inverse
        first = _compare(c1, -alternation, margin)
        if first != 0:
            first = _and(first, _compare(c2, alternation, margin))
        alternates = first
        if alternates != 1:
            second = _compare(c2, -alternation, margin)
            if second != 0:
                second = _and(second, _compare(lags[n + 2, row, i] * inverse, alternation, margin))
            alternates = _or(alternates, second)
        wall = _or(wall, _and(along_, alternates))
        if wall == 1:
            return True, True
    if wall == 2:
        return False, False
    return True, False


@cached_njit(nogil=True)
def _product(fine, row, column, dy, dx):
    """``0.5 * (h(p) h(p + d) + h(p - d) h(p))``, lags wrapping, as :func:`_source_row`."""
    height, width = fine.shape
    centre = fine[row, column]
    return 0.5 * (
        centre * fine[(row + dy) % height, (column + dx) % width]
        + fine[(row - dy) % height, (column - dx) % width] * centre
    )


@cached_njit(nogil=True)
def _exact_smoothed(fine, weights, y, x, dy, dx):
    """The float64 Gaussian of the lag product at one pixel, as the block pipeline and
    scipy compute it: the same operations in the same order (so the same float)."""
    height, width = fine.shape
    radius = weights.shape[0] - 1
    vertical = np.empty(2 * radius + 1)
    for k in range(-radius, radius + 1):
        column = _reflect(x + k, width)
        value = _product(fine, y, column, dy, dx) * weights[0]
        for j in range(radius, 0, -1):
            above = _product(fine, _reflect(y - j, height), column, dy, dx)
            below = _product(fine, _reflect(y + j, height), column, dy, dx)
            value += (above + below) * weights[j]
        vertical[k + radius] = value
    value = vertical[radius] * weights[0]
    for j in range(radius, 0, -1):
        value += (vertical[radius - j] + vertical[radius + j]) * weights[j]
    return value


@cached_njit(nogil=True)
def _exact_wall(fine, weights, y, x, e, along_threshold, alternation_threshold):
    """The wall decision at one pixel (energy ``e`` above the floor), all in float64."""
    denominator = e if not e < 1e-12 else 1e-12
    for direction in range(4):
        ay, ax = LAG_DY[1 + 3 * direction], LAG_DX[1 + 3 * direction]
        if not _exact_smoothed(fine, weights, y, x, ay, ax) / denominator > along_threshold:
            continue
        n = 1 + 3 * NORMAL_FAMILY[direction]
        c1 = _exact_smoothed(fine, weights, y, x, LAG_DY[n], LAG_DX[n]) / denominator
        c2 = _exact_smoothed(fine, weights, y, x, LAG_DY[n + 1], LAG_DX[n + 1]) / denominator
        if c1 < -alternation_threshold and c2 > alternation_threshold:
            return True
        if c2 < -alternation_threshold:
            c4 = _exact_smoothed(fine, weights, y, x, LAG_DY[n + 2], LAG_DX[n + 2]) / denominator
            if c4 > alternation_threshold:
                return True
    return False


# --- structure tensor of the plane upsampled twice (float32) ---------------------------

#: What :func:`orientation_band` writes.
TENSOR_COMPONENTS = 0  # jrr, jrc, jcc
TENSOR_DERIVED = 1  # strength, coherence * strength, cos(2 angle), sin(2 angle)

#: Bytes of :func:`orientation_band`'s ring of smoothed rows per column tile when only
#: the walls' pixels are asked for: narrow tiles skip more rows without walls.
TENSOR_RING_BYTES = 256 * 1024
#: Least width of those tiles (2048 x 2048 walls of a labyrinth: 4 tiles are fastest).
TENSOR_MIN_TILE = 512


@cached_njit(nogil=True)
def _doubled_row(plane, scale, i, origin, line, even, odd):
    """Row ``i`` of ``zoom(plane, 2, order=1, grid_mode=True, mode="nearest")``, split by parity.

    ``even[k]`` and ``odd[k]`` get the doubled columns 2 X and 2 X + 1 for
    X = ``origin + k``; where X is outside the plane, the doubled row's
    nearest column (the doubled plane extended by its edge values: the
    structure tensor sees no edge at the frame). Doubled pixel 2 k samples
    the plane at k - 1/4 and 2 k + 1 at k + 1/4: weights 1/4 and 3/4,
    clamped at the edges. ``i`` is clamped to the doubled rows as well.
    ``line`` is scratch space as long as ``even``. Values are multiplied by
    ``scale`` (a power of two: exact) to keep float32 products in range.
    """
    height, width = plane.shape
    n = even.shape[0]
    i = min(max(i, 0), 2 * height - 1)
    k = i // 2
    other = k - 1 if i % 2 == 0 else k + 1
    other = min(max(other, 0), height - 1)
    near = plane[k]
    far = plane[other]
    # local index j holds phase column origin + j; the plane's columns are j in [j0, j1)
    j0 = min(max(0, -origin), n)
    j1 = max(min(n, width - origin), j0)
    if j1 == j0:
        even[:] = 0.0  # no column of the plane (never asked for)
        odd[:] = 0.0
        return
    # line[j - j0 + 1] = vertical interpolation at column origin + j, for j in [j0 - 1, j1 + 1), clamped
    lo = origin + j0
    hi = origin + j1
    for x in range(lo, hi):
        line[x - lo + 1] = (0.75 * near[x] + 0.25 * far[x]) * scale
    left = max(lo - 1, 0)
    right = min(hi, width - 1)
    line[0] = (0.75 * near[left] + 0.25 * far[left]) * scale
    line[hi - lo + 1] = (0.75 * near[right] + 0.25 * far[right]) * scale
    count = j1 - j0
    quarter = np.float32(0.25)
    three_quarters = np.float32(0.75)
    _interpolate(line[:count], line[1 : count + 1], quarter, three_quarters, even[j0:j1])
    _interpolate(line[1 : count + 1], line[2 : count + 2], three_quarters, quarter, odd[j0:j1])
    # doubled columns before 0 take doubled column 0's value, after 2 W - 1 that one's
    first = even[j0]
    last = odd[j1 - 1]
    for j in range(j0):
        even[j] = first
        odd[j] = first
    for j in range(j1, n):
        even[j] = last
        odd[j] = last


@cached_njit(nogil=True)
def _interpolate(a, b, wa, wb, out):
    for x in range(out.shape[0]):
        out[x] = wa * a[x] + wb * b[x]


@cached_njit(nogil=True)
def _tensor_products(
    up_e, up_o, mid_e, mid_o, down_e, down_o, work, products_e, products_o
):
    """Products of the Sobel derivatives of one doubled row of the extended plane.

    ``up``/``mid``/``down`` are the doubled rows i - 1, i, i + 1 of the
    doubled plane extended by its edge values (:func:`_doubled_row`), split
    by column parity, index k holding phase column ``origin + k``.
    ``products_*[c, k]`` get ``d_r**2``, ``d_r d_c``, ``d_c**2`` at doubled
    columns 2 X (``_e``) and 2 X + 1 (``_o``), X = ``origin + k``, for k in
    [1, n - 1), inside the plane and outside it (the Gaussian reads the
    extended plane's products there). ``work`` is scratch space of shape
    (8, n).
    """
    n = up_e.shape[0]
    dv_e, dv_o, sv_e, sv_o = work[0], work[1], work[2], work[3]
    two = np.float32(2.0)
    dr_e, dr_o, dc_e, dc_o = work[4], work[5], work[6], work[7]
    for k in range(n):
        dv_e[k] = down_e[k] - up_e[k]
        dv_o[k] = down_o[k] - up_o[k]
    for k in range(n):
        sv_e[k] = up_e[k] + two * mid_e[k] + down_e[k]
        sv_o[k] = up_o[k] + two * mid_o[k] + down_o[k]
    m = n - 2
    _sobel_phase(dv_o[: n - 2], dv_e[1 : n - 1], dv_o[1 : n - 1], dr_e[1 : n - 1])
    _sobel_phase(dv_e[1 : n - 1], dv_o[1 : n - 1], dv_e[2:n], dr_o[1 : n - 1])
    _difference(sv_o[1 : n - 1], sv_o[: n - 2], dc_e[1 : n - 1])
    _difference(sv_e[2:n], sv_e[1 : n - 1], dc_o[1 : n - 1])
    _products(
        dr_e[1 : n - 1],
        dc_e[1 : n - 1],
        products_e[0, 1 : n - 1],
        products_e[1, 1 : n - 1],
        products_e[2, 1 : n - 1],
    )
    _products(
        dr_o[1 : n - 1],
        dc_o[1 : n - 1],
        products_o[0, 1 : n - 1],
        products_o[1, 1 : n - 1],
        products_o[2, 1 : n - 1],
    )
    return m


@cached_njit(nogil=True)
def _sobel_phase(left, centre, right, out):
    two = np.float32(2.0)  # float32 arithmetic: a float64 constant would widen the loop
    for x in range(centre.shape[0]):
        out[x] = left[x] + two * centre[x] + right[x]


@cached_njit(nogil=True)
def _difference(a, b, out):
    for x in range(a.shape[0]):
        out[x] = a[x] - b[x]


@cached_njit(nogil=True)
def _products(dr, dc, rr, rc, cc):
    for x in range(dr.shape[0]):
        rr[x] = dr[x] * dr[x]
        rc[x] = dr[x] * dc[x]
        cc[x] = dc[x] * dc[x]


@cached_njit(nogil=True)
def _gauss_even(line_e, line_o, pad, weights, out):
    """Gaussian of a doubled line at its even columns, from its two phases.

    Doubled column 2 X + t is ``line_e[pad + X + t / 2]`` for even t and
    ``line_o[pad + X + (t - 1) / 2]`` for odd t.
    """
    n = out.shape[0]
    radius = weights.shape[0] - 1
    _scale(out, line_e[pad : pad + n], weights[0])
    t = radius
    while t >= 1:
        if t >= 4:
            a1, b1 = _phase_pair(line_e, line_o, pad, n, t)
            a2, b2 = _phase_pair(line_e, line_o, pad, n, t - 1)
            a3, b3 = _phase_pair(line_e, line_o, pad, n, t - 2)
            a4, b4 = _phase_pair(line_e, line_o, pad, n, t - 3)
            _add_taps4(
                out,
                a1,
                b1,
                weights[t],
                a2,
                b2,
                weights[t - 1],
                a3,
                b3,
                weights[t - 2],
                a4,
                b4,
                weights[t - 3],
            )
            t -= 4
        else:
            a, b = _phase_pair(line_e, line_o, pad, n, t)
            _add_tap(out, a, b, weights[t])
            t -= 1


@cached_njit(nogil=True)
def _phase_pair(line_e, line_o, pad, n, t):
    """The two lines of doubled offsets -t and +t for the even outputs 0 .. n - 1."""
    if t % 2 == 0:
        m = t // 2
        return line_e[pad - m : pad - m + n], line_e[pad + m : pad + m + n]
    m = (t - 1) // 2
    return line_o[pad - m - 1 : pad - m - 1 + n], line_o[pad + m : pad + m + n]


@cached_njit(nogil=True)
def _tensor_tile(
    plane, scale, weights, mode, needed, tile_index, x0, x1, y0, y1, out0, out1, out2, out3
):
    """:func:`orientation_band` on the output columns ``[x0, x1)`` (column tile ``tile_index``)."""
    height = plane.shape[0]
    doubled_height = 2 * height
    radius = weights.shape[0] - 1
    ring_rows = 2 * radius + 1
    # every doubled row above the plane has the products of the one just above it, and
    # every row below that of the one just below: one slot each
    top_slot = ring_rows
    bottom_slot = ring_rows + 1
    pad = radius // 2 + 2  # the Gaussian's reach on both phases, and the Sobel's column
    tile = x1 - x0
    origin = x0 - pad  # phase column of local index 0
    n = tile + 2 * pad
    rows_e = np.zeros((3, n), dtype=np.float32)  # doubled rows, in slots row % 3
    rows_o = np.zeros((3, n), dtype=np.float32)
    row_of_slot = np.full(3, -1, dtype=np.int64)
    line = np.empty(n + 2, dtype=np.float32)
    slots = np.empty(3, dtype=np.int64)
    work = np.zeros((8, n), dtype=np.float32)
    products_e = np.zeros((3, n), dtype=np.float32)
    products_o = np.zeros((3, n), dtype=np.float32)
    ring = np.zeros((3, ring_rows + 2, tile), dtype=np.float32)
    tensor = np.empty((3, tile), dtype=np.float32)
    lower = np.empty(radius + 1, dtype=np.int64)
    upper = np.empty(radius + 1, dtype=np.int64)
    for outside, slot in ((-1, top_slot), (doubled_height, bottom_slot)):
        if (outside < 0 and 2 * y0 - radius >= 0) or (
            outside >= 0 and 2 * (y1 - 1) + radius < doubled_height
        ):
            continue  # no row of this band reads it
        _doubled_products(
            plane, scale, outside, origin, rows_e, rows_o, row_of_slot, line, slots, work,
            products_e, products_o,
        )  # fmt: skip
        for c in range(3):
            _gauss_even(products_e[c], products_o[c], pad, weights, ring[c, slot])
    next_row = max(0, 2 * y0 - radius)
    for y in range(y0, y1):
        if not needed[y, tile_index]:
            continue  # nothing asked for in this row of the tile
        centre = 2 * y
        next_row = max(next_row, centre - radius)
        last_row = min(centre + radius, doubled_height - 1)
        while next_row <= last_row:
            i = next_row
            _doubled_products(
                plane, scale, i, origin, rows_e, rows_o, row_of_slot, line, slots, work,
                products_e, products_o,
            )  # fmt: skip
            for c in range(3):
                _gauss_even(products_e[c], products_o[c], pad, weights, ring[c, i % ring_rows])
            next_row += 1
        for j in range(radius + 1):
            r = centre - j
            lower[j] = r % ring_rows if r >= 0 else top_slot
            r = centre + j
            upper[j] = r % ring_rows if r < doubled_height else bottom_slot
        for c in range(3):
            _gauss_rows(ring[c], lower, upper, centre % ring_rows, weights, tensor[c])
        if mode == TENSOR_COMPONENTS:
            _copy(tensor[0], out0[y, x0:x1])
            _copy(tensor[1], out1[y, x0:x1])
            _copy(tensor[2], out2[y, x0:x1])
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


@cached_njit(nogil=True)
def _copy(source, target):
    for x in range(target.shape[0]):
        target[x] = source[x]


@cached_njit(nogil=True)
def _derive(rr, rc, cc, strength, coherent, cosine, sine):
    """Strength ``l1 + l2``, coherence times strength, cos and sin of twice the angle."""
    for x in range(strength.shape[0]):
        trace, weight, c, s = _derived(rr[x], rc[x], cc[x])
        strength[x] = trace
        coherent[x] = weight
        cosine[x] = c
        sine[x] = s


@cached_njit(nogil=True, inline="always")
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


@cached_njit(nogil=True)
def _derive_where(rr, rc, cc, mask, start, strength, coherent, cosine, sine):
    """:func:`_derive` at the True pixels of ``mask`` only, written one after the other
    from index ``start`` of the outputs (the components gathered first, then derived in
    one loop)."""
    count = 0
    for x in range(mask.shape[0]):
        if mask[x]:
            rr[count] = rr[x]  # count <= x: a component is read before it is overwritten
            rc[count] = rc[x]
            cc[count] = cc[x]
            count += 1
    end = start + count
    _derive(
        rr[:count],
        rc[:count],
        cc[:count],
        strength[start:end],
        coherent[start:end],
        cosine[start:end],
        sine[start:end],
    )


@cached_njit(nogil=True)
def orientation_band(plane, scale, weights, mode, needed, out0, out1, out2, out3, y0, y1):
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
    (see :func:`tensor_tiles` and :func:`tiles_with`).
    """
    width = plane.shape[1]
    count = needed.shape[1]
    for k in range(count):
        x0 = (k * width) // count
        x1 = ((k + 1) * width) // count
        _tensor_tile(
            plane, scale, weights, mode, needed, k, x0, x1, y0, y1, out0, out1, out2, out3
        )


#: Variance (original pixels squared) of the 1-2-1 filter on the doubled grid that
#: :func:`decimated_tensor_band` applies before sampling the products on the original grid.
PREFILTER_VARIANCE = 0.125


def decimated_sigma(sigma: float) -> float:
    """The Gaussian sigma (original pixels) that :func:`decimated_tensor_band` applies after its
    prefilter: the two together have the variance of a Gaussian of ``sigma``."""
    return float(np.sqrt(sigma * sigma - PREFILTER_VARIANCE))


@cached_njit(nogil=True)
def _doubled_products(
    plane, scale, i, origin, rows_e, rows_o, row_of_slot, line, slots, work, products_e, products_o
):
    """The tensor products of doubled row ``i`` of the extended plane (see
    :func:`_tensor_products`; any ``i``: a row outside the plane reads its nearest rows);
    the doubled rows it reads are kept in slots ``r % 3`` of ``rows_e``/``rows_o``."""
    doubled_height = 2 * plane.shape[0]
    for k in range(3):
        r = min(max(i - 1 + k, 0), doubled_height - 1)
        slot = r % 3
        if row_of_slot[slot] != r:
            _doubled_row(plane, scale, r, origin, line, rows_e[slot], rows_o[slot])
            row_of_slot[slot] = r
        slots[k] = slot
    _tensor_products(
        rows_e[slots[0]],
        rows_o[slots[0]],
        rows_e[slots[1]],
        rows_o[slots[1]],
        rows_e[slots[2]],
        rows_o[slots[2]],
        work,
        products_e,
        products_o,
    )


@cached_njit(nogil=True)
def _prefilter_columns(products_e, products_o, weight, out):
    """``out[c, k] += weight * (P_o[k - 1] + 2 P_e[k] + P_o[k])`` for k in [1, n): the
    doubled row's 1-2-1 filter across columns, sampled at the even (original) columns."""
    n = out.shape[1]
    two = np.float32(2.0)
    for c in range(3):
        even = products_e[c]
        odd = products_o[c]
        target = out[c]
        for k in range(1, n):
            target[k] += weight * ((odd[k - 1] + odd[k]) + two * even[k])


@cached_njit(nogil=True)
def _add_doubled(
    plane,
    scale,
    i,
    origin,
    rows_e,
    rows_o,
    row_of_slot,
    line,
    slots,
    work,
    products_e,
    products_o,
    weight,
    out,
):
    """``out += weight *`` doubled row ``i``'s products (of the extended plane: any ``i``)
    filtered 1-2-1 across columns."""
    _doubled_products(
        plane,
        scale,
        i,
        origin,
        rows_e,
        rows_o,
        row_of_slot,
        line,
        slots,
        work,
        products_e,
        products_o,
    )
    _prefilter_columns(products_e, products_o, weight, out)


@cached_njit(nogil=True)
def _decimated_tile(
    plane,
    scale,
    weights,
    mode,
    needed,
    starts,
    mask,
    tile_index,
    x0,
    x1,
    y0,
    y1,
    out0,
    out1,
    out2,
    out3,
):
    """:func:`decimated_tensor_band` on the output columns ``[x0, x1)`` (tile ``tile_index``)."""
    height = plane.shape[0]
    radius = weights.shape[0] - 1
    ring_rows = 2 * radius + 1
    # rows before 0 (doubled rows before 0 only) are all alike, as rows after ``height``
    top_slot = ring_rows
    bottom_slot = ring_rows + 1
    pad = radius + 2
    tile = x1 - x0
    origin = x0 - pad  # phase column of local index 0
    n = tile + 2 * pad
    rows_e = np.zeros((3, n), dtype=np.float32)
    rows_o = np.zeros((3, n), dtype=np.float32)
    row_of_slot = np.full(3, -1, dtype=np.int64)
    line = np.empty(n + 2, dtype=np.float32)
    slots = np.empty(3, dtype=np.int64)
    work = np.zeros((8, n), dtype=np.float32)
    products_e = np.zeros((3, n), dtype=np.float32)
    products_o = np.zeros((3, n), dtype=np.float32)
    sampled = np.zeros((3, n), dtype=np.float32)  # the products filtered 1-2-1 both ways
    ring = np.zeros((3, ring_rows + 2, tile), dtype=np.float32)
    tensor = np.empty((3, tile), dtype=np.float32)
    lower = np.empty(radius + 1, dtype=np.int64)
    upper = np.empty(radius + 1, dtype=np.int64)
    quarter = np.float32(0.0625)  # (1/4) * (1/4): the two 1-2-1 filters' norms
    below = np.zeros((3, n), dtype=np.float32)
    # the rows outside the plane's: those before 0 read doubled rows before 0 only, whose
    # products are alike, as those after ``height`` (the 1-2-1 weights' sum: 4 quarters)
    for doubled, slot in ((-1, top_slot), (2 * height, bottom_slot)):
        if (doubled < 0 and y0 - radius >= 0) or (doubled >= 0 and y1 - 1 + radius <= height):
            continue  # no row of this band reads it
        sampled[:] = 0.0
        _add_doubled(
            plane, scale, doubled, origin, rows_e, rows_o, row_of_slot, line, slots, work,
            products_e, products_o, np.float32(4.0) * quarter, sampled,
        )  # fmt: skip
        for c in range(3):
            _gauss_line(sampled[c, pad - radius :], radius, weights, ring[c, slot])
    below_row = -3
    next_row = max(0, y0 - radius)
    for y in range(y0, y1):
        if not needed[y, tile_index]:
            continue
        next_row = max(next_row, y - radius)
        # row ``height`` reads doubled row 2 height - 1 of the plane, and two after it
        last_row = min(y + radius, height)
        while next_row <= last_row:
            row = next_row
            # doubled rows 2 row - 1, 2 row, 2 row + 1 with weights 1, 2, 1; the first is
            # the last of the row before, kept in ``below`` when that row was just computed
            if below_row == 2 * row - 1:
                sampled[:] = below
            else:
                sampled[:] = 0.0
                _add_doubled(
                    plane,
                    scale,
                    2 * row - 1,
                    origin,
                    rows_e,
                    rows_o,
                    row_of_slot,
                    line,
                    slots,
                    work,
                    products_e,
                    products_o,
                    quarter,
                    sampled,
                )
            _add_doubled(
                plane,
                scale,
                2 * row,
                origin,
                rows_e,
                rows_o,
                row_of_slot,
                line,
                slots,
                work,
                products_e,
                products_o,
                quarter + quarter,
                sampled,
            )
            below[:] = 0.0
            _add_doubled(
                plane,
                scale,
                2 * row + 1,
                origin,
                rows_e,
                rows_o,
                row_of_slot,
                line,
                slots,
                work,
                products_e,
                products_o,
                quarter,
                below,
            )
            below_row = 2 * row + 1
            for c in range(3):
                for k in range(n):
                    sampled[c, k] += below[c, k]
            for c in range(3):
                # output column x0 + i is local index pad + i: the line starts ``radius`` before
                _gauss_line(sampled[c, pad - radius :], radius, weights, ring[c, row % ring_rows])
            next_row += 1
        for j in range(radius + 1):
            r = y - j
            lower[j] = r % ring_rows if r >= 0 else top_slot
            r = y + j
            upper[j] = r % ring_rows if r <= height else bottom_slot
        for c in range(3):
            _gauss_rows(ring[c], lower, upper, y % ring_rows, weights, tensor[c])
        if mode == TENSOR_COMPONENTS:
            _copy(tensor[0], out0[y, x0:x1])
            _copy(tensor[1], out1[y, x0:x1])
            _copy(tensor[2], out2[y, x0:x1])
        elif starts.shape[0] == 0:
            _derive(
                tensor[0],
                tensor[1],
                tensor[2],
                out0[y, x0:x1],
                out1[y, x0:x1],
                out2[y, x0:x1],
                out3[y, x0:x1],
            )
        else:
            _derive_where(
                tensor[0],
                tensor[1],
                tensor[2],
                mask[y, x0:x1],
                starts[y, tile_index],
                out0[0],
                out1[0],
                out2[0],
                out3[0],
            )


@cached_njit(nogil=True)
def decimated_tensor_band(
    plane, scale, weights, mode, needed, starts, mask, out0, out1, out2, out3, y0, y1
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
    width = plane.shape[1]
    count = needed.shape[1]
    for k in range(count):
        x0 = (k * width) // count
        x1 = ((k + 1) * width) // count
        _decimated_tile(
            plane, scale, weights, mode, needed, starts, mask, k, x0, x1, y0, y1,
            out0, out1, out2, out3,
        )  # fmt: skip


def tensor_tiles(width: int, radius: int) -> int:
    """Column tiles of :func:`orientation_band` when only some pixels are asked for.

    Narrow tiles skip more rows without a pixel asked for, but their short
    loops cost more per pixel: tiles hold a ring of smoothed rows of
    ``TENSOR_RING_BYTES`` and are at least ``TENSOR_MIN_TILE`` columns wide.
    """
    tile = max(TENSOR_MIN_TILE, TENSOR_RING_BYTES // (3 * (2 * radius + 2) * 4))
    return max(1, (width + tile - 1) // tile)


@cached_njit(nogil=True)
def tiles_with(mask, needed, y0, y1):
    """``needed[y, k]`` = whether row y of column tile k (see :func:`orientation_band`)
    holds a True pixel of ``mask``, for rows ``[y0, y1)``."""
    width = mask.shape[1]
    count = needed.shape[1]
    for y in range(y0, y1):
        row = mask[y]
        for k in range(count):
            found = False
            for x in range((k * width) // count, ((k + 1) * width) // count):
                if row[x]:
                    found = True
                    break
            needed[y, k] = found


@cached_njit(nogil=True)
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


@cached_njit(nogil=True)
def sobel_band(plane, out, sums, y0, y1):
    """``skimage.filters.sobel`` (``reflect``) on rows ``[y0, y1)``; ``sums[y]``: min, max, sum."""
    width = plane.shape[1]
    padded = np.empty((3, width + 2))  # rows y - 1, y, y + 1 with one reflected column a side
    rows = np.empty(width)
    columns = np.empty(width)
    for y in range(y0, y1):
        _sobel_row(plane, y, padded, rows, columns, out[y], sums[y])


@cached_njit(nogil=True)
def _sobel_row(plane, y, padded, rows, columns, row, sums):
    """Row y of :func:`sobel_band` into ``row``; ``sums[0:3]``: its min, max and sum."""
    height, width = plane.shape
    root2 = np.sqrt(2.0)
    for k in range(3):
        source = plane[_reflect(y - 1 + k, height)]
        line = padded[k]
        for x in range(width):
            line[x + 1] = source[x]
        line[0] = source[_reflect(-1, width)]
        line[width + 1] = source[_reflect(width, width)]
    _sobel_rows(padded[0], padded[1], padded[2], rows, columns)
    for x in range(width):
        row[x] = np.sqrt(rows[x] * rows[x] + columns[x] * columns[x]) / root2
    low, high, _ = _finite_range(row)
    sums[0] = low
    sums[1] = high
    sums[2] = _sum(row)


@cached_njit(nogil=True)
def _sobel_rows(up, mid, down, rows, columns):
    """The two Sobel derivatives (skimage's weights 1 2 1 / 4) of a row, from padded rows."""
    for x in range(rows.shape[0]):
        rows[x] = 0.25 * (
            (down[x] + 2.0 * down[x + 1] + down[x + 2]) - (up[x] + 2.0 * up[x + 1] + up[x + 2])
        )
    for x in range(rows.shape[0]):
        columns[x] = 0.25 * (
            (up[x + 2] + 2.0 * mid[x + 2] + down[x + 2]) - (up[x] + 2.0 * mid[x] + down[x])
        )


@cached_njit(nogil=True)
def centred_sums(first, second, first_mean, second_mean, sums, y0, y1):
    """``sums[y]``: the sums of ``(a - ma)**2`` and of ``(b - mb)**2`` over row y."""
    width = first.shape[1]
    squares = np.empty(width)
    for y in range(y0, y1):
        a = first[y]
        b = second[y]
        for x in range(width):
            squares[x] = (a[x] - first_mean) * (a[x] - first_mean)
        sums[y, 0] = _sum(squares)
        for x in range(width):
            squares[x] = (b[x] - second_mean) * (b[x] - second_mean)
        sums[y, 1] = _sum(squares)


@cached_njit(nogil=True)
def added_edge_sums(after, before, edges, added_mean, edges_mean, sums, y0, y1):
    """For ``a = after - before`` and ``s = edges``, ``sums[y]`` gets, over row y:
    ``sum((a - ma)(s - ms))``, ``sum((a - ma)**2)``, min(a), max(a)."""
    width = after.shape[1]
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


@cached_njit(nogil=True)
def wall_pair_counts(walls, positive, y0, y1):
    """Per lattice direction d: pixels p with walls at p and p + d (wrapping, as ``np.roll``),
    and among them those where ``positive`` differs between p and p + d."""
    height, width = walls.shape
    counts = np.zeros((4, 2), dtype=np.int64)
    for k in range(4):
        dy = FAMILIES[k][0]
        dx = FAMILIES[k][1]
        lo = max(0, -dx)  # x + dx inside the row for x in [lo, hi)
        hi = min(width, width - dx)
        for y in range(y0, y1):
            ahead = (y + dy) % height
            both, flips = _pair_counts(
                walls[y, lo:hi],
                walls[ahead, lo + dx : hi + dx],
                positive[y, lo:hi],
                positive[ahead, lo + dx : hi + dx],
            )
            for x in list(range(lo)) + list(range(hi, width)):  # the wrapped ends
                xn = (x + dx) % width
                if walls[y, x] and walls[ahead, xn]:
                    both += 1
                    flips += positive[y, x] != positive[ahead, xn]
            counts[k, 0] += both
            counts[k, 1] += flips
    return counts


@cached_njit(nogil=True)
def _pair_counts(walls, next_walls, signs, next_signs):
    both = 0
    flips = 0
    for x in range(walls.shape[0]):
        pair = np.uint8(walls[x]) & np.uint8(next_walls[x])
        both += pair
        flips += pair & (np.uint8(signs[x]) ^ np.uint8(next_signs[x]))
    return both, flips


@cached_njit(nogil=True)
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


@cached_njit(nogil=True)
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
