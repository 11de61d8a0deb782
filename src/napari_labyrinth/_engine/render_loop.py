"""The render loop: every pass of every plane of an image, on threads, as a generator.

A run is a generator. It yields after every pass of every plane and returns
the rendered array and its diagnostics; closing it (``generator.close()``)
cancels the run: planes in flight stop after their current pass, planes not
started never start, and nothing is left running when ``close`` returns.
The engine knows arrays, layouts and tone scales; argument checking and
presets belong to the API.
"""

from __future__ import annotations

import dataclasses
import math
import queue
import threading
from collections.abc import Generator
from concurrent.futures import ThreadPoolExecutor
from typing import Any

import numpy as np

from .._pages import empty_in_plain_pages
from ..core.noise import tone_noise_sigma, variance_floor
from ..core.parameters import LabyrinthParameters
from ..core.planes import PlaneLayout
from ..core.tone_scale import ToneScale, fits_banded_pass, integer_plane_tones, integer_scale
from .._threads import run_shares
from .changes import new_changes, shares, write_back_changes
from .cores import idle_cores
from .counts import DIAGNOSTICS_DTYPE, diagnostic_counts
from .passes import banded_pass, run_pass
from .tiles import MIN_PARALLEL_PIXELS, default_tile, exact_order_refusal


@dataclasses.dataclass(frozen=True)
class Progress:
    """A progress event of a run: one more pass of one plane is done.

    Attributes
    ----------
    done, total : int
        Plane-passes done so far and in the whole run (every rendering of a
        sweep included; alpha planes are not rendered and not counted).
    run : int
        Which rendering of a sweep (0 otherwise).
    plane : int
        Flat index of the plane among the image's planes (colour axis last).
    pass_number : int
        Passes done on that plane, from 1.
    partial : ndarray or None
        The array this rendering fills, as :func:`render` returns it: with
        ``record_passes`` (stack mode) the plane after this pass is already in
        it, at index ``pass_number``; otherwise a plane lands in it after its
        last pass. Read it, never write to it.
    tone_limits : (float, float) or None
        The values the run maps to tones 0 and 255 (``Result.tone_limits``):
        what the passes so far look like on the tone scale they ran on, as the
        metrics read them (:meth:`~napari_labyrinth.core.tone_scale.ToneScale.to_tones`).
    """

    done: int
    total: int
    run: int
    plane: int
    pass_number: int
    partial: Any = dataclasses.field(default=None, repr=False, compare=False)
    tone_limits: tuple[float, float] | None = None


