"""Numba kernel: one pass of the labyrinthine tiling over one 2-D float32 plane.

The kernel knows nothing of dtypes, tone scaling, presets or napari: it takes a
C-contiguous float32 plane already on the paper's 0-255 tone scale and updates
it in place. Every option is an integer code named in ``codes.py`` (the
parameter table in ``parameters.py`` maps the options' names to them); numba
folds those module-level names at compile time. ``counts`` is indexed by the
diagnostic codes of ``codes.py`` (KEPT_BY_MEAN, ..., SKIPPED).

Arithmetic is float64 in a fixed order and without ``fastmath`` so that
``_reference.py``, a plain-Python reading of the same algorithm, agrees with
this kernel bit for bit.
"""

import math

import numpy as np
from llvmlite import ir
from numba import njit, types
from numba.core import cgutils
from numba.extending import intrinsic

from ._jit import cached_njit

# the kernels' arguments: imported here, their file is part of the kernels' cache stamp
from ._kernel_arguments import PassParameters, PassRegion, PlanePass  # noqa: F401
from .codes import (
    INSIDE,
    KEEP,
    KEPT_BY_MEAN,
    LEAVE,
    LEFT_BY_VARIANCE,
    MIRROR,
    NEAREST,
    NOISE_GATED,
    OUT_OF_TRIES,
    PUSH_IN_RANGE,
    PUSHED,
    REDRAWN,
    SERPENTINE,
    SKIPPED,
    SQRT_V_OVER_N,
    VARIANCE_FIRST,
)

_GOLDEN = np.uint64(0x9E3779B97F4A7C15)
_MIX1 = np.uint64(0xBF58476D1CE4E5B9)
_MIX2 = np.uint64(0x94D049BB133111EB)
_UNIT = 1.0 / 9007199254740992.0  # 2**-53


def _prefetch_codegen(context, builder, signature, args):
    """``llvm.prefetch`` of the element of ``args[0]`` at the indices ``args[1:]``."""
    array_type = signature.args[0]
    array = context.make_array(array_type)(context, builder, args[0])
    pointer = cgutils.get_item_pointer(
        context, builder, array_type, array, list(args[1:]), wraparound=False
    )
    byte_pointer, i32 = ir.IntType(8).as_pointer(), ir.IntType(32)
    function = cgutils.get_or_insert_function(
        builder.module,
        ir.FunctionType(ir.VoidType(), [byte_pointer, i32, i32, i32]),
        "llvm.prefetch.p0i8",
    )
    read, keep_in_every_level, data = (ir.Constant(i32, v) for v in (0, 3, 1))
    address = builder.bitcast(pointer, byte_pointer)
    builder.call(function, [address, read, keep_in_every_level, data])
    return context.get_dummy_value()


@intrinsic
def _prefetch(typingctx, plane, y, x):
    """Ask the processor to bring ``plane[y, x]``'s cache line in (``llvm.prefetch``).

    A hint, with no effect on any value: a tile's row segments start on new
    lines of memory, where the processor's own prefetcher starts late.
    """
    return types.void(plane, y, x), _prefetch_codegen


@intrinsic
def prefetch_flat(typingctx, array, index):
    """``_prefetch`` of ``array[index]`` in a 1-D array."""
    return types.void(array, index), _prefetch_codegen


#: float32 values in a cache line.
_LINE = 16

#: Cache lines at the start of a tile's row segment asked for ahead of the kernel.
_AHEAD_LINES = 4


@njit(inline="always")
def _mix(x):
    """SplitMix64 finaliser: a bijective 64-bit hash (Steele et al., 2014)."""
    z = x + _GOLDEN
    z = (z ^ (z >> np.uint64(30))) * _MIX1
    z = (z ^ (z >> np.uint64(27))) * _MIX2
    return z ^ (z >> np.uint64(31))


@cached_njit()
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


@njit
def _border_index(i, n, border):
    """Index of a neighbour coordinate ``i`` on an axis of length ``n``; -1 if dropped."""
    if 0 <= i < n:
        return i
    if border == INSIDE:  # neighbours outside the image do not count
        return -1
    if border == MIRROR:  # d c b | a b c d | c b a
        if n == 1:
            return 0
        return -i if i < 0 else 2 * n - 2 - i
    if border == NEAREST:  # a a | a b c d | d d
        return 0 if i < 0 else n - 1
    return i % n  # wrap


