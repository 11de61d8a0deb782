"""numba kernels behind :mod:`napari_labyrinth.metrics`.

Every kernel works on a band of output rows ``[y0, y1)`` of a 2-D plane, so
that the caller can share a plane's rows between threads; every kernel
releases the GIL and allocates its own buffers (no shared mutable state).

Two precisions, chosen by what each result feeds:

- The fine-scale component, the local energies and lag correlations behind
  the wall map, and the local mean behind ``wall_width`` are float64 and
  follow ``scipy.ndimage.gaussian_filter`` operation for operation (the same
  1-D passes, axis 0 then axis 1, the same ``reflect`` extension, the same
  order of the taps: centre first, then the outermost pair down to the
  nearest), so they equal scipy's results bit for bit and the wall map is
  the same boolean map.
- The structure tensors (orientations) are float32: they only feed weighted
  means, where float32 rounding moves the result by about 1e-6.
"""

from __future__ import annotations

import numpy as np
from numba import njit

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


@njit(cache=True, nogil=True)
def _reflect(i, n):
    """Index of virtual position ``i`` of a line of ``n`` under scipy's ``reflect``."""
    period = 2 * n
    i = i % period
    if i >= n:
        i = period - 1 - i
    return i


@njit(cache=True, nogil=True)
def _scale(out, centre, w0):
    for i in range(out.shape[0]):
        out[i] = centre[i] * w0


@njit(cache=True, nogil=True)
def _add_taps4(out, a1, b1, w1, a2, b2, w2, a3, b3, w3, a4, b4, w4):
    """``out += (a1 + b1) w1``, then ``+= (a2 + b2) w2`` ... in this order, elementwise."""
    for i in range(out.shape[0]):
        value = out[i]
        value += (a1[i] + b1[i]) * w1
        value += (a2[i] + b2[i]) * w2
        value += (a3[i] + b3[i]) * w3
        value += (a4[i] + b4[i]) * w4
        out[i] = value


@njit(cache=True, nogil=True)
def _add_tap(out, a, b, w):
    for i in range(out.shape[0]):
        out[i] += (a[i] + b[i]) * w


@njit(cache=True, nogil=True)
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
            rows[lower[j]], rows[upper[j]], weights[j],
            rows[lower[j - 1]], rows[upper[j - 1]], weights[j - 1],
            rows[lower[j - 2]], rows[upper[j - 2]], weights[j - 2],
            rows[lower[j - 3]], rows[upper[j - 3]], weights[j - 3],
        )  # fmt: skip
        j -= 4
    while j >= 1:
        _add_tap(out, rows[lower[j]], rows[upper[j]], weights[j])
        j -= 1


@njit(cache=True, nogil=True)
def _gauss_line(ext, radius, weights, out):
    """``out[i]`` = Gaussian of the extended line ``ext`` at ``ext[radius + i]``, scipy's order."""
    n = out.shape[0]
    _scale(out, ext[radius : radius + n], weights[0])
    j = radius
    while j >= 4:
        _add_taps4(
            out,
            ext[radius - j : radius - j + n], ext[radius + j : radius + j + n], weights[j],
            ext[radius - j + 1 : radius - j + 1 + n], ext[radius + j - 1 : radius + j - 1 + n],
            weights[j - 1],
            ext[radius - j + 2 : radius - j + 2 + n], ext[radius + j - 2 : radius + j - 2 + n],
            weights[j - 2],
            ext[radius - j + 3 : radius - j + 3 + n], ext[radius + j - 3 : radius + j - 3 + n],
            weights[j - 3],
        )  # fmt: skip
        j -= 4
    while j >= 1:
        _add_tap(out, ext[radius - j : radius - j + n], ext[radius + j : radius + j + n], weights[j])
        j -= 1


@njit(cache=True, nogil=True)
def _extend(line, radius, ext):
    """``ext`` = ``line`` with ``radius`` values on each side under scipy's ``reflect``."""
    n = line.shape[0]
    for i in range(n):
        ext[radius + i] = line[i]
    for i in range(radius):
        ext[i] = line[_reflect(i - radius, n)]
        ext[radius + n + i] = line[_reflect(n + i, n)]


