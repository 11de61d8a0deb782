"""Kernels of the structure tensor (float32): of the plane upsampled twice
(:func:`orientation_band`, :func:`orientation`'s) and decimated on the original grid
(:func:`decimated_tensor_band`, the walls' and the contours'), and the counts of a mask's
pixels by column tile that say which rows of which tiles to compute.

The tensors only feed weighted means, where float32 rounding moves the
result by about 1e-8. The decimated tensor filters the doubled grid's
products 1-2-1 and smooths them on the original grid: a window within a few
per cent of the doubled grid's Gaussian at a quarter of its pixels.
"""

from __future__ import annotations

import numpy as np

from ...core._jit import cached_njit
from ._rows import _gauss, _helper, _load_row, _plane_shape

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
