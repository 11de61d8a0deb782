"""The arguments of the numba kernels, grouped: NamedTuples that numba takes as they are.

``_kernel.labyrinth_pass`` and ``_banded_pass.banded_pass`` take a plane, a
few of these and the arrays they write; the loops of ``_tone_loops`` take an
:class:`IntegerScale`. numba types a NamedTuple as a tuple of its fields'
types (a float64, an int64, a boolean, an array: each as one of the kernel's
own arguments would be) and reads a field at no cost, so the kernels'
arithmetic is that of separate arguments. Build each field with the type its
annotation says: a field of another type (an int where a float is due) would
compile the kernels again for it.

numba's disk cache knows a NamedTuple by its class and its fields' types, not
by its fields' names: the kernels that take these tuples import them at the
top of their module, so that this file is part of their cache stamp
(``_jit.cached_njit``) and a field moved or renamed compiles them again.

This module imports no numba: the engine builds the tuples before any kernel
is compiled.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np


class PassParameters(NamedTuple):
    """The parameters of a pass as the kernels read them: numbers and option codes.

    Attributes
    ----------
    mean_threshold, variance_threshold : float
        t of Eq. 2 and V of Eq. 4.
    range_bounds, tone_low, tone_high : ndarray of float64
        The inner range limits L_sup^1 .. L_sup^(n-1), and T_inf^i and T_sup^i
        of Eq. 3 (C-contiguous 1-D arrays).
    max_tries : int
        Draws before giving up.
    border, variance_ratio, variance_action, condition_order, on_exhausted, scan : int
        The options' codes (``codes.OPTION_CODES``).
    include_centre : bool
        Whether N counts g itself (Eq. 1).
    """

    mean_threshold: float
    variance_threshold: float
    range_bounds: np.ndarray
    tone_low: np.ndarray
    tone_high: np.ndarray
    max_tries: int
    border: int
    variance_ratio: int
    variance_action: int
    condition_order: int
    on_exhausted: int
    scan: int
    include_centre: bool


class PlanePass(NamedTuple):
    """Which pass over which plane, and what the pass may assume of the plane.

    Attributes
    ----------
    seed : numpy.uint64
        The run's seed; with ``plane_index`` and ``pass_index`` (int) it
        selects the random stream of the pass over the plane (``_kernel.stream_key``).
    plane_index, pass_index : int
    has_nonfinite : bool
        False promises an all-finite plane: interior pixels skip the checks.
    variance_floor : float
        The noise gate's floor (``noise.variance_floor``), in tones²: a pixel
        Eq. 2 does not keep first is left alone where the variance of Eq. 1
        is at most this; negative: the gate is off.
    """

    seed: np.uint64
    plane_index: int
    pass_index: int
    has_nonfinite: bool
    variance_floor: float = -1.0


class PassRegion(NamedTuple):
    """The pixels one call of a pass kernel visits, and which rows of the plane it holds.

    Attributes
    ----------
    colour : int
        -1: every pixel in the order of the scan; 0-3: only the pixels with
        ``(y % 2, x % 2) == (colour // 2, colour % 2)``, none of them
        neighbours, so bands of rows of one colour may run on threads at once.
    row_start, row_stop, diagonal_start, diagonal_stop : int
        Only the rows ``row_start <= y < row_stop`` and, in a raster or
        serpentine scan, the pixels with ``diagonal_start <= x + y <
        diagonal_stop``: a parallelogram tile of the exact-order schedule. A
        stop of -1 is the end of the plane.
    row_offset, plane_height : int
        The plane array holds only the rows ``row_offset, row_offset + 1, ...``
        of a plane of ``plane_height`` rows (-1: the array is the whole plane).
    """

    colour: int = -1
    row_start: int = 0
    row_stop: int = -1
    diagonal_start: int = 0
    diagonal_stop: int = -1
    row_offset: int = 0
    plane_height: int = -1


#: Every pixel of a plane held whole, in the order of the scan.
WHOLE_PLANE = PassRegion()


class IntegerScale(NamedTuple):
    """A tone scale as the numba loops over integer planes read it (``_tone_loops``,
    ``_banded_pass``), for one integer dtype (``tone_scale.integer_scale``).

    Attributes
    ----------
    paper_uint8 : bool
        uint8 values on the scale (0, 255): each value is its own tone.
    low, gain : float
        ``tone = (value - low) * gain`` in float64, and ``value = rint(tone /
        gain + low)`` back (``ToneScale.to_tones``, ``ToneScale.from_tones``).
    low32, gain32 : numpy.float32
        The same map in float32 (0 and 1 where float32 does not hold it).
    wide : bool
        Whether the tones are computed in float64: 32-bit values, or a map
        float32 does not hold (as ``ToneScale.to_tones``).
    lowest, highest : float
        The dtype's range: values written back are clipped to it.
    """

    paper_uint8: bool
    low: float
    gain: float
    low32: np.float32
    gain32: np.float32
    wide: bool
    lowest: float
    highest: float