@njit(cache=True, nogil=True)
def fine_scale_band(plane, weights, fine, y0, y1):
    """``fine = plane - G * plane`` on rows ``[y0, y1)``; returns the sum of ``fine**2``."""
    width = plane.shape[1]
    radius = weights.shape[0] - 1
    column = np.empty(width)
    ext = np.empty(width + 2 * radius)
    smooth = np.empty(width)
    total = 0.0
    lower = np.empty(radius + 1, dtype=np.int64)
    upper = np.empty(radius + 1, dtype=np.int64)
    for y in range(y0, y1):
        for j in range(radius + 1):
            lower[j] = _reflect(y - j, plane.shape[0])
            upper[j] = _reflect(y + j, plane.shape[0])
        _gauss_rows(plane, lower, upper, y, weights, column)
        _extend(column, radius, ext)
        _gauss_line(ext, radius, weights, smooth)
        row = plane[y]
        out = fine[y]
        for x in range(width):
            value = row[x] - smooth[x]
            out[x] = value
            total += value * value
    return total


@njit(cache=True, nogil=True)
def _source_row(fine, plane, mode, dy, dx, row, s0, s1, out):
    """Row ``row``, columns ``[s0, s1)``, of the map that the wall pass smooths.

    ``mode`` MODE_LOCAL_MEAN: the plane itself; ``dy == dx == 0``: ``h**2``;
    otherwise ``0.5 * (h(p) h(p + d) + h(p - d) h(p))`` with the lags
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
        out[x - s0] = 0.5 * (
            centre[x] * ahead[(x + dx) % width] + behind[(x - dx) % width] * centre[x]
        )
    if e2 > e1:
        middle = centre[e1:e2]
        ahead_middle = ahead[e1 + dx : e2 + dx]
        behind_middle = behind[e1 - dx : e2 - dx]
        out_middle = out[e1 - s0 : e2 - s0]
        for i in range(e2 - e1):
            out_middle[i] = 0.5 * (middle[i] * ahead_middle[i] + behind_middle[i] * middle[i])
    for x in range(e2, s1):
        out[x - s0] = 0.5 * (
            centre[x] * ahead[(x + dx) % width] + behind[(x - dx) % width] * centre[x]
        )


@njit(cache=True, nogil=True)
def _smooth_block(fine, plane, mode, dy, dx, weights, b0, b1, x0, x1, ring, column, ext, result):
    """``result[y - b0, x - x0]`` = Gaussian of one source map on rows ``[b0, b1)``, columns ``[x0, x1)``.

    The source rows (:func:`_source_row`) go through a ring buffer of
    ``2 r + 1`` rows; axis 0 first, then axis 1, ``reflect`` on both.
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
        _source_row(fine, plane, mode, dy, dx, _reflect(v, height), s0, s1, rows[v % ring_rows])
    for y in range(b0, b1):
        v = y + radius
        _source_row(fine, plane, mode, dy, dx, _reflect(v, height), s0, s1, rows[v % ring_rows])
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


