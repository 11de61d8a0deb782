"""One raster pass on several threads, bit for bit the pass of one: the exact-order tiles.

The raster scan updates a pixel after the row above it and the pixel to its
left, before the rest of its neighbourhood. Parallelogram tiles of a band of
rows and a range of diagonals ``x + y`` (:func:`exact_order_tiles`) keep that
order between tiles: :func:`run_exact_order` runs each tile on a thread as
soon as the tiles it reads are done. :func:`exact_order_refusal` says which
scans and borders the tiles cannot follow, :func:`default_tile` how large
the tiles are.
"""

from __future__ import annotations

import heapq
import threading

import numpy as np

from .._threads import start_helper
from ..core._kernel_arguments import WHOLE_PLANE, PassParameters, PassRegion, PlanePass
from ..core.parameters import LabyrinthParameters
from .changes import empty_copies, gather_changes
from .counts import add_padded_counts, padded_counts

#: Planes with fewer pixels run on one thread: the tiles would cost more than they gain.
MIN_PARALLEL_PIXELS = 256 * 256


def exact_order_refusal(parameters: LabyrinthParameters) -> str | None:
    """Why the parallelogram tiles cannot reproduce the scan of ``parameters``; None if they can.

    The tiles need every pixel to read no neighbour outside its 3 x 3
    neighbourhood and, in that neighbourhood, the row above and the pixel to
    its left updated, the rest not yet: the raster scan with the borders
    ``"inside"``, ``"mirror"`` and ``"nearest"`` (each reads its 3 x 3
    neighbourhood, mirrored or repeated onto itself).
    """
    if parameters.scan == "serpentine":
        return "scan='serpentine' runs odd rows right to left, which the tiles cannot follow"
    if parameters.scan != "raster":
        return f"scan={parameters.scan!r} has its own order"
    if parameters.border == "wrap":
        return "border='wrap' makes the first rows and columns neighbours of the last ones"
    return None


