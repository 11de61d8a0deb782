"""One pass of the kernel over one plane: the compiled variant, its arguments, its threads.

:func:`run_pass` runs ``core._kernel.labyrinth_pass`` over a float32 plane of
tones, on one thread, in the exact-order tiles (``tiles``) or in the
checkerboard's bands; :func:`banded_pass` runs ``core._banded_pass`` over an
integer plane, tones made and values written band of rows by band of rows.
Both take the kernel variant of the parameters' condition order and
``include_centre``, and the parameters as the kernels read them
(:func:`pass_parameters`).
"""

from __future__ import annotations

import functools
import itertools
import logging
from concurrent.futures import ThreadPoolExecutor

import numpy as np

from ..core._kernel_arguments import WHOLE_PLANE, PassParameters, PassRegion, PlanePass
from ..core.codes import DIAGNOSTIC_FIELDS, OPTION_CODES
from ..core.parameters import LabyrinthParameters
from ..core.tone_scale import integer_scale
from .changes import empty_copies, gather_changes, new_changes
from .cores import idle_cores
from .counts import add_padded_counts, padded_counts
from .tiles import MIN_PARALLEL_PIXELS, default_tile, exact_order_refusal, run_exact_order

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
    variance_floor: float = -1.0,
) -> np.ndarray:
    """Run one pass of the numba kernel on a float32 plane of 0-255 tones, in place.

    The low-level entry point (no tone mapping, no copies, no validation of
    ``tones``): ``tones`` must be a C-contiguous 2-D float32 array.
    ``counts``, if given, is an int64 array of ``len(DIAGNOSTIC_FIELDS)`` that
    the pass increments. ``changes``, if given (see ``changes.new_changes``),
    collects the flat indices of the pixels the pass writes. ``variance_floor``
    is the noise gate's (``core.noise.variance_floor``; negative: off). Returns
    ``counts``.

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
    kernel_parameters = pass_parameters(parameters)
    labyrinth_pass = pass_kernel_for(kernel_parameters)
    if counts is None:
        counts = np.zeros(len(DIAGNOSTIC_FIELDS), dtype=np.int64)
    if changes is None:  # room for none: every call compiles to the same kernel
        changes = new_changes(0)
    if has_nonfinite is None:
        has_nonfinite = not np.isfinite(tones).all()
    plane_pass = PlanePass(
        np.uint64(seed), int(plane_index), int(pass_index), bool(has_nonfinite),
        float(variance_floor),
    )  # fmt: skip
    if parameters.scan == "checkerboard":
        _checkerboard_bands(
            labyrinth_pass, tones, kernel_parameters, plane_pass, counts, changes, workers
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
                    labyrinth_pass, tones, kernel_parameters, plane_pass, counts, changes, rows,
                    diagonals, workers,
                )  # fmt: skip
                return counts
    labyrinth_pass(tones, kernel_parameters, plane_pass, WHOLE_PLANE, counts, changes)
    return counts


def banded_pass(
    values, target, work, scale, parameters, *, seed, plane_index, pass_index, counts, changes,
    variance_floor=-1.0,
) -> None:  # fmt: skip
    """One pass of ``core._banded_pass.banded_pass`` over ``work``, the tones of ``values``:
    made in the first pass, and the values written into ``target`` unless it is None;
    ``variance_floor`` as for :func:`run_pass`."""
    from ..core import _banded_pass  # numba is imported on first use only

    kernel_parameters = pass_parameters(parameters)
    write_out = target is not None
    if not write_out:  # never written then, but typed as written: numba refuses a read-only
        target = np.empty((0, 0), values.dtype)  # array there (``values`` may be one)
    plane_pass = PlanePass(
        np.uint64(seed), int(plane_index), int(pass_index), False, float(variance_floor)
    )
    _banded_pass.banded_pass(
        values, target, work, _banded_pass.band_rows(values.shape[1]), pass_index == 0,
        write_out, integer_scale(scale, values.dtype), kernel_parameters, plane_pass, counts,
        changes, pass_kernel_for(kernel_parameters),
    )  # fmt: skip


def _checkerboard_bands(
    labyrinth_pass, tones, kernel_parameters, plane_pass, counts, changes, workers
) -> None:
    """The four colours in turn, the rows of each split among ``workers`` threads."""
    height = tones.shape[0]
    bands = np.linspace(0, height, min(workers, max(1, height // 2)) + 1).astype(int)
    band_counts = padded_counts(len(bands) - 1)
    band_changes = empty_copies(changes, len(bands) - 1)
    for colour in range(4):  # the pixels of one colour are independent of each other
        if len(bands) == 2:
            labyrinth_pass(
                tones, kernel_parameters, plane_pass, PassRegion(colour, 0, height),
                band_counts[0], band_changes[0],
            )  # fmt: skip
            continue
        with ThreadPoolExecutor(len(bands) - 1) as pool:
            futures = []
            for k, (start, stop) in enumerate(itertools.pairwise(bands)):
                region = PassRegion(colour, int(start), int(stop))
                futures.append(
                    pool.submit(
                        labyrinth_pass,
                        tones,
                        kernel_parameters,
                        plane_pass,
                        region,
                        band_counts[k],
                        band_changes[k],
                    )
                )
            for future in futures:
                future.result()
    add_padded_counts(counts, band_counts)
    gather_changes(changes, band_changes)


@functools.lru_cache(maxsize=64)
def pass_parameters(parameters: LabyrinthParameters) -> PassParameters:
    """``parameters`` as the kernels read them: numbers, float64 arrays and option codes."""
    return PassParameters(
        mean_threshold=float(parameters.mean_threshold),
        variance_threshold=float(parameters.variance_threshold),
        range_bounds=np.array(parameters.tone_ranges[1:-1], dtype=np.float64),
        tone_low=np.array([low for low, _ in parameters.tones], dtype=np.float64),
        tone_high=np.array([high for _, high in parameters.tones], dtype=np.float64),
        max_tries=int(parameters.max_tries),
        include_centre=bool(parameters.include_centre),
        **{name: codes[getattr(parameters, name)] for name, codes in OPTION_CODES.items()},
    )


def pass_kernel_for(kernel_parameters: PassParameters):
    """The numba kernel of one pass (``labyrinth_pass``), the variant of ``kernel_parameters``'
    condition order and ``include_centre`` (``core._kernel.pass_kernel``)."""
    from ..core._kernel import pass_kernel  # numba is imported on first use only

    return pass_kernel(kernel_parameters.condition_order, kernel_parameters.include_centre)