@njit(cache=True, nogil=True)
def smooth_band(
    fine,
    plane,
    mode,
    weights,
    energy_floor2,
    along_threshold,
    alternation_threshold,
    energy,
    flags,
    y0,
    y1,
):
    """The wall pass (or its parts) on rows ``[y0, y1)``; returns the count of True flags
    and the sum of the energy.

    ``MODE_WALLS``: ``energy = G * h**2`` and ``flags`` = the wall map;
    ``MODE_ENERGY``: ``energy`` only; ``MODE_LOCAL_MEAN``: ``flags = plane > G * plane``.
    Every Gaussian is scipy's (``reflect``, axis 0 then axis 1, same order of
    operations). The plane is cut into blocks of ``Y_BLOCK`` rows by
    ``X_TILE`` columns, small enough for a map's ring buffer to stay in L1
    and a block's maps in L2; each map of a block is smoothed in turn and
    turned into flag bits, which the wall decision then reads.
    """
    height, width = fine.shape
    radius = weights.shape[0] - 1
    n_maps = 13 if mode == MODE_WALLS else 1
    ring = np.empty((2 * radius + 1, X_TILE + 2 * radius))
    column = np.empty(X_TILE + 2 * radius)
    ext = np.empty(X_TILE + 2 * radius)
    result = np.empty((Y_BLOCK, X_TILE))
    bits = np.empty((Y_BLOCK, X_TILE), dtype=np.uint32)
    count = 0
    energy_total = 0.0
    for x0 in range(0, width, X_TILE):
        x1 = min(width, x0 + X_TILE)
        tile = x1 - x0
        for b0 in range(y0, y1, Y_BLOCK):
            b1 = min(y1, b0 + Y_BLOCK)
            for m in range(n_maps):
                _smooth_block(
                    fine, plane, mode, LAG_DY[m], LAG_DX[m], weights, b0, b1, x0, x1,
                    ring, column, ext, result,
                )  # fmt: skip
                if mode == MODE_LOCAL_MEAN:
                    for y in range(b0, b1):
                        source = plane[y, x0:x1]
                        mean = result[y - b0]
                        out = flags[y, x0:x1]
                        for i in range(tile):
                            above_mean = source[i] > mean[i]
                            out[i] = above_mean
                            count += above_mean
                elif m == 0:
                    for y in range(b0, b1):
                        row_energy = energy[y, x0:x1]
                        smoothed = result[y - b0]
                        for i in range(tile):
                            row_energy[i] = smoothed[i]
                            energy_total += smoothed[i]
                        bits[y - b0, :tile] = 0
                else:
                    # bit 5 f + 0: C(u_f) > along; + 1: C(u_f) < -alt; + 2: C(2 u_f) > alt;
                    # + 3: C(2 u_f) < -alt; + 4: C(4 u_f) > alt
                    family = (m - 1) // 3
                    step = (m - 1) % 3
                    shift = 5 * family + 2 * step
                    for y in range(b0, b1):
                        row_energy = energy[y, x0:x1]
                        smoothed = result[y - b0]
                        row_bits = bits[y - b0]
                        for i in range(tile):
                            denominator = row_energy[i]
                            if denominator < 1e-12:  # np.maximum(e, 1e-12), NaN included
                                denominator = 1e-12
                            c = smoothed[i] / denominator
                            if step == 0:
                                value = (c > along_threshold) | ((c < -alternation_threshold) << 1)
                            elif step == 1:
                                value = (c > alternation_threshold) | ((c < -alternation_threshold) << 1)
                            else:
                                value = c > alternation_threshold
                            row_bits[i] |= np.uint32(value) << np.uint32(shift)
            if mode != MODE_WALLS:
                continue
            for y in range(b0, b1):
                row_energy = energy[y, x0:x1]
                row_bits = bits[y - b0]
                out = flags[y, x0:x1]
                for i in range(tile):
                    b = row_bits[i]
                    wall = False
                    if row_energy[i] > energy_floor2:
                        for direction in range(4):
                            if (b >> (5 * direction)) & 1:
                                alt = b >> (5 * NORMAL_FAMILY[direction] + 1)
                                # opposite at w and again at 2 w, for w = 1 or 2
                                if (alt & (alt >> 1) & 1) or ((alt >> 2) & (alt >> 3) & 1):
                                    wall = True
                                    break
                    out[i] = wall
                    count += wall
    return count, energy_total


# --- structure tensor of the plane upsampled twice (float32) ---------------------------

#: What :func:`orientation_band` writes.
TENSOR_COMPONENTS = 0  # jrr, jrc, jcc
TENSOR_DERIVED = 1  # strength, coherence * strength, cos(2 angle), sin(2 angle)


@njit(cache=True, nogil=True)
def _doubled_row(plane, i, line, even, odd):
    """Row ``i`` of ``zoom(plane, 2, order=1, grid_mode=True, mode="nearest")``, split by column parity.

    ``even[1 + x]`` holds column 2 x and ``odd[1 + x]`` column 2 x + 1;
    ``even[0]``, ``odd[0]`` and the last elements are zero (the structure
    tensor's ``constant`` padding). Doubled pixel 2 k samples the plane at
    k - 1/4 and 2 k + 1 at k + 1/4: weights 1/4 and 3/4, clamped at the edges.
    """
    height, width = plane.shape
    k = i // 2
    other = k - 1 if i % 2 == 0 else k + 1
    other = min(max(other, 0), height - 1)
    near = plane[k]
    far = plane[other]
    for x in range(width):
        line[x] = 0.75 * near[x] + 0.25 * far[x]
    even[0] = 0.0
    odd[0] = 0.0
    even[width + 1] = 0.0
    odd[width + 1] = 0.0
    even[1] = line[0]
    odd[width] = line[width - 1]
    for x in range(1, width):
        even[1 + x] = 0.25 * line[x - 1] + 0.75 * line[x]
    for x in range(width - 1):
        odd[1 + x] = 0.75 * line[x] + 0.25 * line[x + 1]


