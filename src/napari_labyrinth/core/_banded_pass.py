"""One pass over an integer plane, band of rows by band of rows: tones in, values out.

``labyrinth_pass`` updates a float32 plane of tones. For an integer plane
on one thread, :func:`banded_pass` makes the tones of a band of rows just
before the kernel reaches them and writes the values of the rows the
kernel has finished just after, while both are still in the processor's
cache: one sweep over the image's memory instead of three (tones, pass,
write-back), and no copy of the image made first. A row is finished once
the kernel has passed it: no later pixel writes to it (a pixel writes only
itself), they only read it.

The results are those of ``_tone_loops.integer_tones``, then
``labyrinth_pass`` over the whole plane, then ``_tone_loops.write_back``
(``rounded_tones`` for uint8 on the scale (0, 255)), bit for bit: the same
kernel runs over the same plane in the same order, one band of rows after
the other (``tests/_engine/test_render_loop.py`` checks it for every scan but the
checkerboard, which visits the plane four times and is not banded).
"""

import math

import numpy as np
from numba import njit

from ._jit import cached_njit, compiled_for
from ._kernel_arguments import PassRegion  # its file, the arguments', is in the cache stamp
from ._tone_loops import _tone
from .codes import WRAP

#: Bytes of tones in a band: with its values, inside a core's own (level 2) cache; each
#: band costs a little beyond its rows, so bands are not made smaller (docs/performance.md).
_BAND_BYTES = 1 << 20


