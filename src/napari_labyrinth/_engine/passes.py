"""One pass of the kernel over one plane: the compiled variant, its arguments, its threads.

:func:`run_pass` runs ``core._kernel.labyrinth_pass`` over a float32 plane of
tones, on one thread, in the exact-order tiles (``tiles``) or in the
checkerboard's bands; :func:`banded_pass` runs ``core._banded_pass`` over an
integer plane, tones made and values written band of rows by band of rows.
Both take the kernel variant of the parameters' condition order and
``include_centre``, and pass the parameters as the kernel reads them.
"""

from __future__ import annotations

import functools
import logging
from concurrent.futures import ThreadPoolExecutor
from typing import Any

import numpy as np

from ..core.codes import DIAGNOSTIC_FIELDS, OPTION_CODES
from ..core.parameters import LabyrinthParameters
from ..core.tone_scale import banded_scale_arguments
from .changes import empty_copies, gather_changes, new_changes
from .cores import idle_cores
from .counts import add_padded_counts, padded_counts
from .tiles import (
    MIN_PARALLEL_PIXELS,
    WHOLE_PLANE,
    default_tile,
    exact_order_refusal,
    run_exact_order,
)

_LOG = logging.getLogger("napari_labyrinth")


def run_pass(
    tones: np.ndarray,
    parameters: LabyrinthParameters,
    *,
    seed: int = 0,
    plane_index: int = 0,
    pass_index: int = 0,
    counts: np.ndarray | None = None,
    has_nonfinite: bool | None = None,
    workers: int = 1,
    tile: tuple[int, int] | None = None,
    changes: np.ndarray | None = None,
) -> np.ndarray:
    """Run one pass of the numba kernel on a float32 plane of 0-255 tones, in place.

    The low-level entry point (no tone mapping, no copies, no validation of
    ``tones``): ``tones`` must be a C-contiguous 2-D float32 array.
    ``counts``, if given, is an int64 array of ``len(DIAGNOSTIC_FIELDS)`` that
    the pass increments. ``changes``, if given (see ``changes.new_changes``),
    collects the flat indices of the pixels the pass writes. Returns ``counts``.

    With ``workers > 1`` a large plane runs on several threads: in the
    paper's raster order as parallelogram tiles of ``tile = (rows,
    diagonals)`` pixels (see ``tiles.exact_order_tiles``), bit for bit the
    result of one thread; with ``scan="checkerboard"`` in bands of rows of
    each colour. A raster plane of one band of tiles, or by default of fewer
    than ``MIN_PARALLEL_PIXELS`` pixels, runs on one thread, as does an order
    the tiles cannot reproduce (``tiles.exact_order_refusal``; the
    ``napari_labyrinth`` logger says so). Without ``tile``, the tiles take no
    more threads than ``cores.idle_cores``: on a core shared with a busy task,
    a tile thread would hold up the others.
    """
    labyrinth_pass = _pass_kernel(parameters)
    if counts is None:
        counts = np.zeros(len(DIAGNOSTIC_FIELDS), dtype=np.int64)
    if changes is None:  # room for none: every call compiles to the same kernel
        changes = new_changes(0)
    if has_nonfinite is None:
        has_nonfinite = not np.isfinite(tones).all()
    arguments = (tones, *_kernel_arguments(parameters), np.uint64(seed), plane_index, pass_index)
    options = (*_kernel_options(parameters), has_nonfinite)
    if parameters.scan == "checkerboard":
        _checkerboard_bands(
            labyrinth_pass, arguments, options, counts, tones.shape[0], workers, changes
        )
        return counts
    if workers > 1:
        refusal = exact_order_refusal(parameters)
        rows, diagonals = tile or default_tile(tones.shape, workers, parameters)
        if refusal is not None:
            _LOG.info("one thread for this plane: %s", refusal)
        elif tones.shape[0] > rows and (tile is not None or tones.size >= MIN_PARALLEL_PIXELS):
            if tile is None:  # by default, no more threads than idle cores
                workers = min(workers, idle_cores())
            if workers > 1:
                run_exact_order(
                    labyrinth_pass, arguments, options, counts, rows, diagonals, workers, changes
                )
                return counts
    # every call gives every argument: one compiled kernel serves all of them, and
    # numba's dispatcher takes its fast path (an omitted argument costs ~90 µs a call)
    labyrinth_pass(*arguments, *options, counts, -1, 0, -1, 0, -1, changes, *WHOLE_PLANE)
    return counts