@njit(cache=True, nogil=True)
def _tensor_products(up_e, up_o, mid_e, mid_o, down_e, down_o, pad, work, products_e, products_o):
    """Products of the Sobel derivatives (``constant`` padding) of one doubled row.

    ``up``/``mid``/``down`` are the doubled rows i - 1, i, i + 1 (zero rows
    outside the plane), split by column parity with one zero on each side:
    index 1 + x is column x of a phase, so index 0 of the odd phase is
    column -1 and index ``width + 1`` of the even phase column 2 ``width``,
    both zero. ``products_*[c, pad + x]`` get ``d_r**2``, ``d_r d_c``,
    ``d_c**2`` at columns 2 x (``_e``) and 2 x + 1 (``_o``). ``work`` is
    scratch space of shape (8, width + 2).
    """
    width = up_e.shape[0] - 2
    dv_e, dv_o, sv_e, sv_o = work[0], work[1], work[2], work[3]
    dr_e, dr_o, dc_e, dc_o = work[4], work[5], work[6], work[7]
    for x in range(width + 2):
        dv_e[x] = down_e[x] - up_e[x]
    for x in range(width + 2):
        dv_o[x] = down_o[x] - up_o[x]
    for x in range(width + 2):
        sv_e[x] = up_e[x] + 2.0 * mid_e[x] + down_e[x]
    for x in range(width + 2):
        sv_o[x] = up_o[x] + 2.0 * mid_o[x] + down_o[x]
    _sobel_phase(dv_o[:width], dv_e[1 : width + 1], dv_o[1 : width + 1], dr_e)
    _sobel_phase(dv_e[1 : width + 1], dv_o[1 : width + 1], dv_e[2 : width + 2], dr_o)
    _difference(sv_o[1 : width + 1], sv_o[:width], dc_e)
    _difference(sv_e[2 : width + 2], sv_e[1 : width + 1], dc_o)
    _product(dr_e, dr_e, products_e[0, pad : pad + width])
    _product(dr_e, dc_e, products_e[1, pad : pad + width])
    _product(dc_e, dc_e, products_e[2, pad : pad + width])
    _product(dr_o, dr_o, products_o[0, pad : pad + width])
    _product(dr_o, dc_o, products_o[1, pad : pad + width])
    _product(dc_o, dc_o, products_o[2, pad : pad + width])


@njit(cache=True, nogil=True)
def _sobel_phase(left, centre, right, out):
    for x in range(centre.shape[0]):
        out[x] = left[x] + 2.0 * centre[x] + right[x]


@njit(cache=True, nogil=True)
def _difference(a, b, out):
    for x in range(a.shape[0]):
        out[x] = a[x] - b[x]


@njit(cache=True, nogil=True)
def _product(a, b, out):
    for x in range(out.shape[0]):
        out[x] = a[x] * b[x]


@njit(cache=True, nogil=True)
def _gauss_even(line_e, line_o, pad, weights, out):
    """Gaussian (zero padding) of a doubled line at its even columns, from its two phases.

    Doubled column 2 X + t is ``line_e[pad + X + t / 2]`` for even t and
    ``line_o[pad + X + (t - 1) / 2]`` for odd t.
    """
    n = out.shape[0]
    radius = weights.shape[0] - 1
    _scale(out, line_e[pad : pad + n], weights[0])
    t = radius
    while t >= 1:
        count = min(4, t)
        if count == 4:
            a1, b1 = _phase_pair(line_e, line_o, pad, n, t)
            a2, b2 = _phase_pair(line_e, line_o, pad, n, t - 1)
            a3, b3 = _phase_pair(line_e, line_o, pad, n, t - 2)
            a4, b4 = _phase_pair(line_e, line_o, pad, n, t - 3)
            _add_taps4(
                out, a1, b1, weights[t], a2, b2, weights[t - 1], a3, b3, weights[t - 2],
                a4, b4, weights[t - 3],
            )  # fmt: skip
            t -= 4
        else:
            a, b = _phase_pair(line_e, line_o, pad, n, t)
            _add_tap(out, a, b, weights[t])
            t -= 1


@njit(cache=True, nogil=True)
def _phase_pair(line_e, line_o, pad, n, t):
    """The two lines of doubled offsets -t and +t for the even outputs 0 .. n - 1."""
    if t % 2 == 0:
        m = t // 2
        return line_e[pad - m : pad - m + n], line_e[pad + m : pad + m + n]
    m = (t - 1) // 2
    return line_o[pad - m - 1 : pad - m - 1 + n], line_o[pad + m : pad + m + n]


