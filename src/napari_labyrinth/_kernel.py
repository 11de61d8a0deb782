"""Numba kernel: one pass of the labyrinthine tiling over one 2-D float32 plane.

The kernel knows nothing of dtypes, tone scaling, presets or napari: it takes a
C-contiguous float32 plane already on the paper's 0-255 tone scale and updates
it in place. Every option is an integer code; ``parameters.py`` names the
options and validates them.

Arithmetic is float64 in a fixed order and without ``fastmath`` so that
``_reference.py``, a plain-Python reading of the same algorithm, agrees with
this kernel bit for bit.
"""

import math

import numpy as np
from numba import njit

# Options arrive as integer codes: the index of the option's name in the
# tuples of ``parameters.py`` (BORDERS, VARIANCE_RATIOS, ON_EXHAUSTED, SCANS).
# ``counts`` is incremented in the order of ``parameters.DIAGNOSTIC_FIELDS``.

_GOLDEN = np.uint64(0x9E3779B97F4A7C15)
_MIX1 = np.uint64(0xBF58476D1CE4E5B9)
_MIX2 = np.uint64(0x94D049BB133111EB)
_UNIT = 1.0 / 9007199254740992.0  # 2**-53


@njit(inline="always")
def _mix(x):
    """SplitMix64 finaliser: a bijective 64-bit hash (Steele et al., 2014)."""
    z = x + _GOLDEN
    z = (z ^ (z >> np.uint64(30))) * _MIX1
    z = (z ^ (z >> np.uint64(27))) * _MIX2
    return z ^ (z >> np.uint64(31))


@njit(cache=True)
def stream_key(seed, plane_index, pass_index):
    """Key of the random stream of one plane in one pass."""
    key = _mix(np.uint64(seed))
    key = _mix(key ^ np.uint64(plane_index))
    return _mix(key ^ np.uint64(pass_index))


@njit(inline="always")
def _uniform(pixel_key, try_index):
    """R of Eq. 3: a float64 in [0, 1) from the pixel's key and the try number."""
    return np.float64(_mix(pixel_key ^ np.uint64(try_index)) >> np.uint64(11)) * _UNIT


@njit(inline="always")
def _ratio(numerator, mean):
    """``numerator / mean`` with the M = 0 guard: 0 if the numerator is 0, else inf."""
    if mean > 0.0:
        return numerator / mean
    if numerator == 0.0:
        return 0.0
    return math.inf


@njit(inline="always")
def _tone_range(g, range_bounds, n_ranges):
    """Index i of the tone range that holds g (Eq. 3); tones below L_inf^1 are in the first."""
    i = 0
    while i < n_ranges - 1 and g >= range_bounds[i]:
        i += 1
    return i


@njit(inline="always")
def _border_index(i, n, border):
    """Index of a neighbour coordinate ``i`` on an axis of length ``n``; -1 if dropped."""
    if 0 <= i < n:
        return i
    if border == 0:  # inside: neighbours outside the image do not count
        return -1
    if border == 1:  # mirror: d c b | a b c d | c b a
        if n == 1:
            return 0
        return -i if i < 0 else 2 * n - 2 - i
    if border == 2:  # nearest: a a | a b c d | d d
        return 0 if i < 0 else n - 1
    return i % n  # wrap


@njit(inline="always")
def _interior_sum(plane, y, x):
    """Sum of the 8 neighbours of an interior pixel, row-major, as float64."""
    total = np.float64(plane[y - 1, x - 1])
    total += np.float64(plane[y - 1, x])
    total += np.float64(plane[y - 1, x + 1])
    total += np.float64(plane[y, x - 1])
    total += np.float64(plane[y, x + 1])
    total += np.float64(plane[y + 1, x - 1])
    total += np.float64(plane[y + 1, x])
    total += np.float64(plane[y + 1, x + 1])
    return total