@njit(inline="always")
def _interior_sum(plane, y, x):
    """Sum of the 8 neighbours of an interior pixel, row-major, as float64 (Eq. 1)."""
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
    """Sum of squared deviations from ``mean`` of the 8 neighbours, row-major (Eq. 1)."""
    total = 0.0
    for dy in range(-1, 2):
        for dx in range(-1, 2):
            if dy != 0 or dx != 0:
                deviation = np.float64(plane[y + dy, x + dx]) - mean
                total += deviation * deviation
    return total


@njit
def _gather(plane, y, x, border, neighbours, height, row_offset):
    """Collect the finite neighbours that count at a border or near a non-finite pixel.

    ``y`` is a row of a plane of ``height`` rows, held in ``plane`` from row
    ``row_offset`` on (see ``labyrinth_pass``). Returns their number and
    their sum (row-major order, as ``_interior_sum``).
    """
    width = plane.shape[1]
    count = 0
    total = 0.0
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
            value = np.float64(plane[yy - row_offset, xx])
            if math.isfinite(value):
                neighbours[count] = value
                total += value
                count += 1
    return count, total


@njit  # left to LLVM to inline: numba's IR inlining ("always") here costs 12 % of the speed
def _gathered_squares(neighbours, count, mean):
    """Sum of squared deviations from ``mean`` of the first ``count`` gathered neighbours."""
    total = 0.0
    for k in range(count):
        deviation = neighbours[k] - mean
        total += deviation * deviation
    return total


@njit(inline="always")
def _push(g, mean, mean_ratio, neighbour_sum, n, include_centre, pixel_key, action,
          range_bounds, tone_low, tone_high, max_tries):  # fmt: skip
    """Eq. 4's push: draws on g's side of M until one lies further from M than g.

    Draws are in g's tone range (Eq. 3, ``PUSH_IN_RANGE``) or between M and
    the end of the tone scale (``PUSH_FULL_SCALE``). Returns (pushed, draw).
    """
    n_ranges = tone_low.shape[0]
    upward = g >= mean
    if action == PUSH_IN_RANGE:
        i = _tone_range(g, range_bounds, n_ranges)
        low = max(mean, tone_low[i]) if upward else tone_low[i]
        span = (tone_high[i] if upward else min(mean, tone_high[i])) - low
    else:
        low = mean if upward else tone_low[0]
        span = (tone_high[n_ranges - 1] if upward else mean) - low
    draw = np.float32(0.0)
    pushed = False
    for attempt in range(max_tries):
        draw = np.float32(low + _uniform(pixel_key, attempt) * span)
        candidate = np.float64(draw)
        draw_mean = (neighbour_sum + candidate) / n if include_centre else mean
        beyond = candidate > draw_mean if upward else candidate < draw_mean
        if beyond and _ratio(abs(candidate - draw_mean), draw_mean) > mean_ratio:
            pushed = True
            break
    return pushed, draw


@njit(inline="always")
def _redraw(g, mean, mean_threshold, neighbour_sum, n, include_centre, pixel_key,
            range_bounds, tone_low, tone_high, max_tries):  # fmt: skip
    """Eq. 3: draw tones in the range that holds g until one satisfies Eq. 2.

    Returns (accepted, last draw); the last draw is 0 when ``max_tries`` is 0.
    """
    i = _tone_range(g, range_bounds, tone_low.shape[0])
    low = tone_low[i]
    width_i = tone_high[i] - low
    draw = np.float32(0.0)
    accepted = False
    for attempt in range(max_tries):
        draw = np.float32(low + _uniform(pixel_key, attempt) * width_i)
        candidate = np.float64(draw)
        draw_mean = (neighbour_sum + candidate) / n if include_centre else mean
        if _ratio(abs(candidate - draw_mean), draw_mean) <= mean_threshold:
            accepted = True
            break
    return accepted, draw