def banded_pass(
    values, target, work, scale, parameters, *, seed, plane_index, pass_index, counts, changes
) -> None:
    """One pass of ``core._banded_pass.banded_pass`` over ``work``, the tones of ``values``:
    made in the first pass, and the values written into ``target`` unless it is None."""
    from ..core._banded_pass import band_rows, banded_kernel  # numba is imported on first use only

    banded_pass = banded_kernel(*_variant_options(parameters))
    write_out = target is not None
    if not write_out:  # never written then, but typed as written: numba refuses a read-only
        target = np.empty((0, 0), values.dtype)  # array there (``values`` may be one)
    banded_pass(
        values,
        target,
        work,
        band_rows(values.shape[1]),
        pass_index == 0,
        write_out,
        *banded_scale_arguments(scale, values.dtype),
        *_kernel_arguments(parameters),
        np.uint64(seed),
        plane_index,
        pass_index,
        *_kernel_options(parameters),
        counts,
        changes,
    )


def _checkerboard_bands(
    labyrinth_pass, arguments, options, counts, height, workers, changes
) -> None:
    """The four colours in turn, the rows of each split among ``workers`` threads."""
    bands = np.linspace(0, height, min(workers, max(1, height // 2)) + 1).astype(int)
    band_counts = padded_counts(len(bands) - 1)
    band_changes = empty_copies(changes, len(bands) - 1)
    for colour in range(4):  # the pixels of one colour are independent of each other
        if len(bands) == 2:
            labyrinth_pass(
                *arguments, *options, band_counts[0], colour, 0, height, 0, -1, band_changes[0],
                *WHOLE_PLANE,
            )  # fmt: skip
            continue
        with ThreadPoolExecutor(len(bands) - 1) as pool:
            for future in [
                pool.submit(
                    labyrinth_pass,
                    *arguments,
                    *options,
                    band_counts[k],
                    colour,
                    start,
                    stop,
                    0,
                    -1,
                    band_changes[k],
                    *WHOLE_PLANE,
                )  # fmt: skip
                for k, (start, stop) in enumerate(zip(bands[:-1], bands[1:]))
            ]:
                future.result()
    add_padded_counts(counts, band_counts)
    gather_changes(changes, band_changes)


@functools.lru_cache(maxsize=64)
def _kernel_arguments(parameters: LabyrinthParameters) -> tuple[Any, ...]:
    """Thresholds, range limits, T_inf, T_sup and max tries as the kernel takes them."""
    range_bounds = np.array(parameters.tone_ranges[1:-1], dtype=np.float64)
    tone_low = np.array([low for low, _ in parameters.tones], dtype=np.float64)
    tone_high = np.array([high for _, high in parameters.tones], dtype=np.float64)
    return (
        parameters.mean_threshold,
        parameters.variance_threshold,
        range_bounds,
        tone_low,
        tone_high,
        parameters.max_tries,
    )


def _variant_options(parameters: LabyrinthParameters) -> tuple[int, bool]:
    """The options that select the kernel's compiled variant: ``condition_order``'s code
    and ``include_centre`` (``core._kernel.pass_kernel``)."""
    return OPTION_CODES["condition_order"][parameters.condition_order], parameters.include_centre


def _pass_kernel(parameters: LabyrinthParameters):
    """The numba kernel of one pass (``labyrinth_pass``) compiled for ``parameters``."""
    from ..core._kernel import pass_kernel  # numba is imported on first use only

    return pass_kernel(*_variant_options(parameters))


@functools.lru_cache(maxsize=64)
def _kernel_options(parameters: LabyrinthParameters) -> tuple[Any, ...]:
    """The options' codes in the order of ``codes.OPTION_CODES``, then ``include_centre``."""
    codes = tuple(codes[getattr(parameters, name)] for name, codes in OPTION_CODES.items())
    return (*codes, parameters.include_centre)