@njit(inline="always")
def _interior_squares(plane, y, x, mean):
    """Sum of squared deviations from ``mean`` of the 8 neighbours, row-major."""
    total = 0.0
    for dy in range(-1, 2):
        for dx in range(-1, 2):
            if dy != 0 or dx != 0:
                deviation = np.float64(plane[y + dy, x + dx]) - mean
                total += deviation * deviation
    return total


@njit(cache=True, nogil=True)
def labyrinth_pass(
    plane,
    mean_threshold,
    variance_threshold,
    range_bounds,
    tone_low,
    tone_high,
    max_tries,
    seed,
    plane_index,
    pass_index,
    border,
    variance_ratio,
    variance_action,
    variance_first,
    on_exhausted,
    include_centre,
    scan,
    has_nonfinite,
    counts,
    colour=-1,
    row_start=0,
    row_stop=-1,
):
    """Run one pass of the algorithm over ``plane`` in place.

    Parameters
    ----------
    plane : (H, W) float32 C-contiguous array
        Tones on the 0-255 scale; non-finite values are never changed and
        never count as neighbours.
    mean_threshold, variance_threshold : float
        t of Eq. 2 and V of Eq. 4.
    range_bounds : (n - 1,) float64 array
        Inner range limits L_sup^1 .. L_sup^(n-1); a tone g belongs to the
        first range whose upper limit exceeds it (tones below L_inf^1 belong
        to the first range, the last range takes everything above).
    tone_low, tone_high : (n,) float64 arrays
        T_inf^i and T_sup^i of Eq. 3.
    max_tries : int
        Draws of Eq. 3 before giving up.
    seed, plane_index, pass_index : int
        Select the random stream (see ``stream_key``).
    border, variance_ratio, variance_action, on_exhausted, scan : int
        Index of the option in ``parameters.BORDERS``, ``VARIANCE_RATIOS``,
        ``VARIANCE_ACTIONS``, ``ON_EXHAUSTED`` and ``SCANS``.
    variance_first : bool
        Test Eq. 4 before Eq. 2 (``condition_order="variance_first"``).
    include_centre : bool
        Whether the pixel itself joins M and V (Eq. 1).
    has_nonfinite : bool
        False promises that every value of ``plane`` is finite, which lets
        interior pixels take a path without checks.
    counts : (6,) int64 array
        Incremented in the order of ``parameters.DIAGNOSTIC_FIELDS``.
    colour : int, optional
        -1 scans every pixel in the order of ``scan``; 0-3 only the pixels of
        one checkerboard colour, ``(y % 2, x % 2) == (colour // 2, colour % 2)``,
        row by row (``scan="checkerboard"`` runs the four colours in turn).
    row_start, row_stop : int, optional
        The rows to scan (a band of the plane; -1: to the last row). Bands of
        one colour may run concurrently on threads: the kernel holds no GIL.
    """
    height, width = plane.shape
    key = stream_key(seed, plane_index, pass_index)
    neighbours = np.empty(8, dtype=np.float64)
    n_ranges = tone_low.shape[0]
    fast = not has_nonfinite
    if row_stop < 0:
        row_stop = height
    # A checkerboard colour c holds the pixels with (y mod 2, x mod 2) =
    # (c // 2, c % 2): no two of them are neighbours, so they can be updated
    # in any order, by several threads at once, with the same result.
    x_first = 0 if colour < 0 else colour & 1
    x_step = 1 if colour < 0 else 2
    columns = (width - x_first + x_step - 1) // x_step
    for y in range(row_start, row_stop):
        if colour >= 0 and (y & 1) != (colour >> 1):
            continue
        reverse = scan == 1 and (y & 1) == 1
        interior_row = fast and 0 < y < height - 1
        for step in range(columns):
            x = width - 1 - step if reverse else x_first + step * x_step
            g = np.float64(plane[y, x])
            if not math.isfinite(g):
                counts[5] += 1
                continue

            # Eq. 1: the 8 nearest and next-nearest neighbours, summed in
            # row-major order. Interior pixels of an all-finite plane read
            # them straight from the plane (the common, speed-critical case);
            # the others collect the neighbours that count in a buffer.
            interior = interior_row and 0 < x < width - 1
            if interior:
                count = 8
                neighbour_sum = _interior_sum(plane, y, x)
            else:
                count = 0
                neighbour_sum = 0.0
                for dy in range(-1, 2):
                    yy = _border_index(y + dy, height, border)
                    if yy < 0:
                        continue
                    for dx in range(-1, 2):
                        if dy == 0 and dx == 0:
                            continue
                        xx = _border_index(x + dx, width, border)
                        if xx < 0:
                            continue
                        value = np.float64(plane[yy, xx])
                        if math.isfinite(value):
                            neighbours[count] = value
                            neighbour_sum += value
                            count += 1
                if count == 0:
                    counts[5] += 1
                    continue
            if include_centre:
                n = count + 1
                mean = (neighbour_sum + g) / n
            else:
                n = count
                mean = neighbour_sum / n

            # Eq. 2: keep g when it is close to the local mean (with the
            # variance-first order, only once Eq. 4 has not fired).
            mean_ratio = _ratio(abs(g - mean), mean)
            if mean_ratio <= mean_threshold and not variance_first:
                counts[0] += 1
                continue

            # Eq. 4: the variance condition.
            if interior:
                squares = _interior_squares(plane, y, x, mean)
            else:
                squares = 0.0
                for k in range(count):
                    deviation = neighbours[k] - mean
                    squares += deviation * deviation
            if include_centre:
                squares += (g - mean) * (g - mean)
            variance = squares / n
            if variance_ratio == 0:
                spread = math.sqrt(variance / n)
            else:
                spread = math.sqrt(variance)
            if _ratio(spread, mean) > variance_threshold:
                if variance_action == 0:  # leave g as it is
                    counts[1] += 1
                    continue
                # push: draw on g's side of M, within g's tone range (Eq. 3)
                # or up to the end of the tone scale, until g* lies further
                # from M than g does.
                pixel_key = _mix(key ^ np.uint64(y * width + x))
                upward = g >= mean
                if variance_action == 1:
                    i = _tone_range(g, range_bounds, n_ranges)
                    low = max(mean, tone_low[i]) if upward else tone_low[i]
                    span = (tone_high[i] if upward else min(mean, tone_high[i])) - low
                else:
                    low = mean if upward else tone_low[0]
                    span = (tone_high[n_ranges - 1] if upward else mean) - low
                pushed = False
                for attempt in range(max_tries):
                    draw = np.float32(low + _uniform(pixel_key, attempt) * span)
                    candidate = np.float64(draw)
                    draw_mean = (neighbour_sum + candidate) / n if include_centre else mean
                    beyond = candidate > draw_mean if upward else candidate < draw_mean
                    if beyond and _ratio(abs(candidate - draw_mean), draw_mean) > mean_ratio:
                        pushed = True
                        break
                if pushed:
                    plane[y, x] = draw
                    counts[2] += 1
                else:
                    counts[1] += 1
                continue
            if mean_ratio <= mean_threshold:
                counts[0] += 1
                continue

            # Eq. 3: draw tones in the range that holds g until Eq. 2 holds.
            i = _tone_range(g, range_bounds, n_ranges)
            low = tone_low[i]
            width_i = tone_high[i] - low
            pixel_key = _mix(key ^ np.uint64(y * width + x))
            draw = np.float32(0.0)
            accepted = False
            for attempt in range(max_tries):
                draw = np.float32(low + _uniform(pixel_key, attempt) * width_i)
                candidate = np.float64(draw)
                draw_mean = (neighbour_sum + candidate) / n if include_centre else mean
                if _ratio(abs(candidate - draw_mean), draw_mean) <= mean_threshold:
                    accepted = True
                    break
            if accepted:
                plane[y, x] = draw
                counts[3] += 1
            else:
                counts[4] += 1
                if on_exhausted == 1 and max_tries > 0:
                    plane[y, x] = draw