# Bounds within which a product or square is a normal float64: there each
# rounding is within a relative 2**-53, so a margin of 2**-30 (2**-28 for a
# square) decides a comparison exactly as the rounded quotient would.
_TINY, _HUGE = 1e-280, 1e280


@njit(inline="always")
def _at_most_ratio(numerator, mean, threshold):
    """``_ratio(numerator, mean) <= threshold``, mostly without the division.

    ``numerator`` below ``threshold * mean`` by more than the margin gives a
    quotient below t, above it by more than the margin one above t's next
    float; near the bound, or where the product is not a normal float, divide.
    """
    bound = threshold * mean
    if mean > 0.0 and _TINY < bound < _HUGE:
        if numerator < bound * (1.0 - 2.0**-30):
            return True
        if numerator > bound * (1.0 + 2.0**-30):
            return False
    return _ratio(numerator, mean) <= threshold


@njit(inline="always")
def _above_root_ratio(squared, mean, threshold):
    """``_ratio(math.sqrt(squared), mean) > threshold``, mostly without root or division.

    Compares ``squared`` with ``(threshold * mean) ** 2`` as ``_at_most_ratio``
    compares with the product; near the bound, take the root and divide.
    """
    bound = threshold * mean
    bound *= bound
    if mean > 0.0 and _TINY < bound < _HUGE:
        if squared > bound * (1.0 + 2.0**-28):
            return True
        if squared < bound * (1.0 - 2.0**-28):
            return False
    return _ratio(math.sqrt(squared), mean) > threshold


@njit(inline="always")
def _window_variance(above_left, above, above_right, left, g, right, below_left, below,
                     below_right, mean, include_centre):  # fmt: skip
    """V of Eq. 1 over an interior 3 x 3 window, in the order of ``_interior_squares``."""
    squares = (above_left - mean) * (above_left - mean)
    squares += (above - mean) * (above - mean)
    squares += (above_right - mean) * (above_right - mean)
    squares += (left - mean) * (left - mean)
    squares += (right - mean) * (right - mean)
    squares += (below_left - mean) * (below_left - mean)
    squares += (below - mean) * (below - mean)
    squares += (below_right - mean) * (below_right - mean)
    if include_centre:
        squares += (g - mean) * (g - mean)
        return squares / 9
    return squares * 0.125  # the same float64 as a division by 8, a power of two


@njit(inline="always")
def _kept_run(plane, y, x, x_stop, mean_threshold, variance_threshold, variance_first,
              variance_ratio, include_centre, variance_floor):  # fmt: skip
    """The first of the interior pixels ``x, x + 1, ... < x_stop`` of row y that
    Eq. 2 does not keep as they are (with Eq. 4 first: that Eq. 4 or Eq. 2 does not keep)
    and the noise gate does not leave alone, and how many of those before it the gate left.

    The same arithmetic as the full path of ``labyrinth_pass``, with N = 8 or 9
    known; the pixels before the one returned are kept (none changes).
    """
    gated = 0
    # the 3 x 3 window slides right: two of its columns are read once, before
    above_left, above = np.float64(plane[y - 1, x - 1]), np.float64(plane[y - 1, x])
    left, g = np.float64(plane[y, x - 1]), np.float64(plane[y, x])
    below_left, below = np.float64(plane[y + 1, x - 1]), np.float64(plane[y + 1, x])
    while x < x_stop:
        above_right = np.float64(plane[y - 1, x + 1])
        right = np.float64(plane[y, x + 1])
        below_right = np.float64(plane[y + 1, x + 1])
        # Eq. 1 in the order of _interior_sum and _interior_squares (row-major)
        neighbour_sum = above_left
        neighbour_sum += above
        neighbour_sum += above_right
        neighbour_sum += left
        neighbour_sum += right
        neighbour_sum += below_left
        neighbour_sum += below
        neighbour_sum += below_right
        if include_centre:
            mean = (neighbour_sum + g) / 9
        else:  # the same float64 as a division by 8, a power of two
            mean = neighbour_sum * 0.125
        deviation = abs(g - mean)
        if variance_first:
            variance = _window_variance(
                above_left, above, above_right, left, g, right, below_left, below,
                below_right, mean, include_centre,
            )  # fmt: skip
            if variance <= variance_floor:  # the noise gate
                gated += 1
            else:
                if include_centre:
                    squared_spread = variance / 9 if variance_ratio == SQRT_V_OVER_N else variance
                else:
                    squared_spread = (
                        variance * 0.125 if variance_ratio == SQRT_V_OVER_N else variance
                    )
                if _above_root_ratio(squared_spread, mean, variance_threshold):
                    return x, gated
                if not _at_most_ratio(deviation, mean, mean_threshold):
                    return x, gated
        elif not _at_most_ratio(deviation, mean, mean_threshold):
            if variance_floor < 0.0:  # no gate
                return x, gated
            variance = _window_variance(
                above_left, above, above_right, left, g, right, below_left, below,
                below_right, mean, include_centre,
            )  # fmt: skip
            if variance > variance_floor:
                return x, gated
            gated += 1
        above_left, above = above, above_right
        left, g = g, right
        below_left, below = below, below_right
        x += 1
    return x, gated