def render(
    image: np.ndarray,
    layout: PlaneLayout,
    scale: ToneScale,
    parameters: LabyrinthParameters,
    seed: int,
    *,
    record_passes: bool,
    workers: int = 1,
    noise_sigmas: np.ndarray | None = None,
) -> Generator[tuple[int, int, np.ndarray], None, tuple[np.ndarray, np.ndarray]]:
    """Render every plane of ``image``; yield ``(plane, pass_number, result)`` after each pass.

    With the noise gate on (``parameters.noise_gate > 0``) each plane's noise
    in tones is ``noise_sigmas[index]`` (an array of ``layout.leading_shape``),
    or measured on the plane's values before its passes
    (``core.noise.tone_noise_sigma``) when not given.

    With several planes and ``workers > 1`` planes run concurrently on
    threads (the kernel holds no GIL); the workers left over (all of them
    for a single plane) go to each plane's :func:`run_pass`: its exact-order
    tiles or checkerboard bands. Returns (as the generator's
    value) the rendered image, or with ``record_passes`` the input followed by
    the image after every pass, and the diagnostics in the image's layout.
    """
    passes = parameters.passes
    source = layout.to_planes(image)
    leading = layout.leading_shape
    counts = diagnostic_counts(layout, passes)
    planes = list(layout.rendered_indices())
    plane_workers = max(1, min(workers, len(planes)))
    banded = _banded_render(image, source, planes, parameters, max(1, workers // plane_workers))
    result, targets = _allocate(image, layout, passes, record_passes, written_whole=banded)
    stop = threading.Event()

    def passes_of(index):
        """Every pass over one plane, yielding after each; stops early once ``stop`` is set."""
        if not passes:
            return
        values = source[index]
        floor = -1.0  # the noise gate's floor (core.noise.variance_floor): off
        if parameters.noise_gate > 0:
            if noise_sigmas is None:  # measured here, on the plane's threads
                sigma = tone_noise_sigma(values, scale, workers=max(1, workers // plane_workers))
            else:
                sigma = noise_sigmas[index]
            floor = variance_floor(parameters.noise_gate, float(sigma))
        if banded:  # tones in and values out, band of rows by band of rows
            work = _banded_tones(values.shape, passes == 1 and not record_passes, parameters)
            changes = new_changes(values.size)
            for pass_index in range(passes):
                if stop.is_set():
                    return
                write_out = record_passes or pass_index == passes - 1
                banded_pass(
                    values,
                    targets[pass_index if record_passes else 0][index] if write_out else None,
                    work,
                    scale,
                    parameters,
                    seed=seed,
                    plane_index=layout.stream_index(index),
                    pass_index=pass_index,
                    counts=counts[(pass_index,) + index],
                    changes=changes,
                    variance_floor=floor,
                )
                yield pass_index + 1
            return
        # integer planes: tones in one pass, and no copy of them kept (see write_back_changes);
        # a plane on several threads (its tiles) makes and writes them on those threads
        threads = _plane_threads(values, max(1, workers // plane_workers))
        work = _integer_tones(scale, values, threads)
        initial = changes = None
        if work is None:
            initial = np.ascontiguousarray(scale.to_tones(values))
            work = initial.copy()
        else:  # the pixels the passes write, for a write-back that visits only them
            changes = new_changes(work.size)
        has_nonfinite = image.dtype.kind == "f" and not np.isfinite(work).all()
        for pass_index in range(passes):
            if stop.is_set():
                return
            run_pass(
                work,
                parameters,
                seed=seed,
                plane_index=layout.stream_index(index),
                pass_index=pass_index,
                counts=counts[(pass_index,) + index],
                has_nonfinite=has_nonfinite,
                workers=max(1, workers // plane_workers),  # spare threads: tiles
                changes=changes,
                variance_floor=floor,
            )
            if record_passes:
                write_back_changes(
                    targets[pass_index][index], values, initial, work, scale, changes, threads
                )
            yield pass_index + 1
        if not record_passes and passes:
            write_back_changes(targets[0][index], values, initial, work, scale, changes, threads)

    flat = {index: int(np.ravel_multi_index(index, leading)) if index else 0 for index in planes}
    if plane_workers == 1:
        for index in planes:
            for pass_number in passes_of(index):
                yield flat[index], pass_number, result
    else:
        for plane, pass_number in _on_threads(
            planes, passes, passes_of, flat, plane_workers, stop
        ):
            yield plane, pass_number, result
    diagnostics = layout.to_image_layout(counts.view(DIAGNOSTICS_DTYPE)[..., 0])
    return result, np.ascontiguousarray(diagnostics)


def _allocate(
    image: np.ndarray,
    layout: PlaneLayout,
    passes: int,
    record_passes: bool,
    *,
    written_whole: bool = False,
):
    """The result (a copy of the image, or the input and a copy per pass) and, in the
    layout of planes, where each pass (or the last) is written. A large result is
    in plain pages (``_pages``): its first touches, made by the render threads,
    must not stall a GUI's event loop.

    ``written_whole``: the passes write every pixel of the planes they render
    (the banded pass), so only the others (alpha) are copied there.
    """
    if record_passes:
        result = empty_in_plain_pages((passes + 1,) + image.shape, image.dtype)
        if written_whole:
            result[0] = image
        else:
            result[...] = image
        targets = [layout.to_planes(result[k]) for k in range(1, passes + 1)]
    else:
        result = empty_in_plain_pages(image.shape, image.dtype)
        if not written_whole:
            result[...] = image
        targets = [layout.to_planes(result)]
    if written_whole:
        source = layout.to_planes(image)
        for index in np.ndindex(layout.leading_shape):
            if layout.is_alpha(index):
                for target in targets:
                    target[index] = source[index]
    return result, targets


def _banded_render(image, source, planes, parameters, plane_threads) -> bool:
    """Whether every plane renders on one thread by ``passes.banded_pass``: integer planes that
    are C-contiguous, in an order of rows (not the checkerboard), not in tiles."""
    if not parameters.passes or not planes or image.dtype.kind not in "iu":
        return False
    if parameters.scan == "checkerboard":
        return False
    if plane_threads > 1 and exact_order_refusal(parameters) is None:
        shape = source.shape[-2:]
        rows = default_tile(shape, 2, parameters)[0]
        if math.prod(shape) >= MIN_PARALLEL_PIXELS and shape[0] > rows:
            return False  # the plane's passes may run in tiles on several threads
    return all(fits_banded_pass(source[index]) for index in planes)


def _plane_threads(values: np.ndarray, spare: int) -> int:
    """The threads that make a plane's tones and write its values: its ``spare`` workers,
    no more than ``idle_cores`` (as its tiles take), one for a plane under
    ``MIN_PARALLEL_PIXELS``."""
    if spare <= 1 or values.size < MIN_PARALLEL_PIXELS:
        return 1
    return max(1, min(spare, idle_cores()))


def _integer_tones(scale: ToneScale, values: np.ndarray, threads: int) -> np.ndarray | None:
    """``integer_plane_tones(scale, values)``, the rows shared by ``threads`` threads (the
    first touches of the new plane of tones too)."""
    if threads <= 1 or not fits_banded_pass(values):
        return integer_plane_tones(scale, values)
    from ..core._tone_loops import integer_tones  # numba is imported on first use only

    tones = np.empty(values.shape, dtype=np.float32)
    bounds = shares(values.shape[0], threads)
    fused = integer_scale(scale, values.dtype)

    def share(k):
        rows = slice(bounds[k], bounds[k + 1])
        integer_tones(values[rows], tones[rows], fused)

    run_shares(share, len(bounds) - 1)
    return tones


def _banded_tones(shape, only_pass, parameters) -> np.ndarray:
    """The float32 tones ``passes.banded_pass`` updates: a ring of one band of rows and the rows
    around it for the only pass of a plane (any border but "wrap"), else a whole plane."""
    from ..core._banded_pass import band_rows  # numba is imported on first use only

    rows = band_rows(shape[1]) + 2
    if only_pass and parameters.border != "wrap" and rows < shape[0]:
        return np.empty((rows, shape[1]), dtype=np.float32)
    return np.empty(shape, dtype=np.float32)


def _on_threads(planes, passes, passes_of, flat, plane_workers, stop):
    """Run ``passes_of(plane)`` for every plane on a pool; yield as passes finish."""
    finished: queue.SimpleQueue = queue.SimpleQueue()  # (plane, pass) or an error

    def run(index):
        try:
            for pass_number in passes_of(index):
                finished.put((flat[index], pass_number))
        except BaseException as error:  # noqa: BLE001 - raised in the caller's thread
            finished.put(error)

    expected = len(planes) * passes
    pool = ThreadPoolExecutor(plane_workers, thread_name_prefix="napari-labyrinth")
    try:
        for index in planes:
            pool.submit(run, index)
        for _ in range(expected):
            item = finished.get()
            if isinstance(item, BaseException):
                raise item
            yield item
    finally:  # done, failed, or closed by the caller: nothing is left running
        stop.set()
        pool.shutdown(wait=True, cancel_futures=True)


def run_to_end(steps: Generator[Any, None, Any]) -> Any:
    """Run a generator to its end and return its value (the result of :func:`render`)."""
    while True:
        try:
            next(steps)
        except StopIteration as finished:
            return finished.value
