"""Slow, plain-Python reading of the algorithm: the oracle for the numba kernel.

Written for clarity, not speed, from the paper's text: Eq. 1 (local mean and
variance), Eq. 2 (mean condition), Eq. 3 (random tone in the pixel's range),
Eq. 4 (variance condition). It shares no code with ``_kernel.py``; the tests
require the two to agree bit for bit. Arithmetic is Python float (IEEE
float64) in the same order as the kernel; drawn tones are rounded to float32
before they are tested, as the kernel stores them.
"""

import math

import numpy as np

from . import _noise_reference
from . import noise as _noise
from .codes import (
    BORDER_CODES,
    CHECKERBOARD,
    CONDITION_ORDER_CODES,
    DIAGNOSTIC_FIELDS,
    INSIDE,
    LAST_DRAW,
    LEAVE,
    MEAN_FIRST,
    MIRROR,
    NEAREST,
    ON_EXHAUSTED_CODES,
    OPTION_CODES,
    PUSH_IN_RANGE,
    SCAN_CODES,
    SERPENTINE,
    SQRT_V_OVER_N,
    VARIANCE_ACTION_CODES,
    VARIANCE_RATIO_CODES,
    WRAP,
)
from .tone_scale import ToneScale

_MASK64 = 0xFFFFFFFFFFFFFFFF

#: The tone scale of a plane of tones: each tone is its own value.
_TONES = ToneScale(0.0, 255.0)


def splitmix64(x):
    """SplitMix64 finaliser on Python ints."""
    z = (x + 0x9E3779B97F4A7C15) & _MASK64
    z = ((z ^ (z >> 30)) * 0xBF58476D1CE4E5B9) & _MASK64
    z = ((z ^ (z >> 27)) * 0x94D049BB133111EB) & _MASK64
    return z ^ (z >> 31)


def uniform(seed, plane_index, pass_index, pixel_index, try_index):
    """R of Eq. 3 for one draw: a pure function of its five counters."""
    key = splitmix64(seed)
    key = splitmix64(key ^ plane_index)
    key = splitmix64(key ^ pass_index)
    key = splitmix64(key ^ pixel_index)
    return (splitmix64(key ^ try_index) >> 11) * 2.0**-53


def _ratio(numerator, mean):
    if mean > 0.0:
        return numerator / mean
    return 0.0 if numerator == 0.0 else math.inf


def _tone_range(g, range_limits, n_ranges):
    """The range i with L_inf^i <= g < L_sup^i (below L_inf^1: the first; 255: the last)."""
    i = 0
    while i < n_ranges - 1 and g >= range_limits[i + 1]:
        i += 1
    return i


def _neighbour_coordinate(i, n, border):
    if 0 <= i < n:
        return i
    if border == INSIDE:
        return None
    if border == MIRROR:
        if n == 1:
            return 0
        return -i if i < 0 else 2 * n - 2 - i
    if border == NEAREST:
        return 0 if i < 0 else n - 1
    if border == WRAP:
        return i % n
    raise ValueError(border)


