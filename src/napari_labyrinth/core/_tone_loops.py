"""Numba loops of the tone scale for integer planes: one pass over the data each.

- ``count_values``: the histogram of 8- and 16-bit integers, from which
  ``percentiles.integer_percentiles`` takes the default tone limits exactly;
- ``integer_tones``: the 0-255 tones of a plane, as ``ToneScale.to_tones``;
- ``write_back``: the values of the tones that changed, as
  ``ToneScale.from_tones``, written over the source values in place, with no
  mask and no temporary array; a tone has changed where its bits differ from
  those of the source value's tone, computed again (nothing else is kept).

Each loop does the arithmetic of its numpy counterpart in the same precision
and order (float32 for 8- and 16-bit values, float64 for 32-bit ones), so the
results are bit for bit the same; ``tests/core/test_tone_scale.py`` checks it.
"""

import math

import numpy as np
from numba import njit


@njit(cache=True, nogil=True)
def count_values(flat, offset, counts):
    """Add to ``counts[v - offset]`` one for every value v of the 1-D array ``flat``."""
    for value in flat:
        counts[np.int64(value) - offset] += 1


@njit(inline="always")
def _tone(value, low, gain, low32, gain32, wide):
    """The tone of one integer value (``ToneScale.to_tones``)."""
    if wide:  # 32-bit integers: float64, then rounded to float32
        tone = np.float32((np.float64(value) - low) * gain)
    else:  # exact in float32: computed there
        tone = (np.float32(value) - low32) * gain32
    return min(max(tone, np.float32(0.0)), np.float32(255.0))


@njit(cache=True, nogil=True)
def integer_tones(values, tones, low, gain, low32, gain32, wide):
    """Fill the float32 plane ``tones`` with the tones of the integer plane ``values``."""
    height, width = values.shape
    for y in range(height):
        for x in range(width):
            tones[y, x] = _tone(values[y, x], low, gain, low32, gain32, wide)


@njit(cache=True, nogil=True)
def write_back(target, source, tones, low, gain, low32, gain32, wide, lowest, highest):
    """Where a tone of ``tones`` differs from that of ``source``, write its value to ``target``.

    The value is ``rint(tone / gain + low)`` clipped to ``[lowest, highest]``
    (``ToneScale.from_tones``); ``target`` holds the source values elsewhere.
    """
    height, width = source.shape
    for y in range(height):
        for x in range(width):
            tone = tones[y, x]
            before = _tone(source[y, x], low, gain, low32, gain32, wide)
            # the same bits (+0 and -0 differ): the pixel did not change
            if tone == before and math.copysign(1.0, tone) == math.copysign(1.0, before):
                continue
            value = np.rint(np.float64(tone) / gain + low)
            target[y, x] = min(max(value, lowest), highest)