def default_tile(
    shape: tuple[int, int], workers: int, parameters: LabyrinthParameters | None = None
) -> tuple[int, int]:
    """``(rows, diagonals)`` of the tiles of a plane for ``workers`` threads.

    Enough bands (16 per worker, up to 64 rows) and tiles per band (up to 2 per
    worker) that the threads soon all run and seldom wait on each other, tiles
    large enough that their cost is small (``benchmarks/bench_parallel.py
    --sections tiles model`` measures both). A pass that tests Eq. 2 first
    (``condition_order="mean_first"``, the paper's) keeps most pixels after
    Eq. 2 alone and costs about a sixth of one that tests Eq. 4 first: its
    bands are twice as tall (8 per worker, up to 128 rows), which halves the
    tiles' cost per pixel (paper, 2048², tiles on one thread, CPU time over
    the serial pass: about 6 % -> 4-5 %; on 2 threads as fast or faster).
    """
    height, width = shape
    cheap = parameters is not None and parameters.condition_order == "mean_first"
    bands = 8 if cheap else 16  # per worker
    rows = int(np.clip(height // (bands * workers), 16, 128 if cheap else 64))
    return rows, int(np.clip(width // (2 * workers), 128, 512))


def exact_order_tiles(
    shape: tuple[int, int], rows: int, diagonals: int, first_row: int = 0
) -> list[list[int]]:
    """The parallelogram tiles of a plane, band by band of ``rows`` rows.

    Tile j of band i holds the pixels with ``i * rows <= y < (i + 1) * rows``
    and ``j * diagonals <= x + y < (j + 1) * diagonals``. In coordinates
    (y, s = x + y) a pixel's neighbours that the raster scan updates before it
    lie at (-1, -2), (-1, -1), (-1, 0) and (0, -1), those it updates after it
    at (0, 1), (1, 0), (1, 1) and (1, 2). So a tile reads tiles (i - 1, j - 1),
    (i - 1, j) and (i, j - 1) updated and tiles (i, j + 1), (i + 1, j) and
    (i + 1, j + 1) not yet, and no other: tile (i, j) may run as soon as
    tile (i - 1, j) (or the whole band above, past its last tile) and tile
    (i, j - 1) are done, beside any other tile. Returns, for every band, the
    indices j of its non-empty tiles. With ``first_row``, the bands and tiles of the rows
    ``first_row <= y < height`` only (band i from row ``first_row + i * rows``).
    """
    height, width = shape
    bands = []
    for row_start in range(first_row, height, rows):
        row_stop = min(height, row_start + rows)
        bands.append(list(range(row_start // diagonals, (row_stop + width - 2) // diagonals + 1)))
    return bands


def run_exact_order(
    labyrinth_pass,
    tones: np.ndarray,
    parameters: PassParameters,
    plane_pass: PlanePass,
    counts: np.ndarray,
    changes: np.ndarray,
    rows: int,
    diagonals: int,
    workers: int,
    window: PassRegion = WHOLE_PLANE,
) -> None:
    """Run the tiles of ``exact_order_tiles`` on threads, each as soon as it may run.

    ``labyrinth_pass`` (a variant of ``core._kernel.labyrinth_pass``) runs over
    ``tones`` with ``parameters`` and ``plane_pass`` in tiles of ``rows`` rows
    and ``diagonals`` diagonals, on at most ``workers`` threads (the caller's
    among them), adding to ``counts`` and ``changes`` as one call over the
    whole plane would.

    The tiles that may run wait in a queue, the upper band first; a free
    thread takes the next one, runs it (the kernel holds no GIL), then queues
    the tiles it freed: the next of its band and the waiting one of the band
    below. A thread with nothing to take sleeps on a condition variable (never
    spins), and a thread that the system holds back holds up only the tiles
    that need its own: the others take the rest of the plane meanwhile. Every
    tile calls the kernel's compiled code for the types of its arguments
    (``_jit.compiled_for``): numba's dispatcher would type its NamedTuples
    again at every call, a few µs a tile.

    ``window`` (its ``row_start``, ``row_stop``, ``row_offset`` and
    ``plane_height``) runs only the rows ``row_start <= y < row_stop`` of a
    plane of which ``tones`` holds the rows from ``row_offset`` on (a band of
    a plane streamed band by band), as one call of the kernel over that
    window would.
    """
    from ..core._jit import compiled_for  # numba is imported on first use only

    rows, diagonals = int(rows), int(diagonals)
    first, offset = window.row_start, window.row_offset
    height = window.row_stop if window.row_stop >= 0 else tones.shape[0] + offset
    tiles = exact_order_tiles((height, tones.shape[1]), rows, diagonals, first)
    bands = len(tiles)
    workers = min(workers, bands)
    position = [0] * bands  # the index in tiles[band] of the band's next tile
    finished = [0] * bands  # the band is done up to (not including) tile j = finished[band]
    waiting = [True] * bands  # neither queued nor running
    ready: list[int] = []  # bands whose next tile may run (a heap: the upper band first)
    remaining = [sum(map(len, tiles))]
    changed = threading.Condition()
    band_counts = padded_counts(workers)
    worker_changes = empty_copies(changes, workers)  # each thread notes its own
    failed: list[BaseException] = []
    kernel = compiled_for(
        labyrinth_pass, tones, parameters, plane_pass, WHOLE_PLANE, band_counts[0],
        worker_changes[0],
    )  # fmt: skip

    def queue_if_ready(band):
        """Queue ``band`` if its next tile may run (called holding ``changed``); 1 if queued."""
        if band >= bands or not waiting[band] or position[band] == len(tiles[band]):
            return 0
        j = tiles[band][position[band]]
        if band == 0 or finished[band - 1] >= min(j, tiles[band - 1][-1]) + 1:
            waiting[band] = False
            heapq.heappush(ready, band)
            return 1
        return 0

    sleeping = [0]  # threads waiting on ``changed``: woken only if there is work for them

    def work(worker):
        own_counts, own_changes = band_counts[worker], worker_changes[worker]
        band = j = -1
        try:
            while True:
                with changed:  # one hold per tile: the last one's end, the next one's start
                    if band >= 0:
                        finished[band] = j + 1
                        position[band] += 1
                        remaining[0] -= 1
                        waiting[band] = True
                        freed = queue_if_ready(band) + queue_if_ready(band + 1)
                        if freed and sleeping[0]:
                            changed.notify(freed)
                    while not ready and remaining[0] and not failed:
                        sleeping[0] += 1
                        changed.wait()
                        sleeping[0] -= 1
                    if failed or not remaining[0]:
                        changed.notify_all()  # the others stop too
                        return
                    band = heapq.heappop(ready)
                    j = tiles[band][position[band]]
                row_start = first + band * rows
                row_stop = min(height, row_start + rows)
                tile = PassRegion(
                    -1, row_start, row_stop, j * diagonals, (j + 1) * diagonals, offset,
                    window.plane_height,
                )  # fmt: skip
                kernel(tones, parameters, plane_pass, tile, own_counts, own_changes)
        except BaseException as error:  # noqa: BLE001 - raised in the caller's thread
            with changed:
                failed.append(error)
                changed.notify_all()

    queue_if_ready(0)
    # only the first tile can run yet: the helpers start without waiting for them to run
    done = [start_helper(work, k) for k in range(1, workers)]
    work(0)
    for lock in done:
        lock.acquire()
    if failed:
        raise failed[0]
    add_padded_counts(counts, band_counts)
    gather_changes(changes, worker_changes)