def _scan_order(height, width, scan):
    """The (y, x) of every pixel in the order of the in-place update."""
    if scan == CHECKERBOARD:  # colour by colour, each in raster order
        return [
            (y, x)
            for colour in range(4)
            for y in range(colour // 2, height, 2)
            for x in range(colour % 2, width, 2)
        ]
    order = []
    for y in range(height):
        columns = range(width)
        if scan == SERPENTINE and y % 2 == 1:
            columns = reversed(columns)
        order += [(y, x) for x in columns]
    return order


def _neighbour_values(g_plane, y, x, border):
    """The finite values of the 8 neighbours that count (Eq. 1), in row-major order."""
    height, width = g_plane.shape
    values = []
    for dy in (-1, 0, 1):
        yy = _neighbour_coordinate(y + dy, height, border)
        if yy is None:
            continue
        for dx in (-1, 0, 1):
            if dy == dx == 0:
                continue
            xx = _neighbour_coordinate(x + dx, width, border)
            if xx is None:
                continue
            value = float(g_plane[yy, xx])
            if math.isfinite(value):
                values.append(value)
    return values


def _push_bounds(g, mean, variance_action, range_limits, tones):
    """Where a push draws: on g's side of M, in g's tone range or up to the end of the scale."""
    t_inf, t_sup = tones[_tone_range(g, range_limits, len(tones))]
    if variance_action == PUSH_IN_RANGE:
        return (max(mean, t_inf), t_sup) if g >= mean else (t_inf, min(mean, t_sup))
    if g >= mean:
        return mean, tones[-1][1]
    return tones[0][0], mean


def reference_pass(
    plane,
    *,
    mean_threshold,
    variance_threshold,
    range_limits,
    tones,
    max_tries,
    seed,
    plane_index=0,
    pass_index=0,
    border="inside",
    variance_ratio="sqrt(V/N)/M",
    variance_action="leave",
    condition_order="mean_first",
    on_exhausted="keep",
    include_centre=False,
    scan="raster",
    variance_floor=-1.0,
):
    """One pass over a copy of ``plane``; returns ``(new_plane, counts)``.

    ``range_limits`` are L_inf^1 < L_sup^1 = L_inf^2 < ... < L_sup^n and
    ``tones`` the pairs (T_inf^i, T_sup^i); the options are given by name
    (``codes.py`` maps them to the kernel's codes). A pixel that Eq. 2 does not
    keep first and whose V of Eq. 1 is at most ``variance_floor`` is left alone
    (the noise gate; a negative floor: off). ``counts`` is a dict with
    the diagnostic names of ``codes.DIAGNOSTIC_FIELDS``.
    """
    border = BORDER_CODES[border]
    variance_ratio = VARIANCE_RATIO_CODES[variance_ratio]
    variance_action = VARIANCE_ACTION_CODES[variance_action]
    condition_order = CONDITION_ORDER_CODES[condition_order]
    on_exhausted = ON_EXHAUSTED_CODES[on_exhausted]
    scan = SCAN_CODES[scan]
    g_plane = np.array(plane, dtype=np.float32)
    height, width = g_plane.shape
    counts = dict.fromkeys(DIAGNOSTIC_FIELDS, 0)
    for y, x in _scan_order(height, width, scan):
        g = float(g_plane[y, x])
        if not math.isfinite(g):
            counts["skipped"] += 1
            continue
        values = _neighbour_values(g_plane, y, x, border)
        if not values:
            counts["skipped"] += 1
            continue
        neighbour_sum = 0.0
        for value in values:
            neighbour_sum += value
        if include_centre:
            values.append(g)
            n = len(values)
            mean = (neighbour_sum + g) / n
        else:
            n = len(values)
            mean = neighbour_sum / n

        mean_ratio = _ratio(abs(g - mean), mean)
        if mean_ratio <= mean_threshold and condition_order == MEAN_FIRST:  # Eq. 2
            counts["kept_by_mean"] += 1
            continue

        squares = 0.0
        for value in values:
            squares += (value - mean) * (value - mean)
        variance = squares / n  # Eq. 1
        if variance <= variance_floor:  # the noise gate: no more than the noise
            counts["noise_gated"] += 1
            continue
        if variance_ratio == SQRT_V_OVER_N:
            spread = math.sqrt(variance / n)
        else:
            spread = math.sqrt(variance)
        if _ratio(spread, mean) > variance_threshold:  # Eq. 4
            if variance_action == LEAVE:
                counts["left_by_variance"] += 1
                continue
            # push g away from M: draws on g's side of M, in g's tone range
            # or up to the end of the tone scale
            low, high = _push_bounds(g, mean, variance_action, range_limits, tones)
            for attempt in range(max_tries):
                r = uniform(seed, plane_index, pass_index, y * width + x, attempt)
                draw = float(np.float32(low + r * (high - low)))
                draw_mean = (neighbour_sum + draw) / n if include_centre else mean
                further_out = draw > draw_mean if g >= mean else draw < draw_mean
                if further_out and _ratio(abs(draw - draw_mean), draw_mean) > mean_ratio:
                    g_plane[y, x] = draw
                    counts["pushed"] += 1
                    break
            else:
                counts["left_by_variance"] += 1
            continue
        if mean_ratio <= mean_threshold:  # Eq. 2, after Eq. 4
            counts["kept_by_mean"] += 1
            continue

        t_inf, t_sup = tones[_tone_range(g, range_limits, len(tones))]
        draw = None
        accepted = False
        for attempt in range(max_tries):
            r = uniform(seed, plane_index, pass_index, y * width + x, attempt)
            draw = float(np.float32(t_inf + r * (t_sup - t_inf)))  # Eq. 3
            draw_mean = (neighbour_sum + draw) / n if include_centre else mean
            if _ratio(abs(draw - draw_mean), draw_mean) <= mean_threshold:
                accepted = True
                break
        if accepted:
            g_plane[y, x] = draw
            counts["redrawn"] += 1
        else:
            counts["out_of_tries"] += 1
            if on_exhausted == LAST_DRAW and draw is not None:
                g_plane[y, x] = draw
    return g_plane, counts


def reference_render(plane, parameters, *, seed=0, plane_index=0, noise_sigma=None):
    """All ``parameters.passes`` passes over a float32 plane of tones.

    ``parameters`` is a :class:`~napari_labyrinth.core.parameters.LabyrinthParameters`;
    ``noise_sigma``, the plane's noise in tones, is measured on ``plane``
    (``_noise_reference.tone_noise_sigma``, the numpy reading of
    ``noise.tone_noise_sigma``) when not given and the noise gate is on.
    Returns the final plane and the list of per-pass counts.
    """
    work, all_counts = np.array(plane, dtype=np.float32), []
    if noise_sigma is None:
        gated = parameters.noise_gate > 0
        noise_sigma = _noise_reference.tone_noise_sigma(work, _TONES) if gated else 0.0
    floor = _noise.variance_floor(parameters.noise_gate, noise_sigma)
    for pass_index in range(parameters.passes):
        work, counts = reference_pass(
            work,
            mean_threshold=parameters.mean_threshold,
            variance_threshold=parameters.variance_threshold,
            range_limits=parameters.tone_ranges,
            tones=parameters.tones,
            max_tries=parameters.max_tries,
            seed=seed,
            plane_index=plane_index,
            pass_index=pass_index,
            include_centre=parameters.include_centre,
            variance_floor=floor,
            **{name: getattr(parameters, name) for name in OPTION_CODES},
        )
        all_counts.append(counts)
    return work, all_counts