@njit(cache=True, nogil=True)
def orientation_band(plane, weights, mode, out0, out1, out2, out3, y0, y1):
    """Structure tensor of ``zoom(plane, 2)`` at the even doubled pixels of rows ``[y0, y1)``.

    ``skimage.feature.structure_tensor(doubled, sigma, order="rc")[::2, ::2]``:
    Sobel derivatives and a Gaussian (``weights``, on the doubled grid), both
    with zero padding, in float32. ``mode`` TENSOR_COMPONENTS writes jrr, jrc,
    jcc to ``out0..out2``; TENSOR_DERIVED writes the strength ``l1 + l2``,
    coherence times strength, and cos, sin of twice the angle (``out0..out3``).
    """
    height, width = plane.shape
    doubled_height = 2 * height
    radius = weights.shape[0] - 1
    ring_rows = 2 * radius + 1
    zero_slot = ring_rows
    pad = radius // 2 + 1
    # doubled rows (phases, one zero on each side): slots 0..2 by row % 3, slot 3 a zero row
    rows_e = np.zeros((4, width + 2), dtype=np.float32)
    rows_o = np.zeros((4, width + 2), dtype=np.float32)
    row_of_slot = np.full(3, -1, dtype=np.int64)
    products_e = np.zeros((3, width + 2 * pad), dtype=np.float32)
    products_o = np.zeros((3, width + 2 * pad), dtype=np.float32)
    ring = np.zeros((3, ring_rows + 1, width), dtype=np.float32)
    tensor = np.empty((3, width), dtype=np.float32)
    lower = np.empty(radius + 1, dtype=np.int64)
    upper = np.empty(radius + 1, dtype=np.int64)
    line_e = np.empty(width + 2)
    line_o = np.empty(width + 2)
    line = np.empty(width)
    slots = np.empty(3, dtype=np.int64)
    work = np.empty((8, width + 2), dtype=np.float32)
    next_row = max(0, 2 * y0 - radius)
    for y in range(y0, y1):
        centre = 2 * y
        last = min(centre + radius, doubled_height - 1)
        while next_row <= last:
            i = next_row
            for k in range(3):
                r = i - 1 + k
                if r < 0 or r >= doubled_height:
                    slots[k] = 3
                    continue
                slot = r % 3
                if row_of_slot[slot] != r:
                    _doubled_row(plane, r, line, line_e, line_o)
                    for x in range(width + 2):
                        rows_e[slot, x] = line_e[x]
                        rows_o[slot, x] = line_o[x]
                    row_of_slot[slot] = r
                slots[k] = slot
            _tensor_products(
                rows_e[slots[0]], rows_o[slots[0]], rows_e[slots[1]], rows_o[slots[1]],
                rows_e[slots[2]], rows_o[slots[2]], pad, work, products_e, products_o,
            )  # fmt: skip
            for c in range(3):
                _gauss_even(products_e[c], products_o[c], pad, weights, ring[c, i % ring_rows])
            next_row += 1
        for j in range(radius + 1):
            r = centre - j
            lower[j] = r % ring_rows if r >= 0 else zero_slot
            r = centre + j
            upper[j] = r % ring_rows if r < doubled_height else zero_slot
        for c in range(3):
            _gauss_rows(ring[c], lower, upper, centre % ring_rows, weights, tensor[c])
        if mode == TENSOR_COMPONENTS:
            for x in range(width):
                out0[y, x] = tensor[0, x]
                out1[y, x] = tensor[1, x]
                out2[y, x] = tensor[2, x]
            continue
        for x in range(width):
            jrr = np.float64(tensor[0, x])
            jrc = np.float64(tensor[1, x])
            jcc = np.float64(tensor[2, x])
            trace = jrr + jcc
            along = jrr - jcc
            across = 2.0 * jrc
            difference = np.sqrt(along * along + across * across)
            coherence = 0.0
            if trace > 0:
                coherence = (difference / max(trace, 1e-12)) ** 2
            cosine = 1.0
            sine = 0.0
            if difference > 0:
                cosine = along / difference
                sine = across / difference
            out0[y, x] = trace
            out1[y, x] = coherence * trace
            out2[y, x] = cosine
            out3[y, x] = sine


# --- reductions --------------------------------------------------------------------------