@njit
def _note_written(changes, index):
    """Note that the pixel of flat index ``index`` was written (see ``labyrinth_pass``)."""
    if changes is not None:
        written = changes[0]
        if written + 1 < changes.shape[0]:
            changes[written + 1] = index
        changes[0] = written + 1


def _labyrinth_pass_variant(variance_decides_first, centre_counts):
    """The kernel of one pass compiled for one condition order and one N.

    ``variance_decides_first`` (``condition_order == VARIANCE_FIRST``) and
    ``centre_counts`` (``include_centre``) are constants of the compiled code:
    each variant holds the tight loop of its own case only, and compiles in
    half the time of one kernel holding all four. :func:`pass_kernel` picks the
    variant of a call's ``condition_order`` and ``include_centre``.
    """

    @cached_njit(nogil=True)
    def labyrinth_pass(plane, parameters, plane_pass, region, counts, changes):
        """Run one pass of the algorithm over ``plane`` in place (Eq. 1-4).

        Parameters
        ----------
        plane : (H, W) float32 C-contiguous array
            Tones on the 0-255 scale; non-finite values never change and never count.
        parameters : _kernel_arguments.PassParameters
            t, V, the tone ranges, the draws before giving up and the options'
            codes; its ``condition_order`` and ``include_centre`` are the
            variant's (:func:`pass_kernel`).
        plane_pass : _kernel_arguments.PlanePass
            The random stream (``seed``, ``plane_index``, ``pass_index``: see
            ``stream_key``), ``has_nonfinite`` (False promises an all-finite
            plane: interior pixels skip the checks) and ``variance_floor``: a
            pixel not kept by Eq. 2 first whose V of Eq. 1 is at most it is left
            alone (the noise gate; negative: off).
        region : _kernel_arguments.PassRegion
            The pixels this call visits: a checkerboard colour, a band of rows, a
            range of diagonals ``x + y`` (a parallelogram tile of the exact-order
            schedule of ``_engine``), and the rows of the plane that ``plane``
            holds (``WHOLE_PLANE``: all of them). Rows, random streams and
            borders are those of the whole plane.
        counts : (7,) int64 array
            Incremented at the diagnostic codes (``codes.KEPT_BY_MEAN``, ...).
        changes : (1 + capacity,) int64 array
            Where the pass notes the pixels it writes: ``changes[0]`` is
            incremented for every write and the first ``capacity`` writes' flat
            indices ``y * W + x`` follow it (so that the write-back of a few
            changes need not visit the whole plane). A pixel written to the
            tone it had is noted too.

        Notes
        -----
        Interior pixels of an all-finite plane that are kept as they are (the
        common case) run in a tight loop (``_kept_run``), the one of the
        variant's ``condition_order`` and ``include_centre``; every other pixel takes the
        full path below it. Both agree with ``_reference.py`` bit for bit.
        """
        mean_threshold = parameters.mean_threshold
        variance_threshold = parameters.variance_threshold
        range_bounds, tone_low, tone_high = (
            parameters.range_bounds, parameters.tone_low, parameters.tone_high
        )  # fmt: skip
        max_tries, border, scan = parameters.max_tries, parameters.border, parameters.scan
        variance_ratio, variance_action = parameters.variance_ratio, parameters.variance_action
        on_exhausted, has_nonfinite = parameters.on_exhausted, plane_pass.has_nonfinite
        variance_floor = plane_pass.variance_floor
        colour, row_start, row_stop = region.colour, region.row_start, region.row_stop
        diagonal_start, diagonal_stop = region.diagonal_start, region.diagonal_stop
        row_offset, plane_height = region.row_offset, region.plane_height
        width = plane.shape[1]
        height = plane.shape[0] if plane_height < 0 else plane_height
        key = stream_key(plane_pass.seed, plane_pass.plane_index, plane_pass.pass_index)
        neighbours = np.empty(8, dtype=np.float64)
        if row_stop < 0:
            row_stop = height
        # the pixels of one checkerboard colour are no neighbours of each other:
        # they can be updated in any order, by several threads, with one result
        x_first = 0 if colour < 0 else colour & 1
        x_step = 1 if colour < 0 else 2
        kept = left = pushed_count = redrawn = exhausted = skipped = gated = 0
        for y in range(row_start, row_stop):
            if colour >= 0 and (y & 1) != (colour >> 1):
                continue
            reverse = scan == SERPENTINE and (y & 1) == 1
            interior_row = not has_nonfinite and 0 < y < height - 1
            x_start = max(x_first, diagonal_start - y)
            x_stop = width if diagonal_stop < 0 else min(width, diagonal_stop - y)
            row = y - row_offset  # the row's place in ``plane``
            if diagonal_stop >= 0 and row + 2 < plane.shape[0]:
                # a tile: the row below the next one, which that row's segment
                # (one pixel to the left) reads, is not yet in the cache; its first
                # lines only: the processor's own prefetcher follows the rest (asking
                # for every line cost a single tile over the plane ~5 % more time)
                ahead_stop = min(width, x_stop, x_start - 2 + _AHEAD_LINES * _LINE)
                for x_ahead in range(max(0, x_start - 2), ahead_stop, _LINE):
                    _prefetch(plane, row + 2, x_ahead)
            # interior pixels that Eq. 2 keeps (Eq. 4 first: that keeps) run in a
            # tight loop of their own (_kept_run); the others take the full path
            fast_row = interior_row and not reverse and colour < 0
            fast_start, fast_stop = max(x_start, 1), min(x_stop, width - 1)
            not_kept = -1  # the pixel at which the last run stopped
            steps = (x_stop - x_start + x_step - 1) // x_step
            step = -1
            while step < steps - 1:  # a for loop that a run of kept pixels can advance
                step += 1
                x = x_stop - 1 - step if reverse else x_start + step * x_step
                if fast_row and fast_start <= x < fast_stop and x != not_kept:
                    # the loop of this variant's case (the other branches fold away):
                    # no test of the options inside it
                    if variance_decides_first:
                        if centre_counts:
                            x_next, gated_run = _kept_run(
                                plane, row, x, fast_stop, mean_threshold, variance_threshold,
                                True, variance_ratio, True, variance_floor,
                            )  # fmt: skip
                        else:
                            x_next, gated_run = _kept_run(
                                plane, row, x, fast_stop, mean_threshold, variance_threshold,
                                True, variance_ratio, False, variance_floor,
                            )  # fmt: skip
                    elif centre_counts:
                        x_next, gated_run = _kept_run(
                            plane, row, x, fast_stop, mean_threshold, variance_threshold,
                            False, variance_ratio, True, variance_floor,
                        )  # fmt: skip
                    else:
                        x_next, gated_run = _kept_run(
                            plane, row, x, fast_stop, mean_threshold, variance_threshold,
                            False, variance_ratio, False, variance_floor,
                        )  # fmt: skip
                    if x_next > x:
                        kept += x_next - x - gated_run
                        gated += gated_run
                        step += x_next - x - 1
                        not_kept = x_next
                        continue
                g = np.float64(plane[row, x])
                if not math.isfinite(g):
                    skipped += 1
                    continue
                # Eq. 1 over the 8 nearest and next-nearest neighbours: interior
                # pixels of an all-finite plane (the common, speed-critical case)
                # read them straight from the plane, the others gather them.
                interior = interior_row and 0 < x < width - 1
                if interior:
                    count, neighbour_sum = 8, _interior_sum(plane, row, x)
                else:
                    count, neighbour_sum = _gather(
                        plane, y, x, border, neighbours, height, row_offset
                    )
                    if count == 0:
                        skipped += 1
                        continue
                n = count + 1 if centre_counts else count
                if centre_counts:
                    mean = (neighbour_sum + g) / n
                elif interior:  # n = 8: the same float64 as a division by 8, a power of two
                    mean = neighbour_sum * 0.125
                else:
                    mean = neighbour_sum / n

                # Eq. 2 decides first unless the order is variance-first.
                mean_ratio = _ratio(abs(g - mean), mean)
                if mean_ratio <= mean_threshold and not variance_decides_first:
                    kept += 1
                    continue

                # Eq. 4: the variance condition.
                if interior:
                    squares = _interior_squares(plane, row, x, mean)
                else:
                    squares = _gathered_squares(neighbours, count, mean)
                if centre_counts:
                    squares += (g - mean) * (g - mean)
                if interior and not centre_counts:
                    variance = squares * 0.125
                    spread = math.sqrt(
                        variance * 0.125 if variance_ratio == SQRT_V_OVER_N else variance
                    )
                else:
                    variance = squares / n
                    spread = math.sqrt(
                        variance / n if variance_ratio == SQRT_V_OVER_N else variance
                    )
                if variance <= variance_floor:  # the noise gate: no more than the noise
                    gated += 1
                    continue
                if _ratio(spread, mean) > variance_threshold:
                    if variance_action == LEAVE:
                        left += 1
                        continue
                    pushed, draw = _push(
                        g, mean, mean_ratio, neighbour_sum, n, centre_counts,
                        _mix(key ^ np.uint64(y * width + x)), variance_action,
                        range_bounds, tone_low, tone_high, max_tries,
                    )  # fmt: skip
                    if pushed:
                        plane[row, x] = draw
                        _note_written(changes, y * width + x)
                        pushed_count += 1
                    else:
                        left += 1
                    continue
                if mean_ratio <= mean_threshold:
                    kept += 1
                    continue

                # Eq. 3: draws in the tone range of g until one satisfies Eq. 2.
                accepted, draw = _redraw(
                    g, mean, mean_threshold, neighbour_sum, n, centre_counts,
                    _mix(key ^ np.uint64(y * width + x)), range_bounds, tone_low, tone_high,
                    max_tries,
                )  # fmt: skip
                if accepted:
                    plane[row, x] = draw
                    _note_written(changes, y * width + x)
                    redrawn += 1
                else:
                    exhausted += 1
                    if on_exhausted != KEEP and max_tries > 0:
                        plane[row, x] = draw
                        _note_written(changes, y * width + x)
        counts[KEPT_BY_MEAN] += kept
        counts[LEFT_BY_VARIANCE] += left
        counts[PUSHED] += pushed_count
        counts[REDRAWN] += redrawn
        counts[OUT_OF_TRIES] += exhausted
        counts[SKIPPED] += skipped
        counts[NOISE_GATED] += gated

    return labyrinth_pass


#: The kernel's variants, indexed by ``variant_index``.
PASS_VARIANTS = tuple(
    _labyrinth_pass_variant(variance_decides_first, centre_counts)
    for variance_decides_first in (False, True)
    for centre_counts in (False, True)
)


def variant_index(condition_order: int, include_centre: bool) -> int:
    """The index in ``PASS_VARIANTS`` of the kernel for ``condition_order`` and
    ``include_centre``."""
    return 2 * int(condition_order == VARIANCE_FIRST) + int(bool(include_centre))


def pass_kernel(condition_order: int, include_centre: bool):
    """The numba kernel of one pass (``labyrinth_pass``) for ``condition_order`` and
    ``include_centre``, which the kernel's ``parameters`` must repeat."""
    return PASS_VARIANTS[variant_index(condition_order, include_centre)]