def band_rows(width: int) -> int:
    """Rows of a band of a plane ``width`` pixels wide."""
    return max(4, _BAND_BYTES // (4 * max(1, width)))


def banded_pass(values, target, tones, rows, tones_in, write_out, scale, parameters, plane_pass,
                counts, changes, pass_kernel):  # fmt: skip
    """One pass of ``pass_kernel`` (a ``labyrinth_pass``) over the tones of the integer
    plane ``values``, band of rows by band of rows.

    Parameters
    ----------
    values : (H, W) integer C-contiguous array
        The plane's values before the passes (never written).
    target : (H, W) array of the dtype of ``values``
        With ``write_out``, every pixel gets its value after this pass: the
        value of the source where its tone did not change, else
        ``rint(tone / gain + low)`` clipped to ``[lowest, highest]``
        (``ToneScale.from_tones``).
    tones : (H, W) or (rows + 2, W) float32 C-contiguous array
        The tones the pass updates in place; with ``tones_in`` it need hold
        nothing: each row gets the tone of its values just before the kernel
        reads it (``ToneScale.to_tones``). With ``tones_in`` and ``write_out``
        (the only pass of a render) it may be a ring of one band and the rows
        above and below it, which the bands take in turn: the tones never leave
        the cache (any border but ``"wrap"``).
    rows : int
        Rows of a band (``band_rows(W)``; a ring holds ``rows + 2``).
    tones_in, write_out : bool
        Make the tones; write the values.
    scale : IntegerScale
        The tone scale of ``values``' dtype. With ``paper_uint8`` (uint8 on the
        scale (0, 255)) a tone is its value: in a whole plane every one is
        rounded back, nothing compared; in a ring the values are copied with the
        tones and the changed ones written, as for any other scale.
    parameters, plane_pass, counts
        As ``labyrinth_pass`` takes them (any scan but the checkerboard;
        ``plane_pass.has_nonfinite`` False: a plane of integers is finite).
    changes : (1 + capacity,) int64 array
        The pixels the passes write, as ``labyrinth_pass`` notes them (zero
        before the first pass): with a ring, those of each band in turn; with a
        whole plane, those of every pass so far. Where they are few, the source
        values are copied and only they are written.
    pass_kernel : numba dispatcher
        The variant of ``labyrinth_pass`` for ``parameters`` (``_kernel.pass_kernel``).

    Notes
    -----
    The bands are taken here, not in one compiled loop: the pass kernel is
    compiled once for every dtype, and only the loops that make tones and
    write values are compiled for each. A band costs three calls of compiled
    code (``_jit.compiled_for``), microseconds against its milliseconds.
    """
    height, width = values.shape
    ring = tones.shape[0] < height
    # a whole plane that changed little so far: its values are written after the pass
    deferred = (
        write_out and not ring and not scale.paper_uint8 and 32 * int(changes[0]) < height * width
    )
    # the only pass, a ring: the source values copied into the target with the tones
    # (uint8 on (0, 255) too: a copy and the few changes cost less than rounding every tone)
    copied = ring and write_out
    wrap = tones_in and parameters.border == WRAP and height > 1  # row 0 reads the last row
    made = 0  # rows whose tones are made
    prepare = write = run_pass = None
    for band_start in range(0, height, rows):
        band_stop = min(height, band_start + rows)
        # ``tones`` holds the rows from ``offset`` on: the ring, from the row above the band
        offset = band_start - 1 if ring else 0
        arguments = (values, tones, target, band_start, band_stop, rows, made, offset, ring,
                     tones_in, copied, wrap, scale)  # fmt: skip
        prepare = prepare or compiled_for(_prepare_band, *arguments)
        made = prepare(*arguments)
        if ring:
            changes[0] = 0
        region = PassRegion(-1, band_start, band_stop, 0, -1, offset, height)
        arguments = (tones, parameters, plane_pass, region, counts, changes)
        run_pass = run_pass or compiled_for(pass_kernel, *arguments)
        run_pass(*arguments)
        if write_out and not deferred:
            arguments = (target, values, tones, band_start, band_stop, offset, changes, ring,
                         scale.paper_uint8, copied, scale)  # fmt: skip
            write = write or compiled_for(write_band, *arguments)
            write(*arguments)
    if deferred:
        write_band(target, values, tones, 0, height, 0, changes, True, False, False, scale)


@cached_njit(nogil=True)
def _prepare_band(values, tones, target, band_start, band_stop, rows, made, offset, ring,
                  tones_in, copied, wrap, scale):  # fmt: skip
    """The tones a band reads, before the pass kernel takes it; the rows made so far.

    In a ring, the last row of the band above and the band's first move to the
    ring's first two rows. With ``tones_in``, the tones of the band and of the row
    below it (which the band's last row reads) from ``made`` on (and with
    ``copied`` their values into ``target``); with ``wrap``, before the first band,
    those of the last row, which row 0 reads.
    """
    height, width = values.shape
    if wrap and band_start == 0:
        _make_tones(values, tones, height - 1, height, 0, scale)
    if ring and band_start > 0:
        for k in range(2):
            for x in range(width):
                tones[k, x] = tones[rows + k, x]
    if not tones_in:
        return made
    ahead = min(height, band_stop + 1)
    if copied:  # and the source values into the target, where few will change
        _make_tones_and_copy(values, tones, target, made, ahead, offset, scale)
    else:
        _make_tones(values, tones, made, ahead, offset, scale)
    return ahead


@cached_njit(nogil=True)
def write_band(target, values, tones, row_start, row_stop, offset, changes, listed, paper_uint8,
               copied, scale):  # fmt: skip
    """The values of the rows ``row_start <= y < row_stop`` (tones at ``tones[y - offset]``):
    if ``listed`` and ``changes`` holds few pixels (all that changed there), the source
    values (unless ``copied`` there already) and those; else every pixel compared."""
    if paper_uint8 and not copied:
        _rounded_rows(target, tones, row_start, row_stop, offset)
        return
    written = changes[0]
    pixels = (row_stop - row_start) * values.shape[1]
    if listed and written < changes.shape[0] and 16 * written < pixels:
        if not copied:
            _copy_rows(target, values, row_start, row_stop)
        _write_listed(target, values, tones, changes[1 : written + 1], offset, scale)
    else:
        _write_rows(target, values, tones, row_start, row_stop, offset, scale)


@njit(nogil=True)
def _make_tones(values, tones, row_start, row_stop, offset, scale):
    """``integer_tones`` of the rows ``row_start <= y < row_stop``, into ``tones[y - offset]``."""
    width = values.shape[1]
    low, gain, low32, gain32 = scale.low, scale.gain, scale.low32, scale.gain32
    if scale.wide:  # the test out of the loop: the loop over a row runs on vector registers
        for y in range(row_start, row_stop):
            for x in range(width):
                tones[y - offset, x] = _tone(values[y, x], low, gain, low32, gain32, True)
    else:
        for y in range(row_start, row_stop):
            for x in range(width):
                tones[y - offset, x] = _tone(values[y, x], low, gain, low32, gain32, False)


@njit(nogil=True)
def _make_tones_and_copy(values, tones, target, row_start, row_stop, offset, scale):
    """``_make_tones``, and the rows' values copied into ``target`` in the same loop."""
    width = values.shape[1]
    low, gain, low32, gain32 = scale.low, scale.gain, scale.low32, scale.gain32
    for y in range(row_start, row_stop):
        if scale.wide:
            for x in range(width):
                value = values[y, x]
                target[y, x] = value
                tones[y - offset, x] = _tone(value, low, gain, low32, gain32, True)
        else:
            for x in range(width):
                value = values[y, x]
                target[y, x] = value
                tones[y - offset, x] = _tone(value, low, gain, low32, gain32, False)


@njit(nogil=True)
def _copy_rows(target, values, row_start, row_stop):
    """``target[row_start:row_stop] = values[row_start:row_stop]``, as a plain loop."""
    width = values.shape[1]
    for y in range(row_start, row_stop):
        for x in range(width):
            target[y, x] = values[y, x]


@njit(nogil=True)
def _write_rows(target, values, tones, row_start, row_stop, offset, scale):
    """Every pixel of the rows: its source value, or the value of its changed tone
    (``tones[y - offset]``)."""
    width = values.shape[1]
    low, gain, low32, gain32, wide = scale.low, scale.gain, scale.low32, scale.gain32, scale.wide
    lowest, highest = scale.lowest, scale.highest
    for y in range(row_start, row_stop):
        for x in range(width):
            tone = tones[y - offset, x]
            source = values[y, x]
            before = _tone(source, low, gain, low32, gain32, wide)
            # the same bits (+0 and -0 differ): the pixel did not change
            if tone == before and math.copysign(1.0, tone) == math.copysign(1.0, before):
                target[y, x] = source
            else:
                target[y, x] = min(max(np.rint(np.float64(tone) / gain + low), lowest), highest)


@njit(nogil=True)
def _write_listed(target, values, tones, indices, offset, scale):
    """The value of the changed tone (``tones[y - offset]``) at the pixels of flat
    ``indices`` (repeats allowed)."""
    width = values.shape[1]
    low, gain, low32, gain32, wide = scale.low, scale.gain, scale.low32, scale.gain32, scale.wide
    lowest, highest = scale.lowest, scale.highest
    for index in indices:
        y, x = index // width, index % width
        tone = tones[y - offset, x]
        before = _tone(values[y, x], low, gain, low32, gain32, wide)
        if tone == before and math.copysign(1.0, tone) == math.copysign(1.0, before):
            continue
        target[y, x] = min(max(np.rint(np.float64(tone) / gain + low), lowest), highest)


@njit(nogil=True)
def _rounded_rows(target, tones, row_start, row_stop, offset):
    """``_tone_loops.rounded_tones`` of the rows ``row_start <= y < row_stop``
    (``tones[y - offset]``)."""
    width = tones.shape[1]
    for y in range(row_start, row_stop):
        for x in range(width):
            tone = min(max(tones[y - offset, x], np.float32(0.0)), np.float32(255.0))
            target[y, x] = np.uint8(np.rint(tone))