@njit(cache=True, nogil=True)
def sobel_band(plane, out, y0, y1):
    """``skimage.filters.sobel`` (``reflect``) on rows ``[y0, y1)``; returns min, max and sum."""
    height, width = plane.shape
    low = np.inf
    high = -np.inf
    total = 0.0
    root2 = np.sqrt(2.0)
    for y in range(y0, y1):
        up = plane[_reflect(y - 1, height)]
        mid = plane[y]
        down = plane[_reflect(y + 1, height)]
        for x in range(width):
            left = x - 1 if x > 0 else _reflect(x - 1, width)
            right = x + 1 if x + 1 < width else _reflect(x + 1, width)
            rows = (down[left] + 2.0 * down[x] + down[right]) - (up[left] + 2.0 * up[x] + up[right])
            columns = (up[right] + 2.0 * mid[right] + down[right]) - (
                up[left] + 2.0 * mid[left] + down[left]
            )
            rows *= 0.25
            columns *= 0.25
            value = np.sqrt(rows * rows + columns * columns) / root2
            out[y, x] = value
            low = min(low, value)
            high = max(high, value)
            total += value
    return low, high, total


@njit(cache=True, nogil=True)
def centred_sums(first, second, first_mean, second_mean, y0, y1):
    """Sums of ``(a - ma)**2`` and of ``(b - mb)**2`` over rows ``[y0, y1)``."""
    width = first.shape[1]
    first_total = 0.0
    second_total = 0.0
    for y in range(y0, y1):
        for x in range(width):
            a = first[y, x] - first_mean
            b = second[y, x] - second_mean
            first_total += a * a
            second_total += b * b
    return first_total, second_total


@njit(cache=True, nogil=True)
def added_edge_sums(after, before, edges, added_mean, edges_mean, y0, y1):
    """For ``a = after - before`` and ``s = edges`` on rows ``[y0, y1)``:
    ``sum((a - ma)(s - ms))``, ``sum((a - ma)**2)``, min(a), max(a)."""
    width = after.shape[1]
    cross = 0.0
    spread = 0.0
    low = np.inf
    high = -np.inf
    for y in range(y0, y1):
        for x in range(width):
            added = after[y, x] - before[y, x]
            a = added - added_mean
            cross += a * (edges[y, x] - edges_mean)
            spread += a * a
            low = min(low, added)
            high = max(high, added)
    return cross, spread, low, high


@njit(cache=True, nogil=True)
def wall_pair_counts(walls, positive, y0, y1):
    """Per lattice direction d: pixels p with walls at p and p + d (wrapping, as ``np.roll``),
    and among them those where ``positive`` differs between p and p + d."""
    height, width = walls.shape
    counts = np.zeros((4, 2), dtype=np.int64)
    for k in range(4):
        dy = FAMILIES[k][0]
        dx = FAMILIES[k][1]
        for y in range(y0, y1):
            wall_row = walls[y]
            sign_row = positive[y]
            next_walls = walls[(y + dy) % height]
            next_signs = positive[(y + dy) % height]
            both = 0
            flips = 0
            for x in range(width):
                if wall_row[x]:
                    xn = (x + dx) % width
                    if next_walls[xn]:
                        both += 1
                        flips += sign_row[x] != next_signs[xn]
            counts[k, 0] += both
            counts[k, 1] += flips
    return counts


@njit(cache=True, nogil=True)
def wall_weighted_sums(walls, strength, coherent, y0, y1):
    """``sum(coherent * walls)`` and ``sum(strength * walls)`` over rows ``[y0, y1)``."""
    width = walls.shape[1]
    numerator = 0.0
    denominator = 0.0
    for y in range(y0, y1):
        for x in range(width):
            if walls[y, x]:
                numerator += coherent[y, x]
                denominator += strength[y, x]
    return numerator, denominator


@njit(cache=True, nogil=True)
def alignment_sums(walls, wall_coherent, wall_cos, wall_sin, contour_coherent, contour_cos, contour_sin, y0, y1):
    """``sum(cos**2(angle difference) * weight)`` and ``sum(weight)`` on the walls,
    weight = wall coherence * strength * contour coherence * strength.

    ``cos**2(a - b) = (1 + cos 2a cos 2b + sin 2a sin 2b) / 2``.
    """
    width = walls.shape[1]
    numerator = 0.0
    denominator = 0.0
    for y in range(y0, y1):
        for x in range(width):
            if walls[y, x]:
                weight = np.float64(wall_coherent[y, x]) * np.float64(contour_coherent[y, x])
                cosine = np.float64(wall_cos[y, x]) * contour_cos[y, x] + np.float64(wall_sin[y, x]) * contour_sin[y, x]
                numerator += 0.5 * (1.0 + cosine) * weight
                denominator += weight
    return numerator, denominator
