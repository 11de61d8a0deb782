"""Threads: one plane in the paper's exact order, planes in parallel. Prints, asserts nothing.

Sections (all by default; ``--sections`` picks some):

- ``exact``: one plane, one pass in raster order: the serial kernel, the
  parallelogram tiles forced onto 1 thread (their overhead) and, as
  ``labyrinth()`` runs them, on 2 (and every core; ``run_pass`` with its
  default tiles, which takes no more threads than ``_engine.idle_cores()``),
  interleaved, best and median of ``--repeats``; at 2048² and ``--big``²
  (8192²); the best process CPU time of each variant (all its threads) and
  its excess over the serial pass (for ``1 thr``: what the tiles themselves
  cost); the speed-up one run in ten falls below (``slowest 10%``: how
  reliable it is); bit-identity of every variant with the serial pass. On a
  busy machine the best of a few runs favours one thread (one thread is
  more likely to get a whole pass undisturbed than two at once): read the
  medians too.
- ``loaded``: the same at 2048² while another process keeps one core busy
  (a plain Python loop started here and stopped after); the idle cores seen
  before each section are printed.
- ``tiles``: tile-size sensitivity, 2 threads, rows x diagonals.
- ``model``: the time of every tile measured on one thread, then the
  schedule of ``_engine.tiles.run_exact_order`` simulated on 1 to 16 cores (each band
  on its worker, each tile after the one to its left and the one above, the
  measured per-tile overhead added): predicted speed-ups, wave counts.
- ``stack``: a ``--planes`` x 1024² uint16 stack, 1 thread against every core.
- ``checkerboard``: one ``--big``² plane in checkerboard order (not the
  paper's) on 1 and every thread, and its pattern against the raster scan's.

``--presets paper`` limits the exact, loaded and tiles sections to one
preset (e.g. ``--sections exact tiles --presets paper --repeats 25``).

The load average is printed beside the figures: on a shared machine
compare ratios of interleaved variants, and re-run on a quiet one with
``make bench-speed``.
"""

from __future__ import annotations

import argparse
import contextlib
import heapq
import os
import subprocess
import sys
import time

import numpy as np


#: The presets the sections measure by default (``--presets``).
PRESETS = ("labyrinth", "paper")


def load():
    return "load %.2f %.2f %.2f" % os.getloadavg()


def textured_stack(planes: int, size: int) -> np.ndarray:
    """A uint16 stack of shifted, rescaled camera images (real work for the kernel)."""
    from skimage import data, transform

    base = transform.resize(data.camera(), (size, size), order=1, preserve_range=True)
    base = (base * 200).astype(np.uint16)
    stack = np.empty((planes, size, size), np.uint16)
    for k in range(planes):
        stack[k] = np.roll(base, (7 * k, 13 * k), axis=(0, 1))
    return stack


def tones_of(size: int) -> np.ndarray:
    from napari_labyrinth.core.tone_scale import ToneScale

    return ToneScale(0, 51000).to_tones(textured_stack(1, size)[0])


def timed(function, repeats=1, clock=time.perf_counter):
    best = float("inf")
    for _ in range(repeats):
        start = clock()
        result = function()
        best = min(best, clock() - start)
    return best, result


def tiled_pass(tones, parameters, workers, tile):
    """One pass of the exact-order tiles on ``workers`` threads (1 included), in place."""
    from napari_labyrinth._engine import new_changes
    from napari_labyrinth._engine.passes import pass_kernel_for, pass_parameters
    from napari_labyrinth._engine.tiles import run_exact_order
    from napari_labyrinth.core._kernel_arguments import PlanePass
    from napari_labyrinth.core.codes import DIAGNOSTIC_FIELDS

    kernel_parameters = pass_parameters(parameters)
    labyrinth_pass = pass_kernel_for(kernel_parameters)
    counts = np.zeros(len(DIAGNOSTIC_FIELDS), np.int64)
    plane_pass = PlanePass(np.uint64(0), 0, 0, False)
    run_exact_order(
        labyrinth_pass, tones, kernel_parameters, plane_pass, counts, new_changes(0), *tile,
        workers,
    )  # fmt: skip
    return counts


def compare_threads(tones, parameters, repeats, thread_counts):
    """Serial kernel, tiles on 1 thread and on each of ``thread_counts``, interleaved."""
    from napari_labyrinth._engine import default_tile, run_pass

    reference = tones.copy()
    reference_counts = run_pass(reference, parameters, has_nonfinite=False)
    variants = {"serial": lambda t: run_pass(t, parameters, has_nonfinite=False)}
    for workers in thread_counts:
        if workers == 1:  # the tiles' own cost: forced onto one thread
            tile = default_tile(tones.shape, workers, parameters)
            variants["1 thr"] = lambda t, tile=tile: tiled_pass(t, parameters, 1, tile)
        else:  # as labyrinth() runs them: default tiles, no more threads than idle cores
            variants[f"{workers} thr"] = lambda t, w=workers: run_pass(
                t, parameters, has_nonfinite=False, workers=w
            )
    seconds = {name: [] for name in variants}
    cpu = {name: [] for name in variants}  # of every thread of the process
    same = dict.fromkeys(variants, True)
    for _ in range(repeats):
        for name, run in variants.items():
            work = tones.copy()
            start, start_cpu = time.perf_counter(), time.process_time()
            counts = run(work)
            cpu[name].append(time.process_time() - start_cpu)
            seconds[name].append(time.perf_counter() - start)
            same[name] &= np.array_equal(work.view(np.uint32), reference.view(np.uint32))
            same[name] &= np.array_equal(counts, reference_counts)
    return seconds, cpu, same


def print_threads(title, tones, parameters, repeats, thread_counts):
    from napari_labyrinth._engine import default_tile

    times, cpu, same = compare_threads(tones, parameters, repeats, thread_counts)
    serial, serial_median = min(times["serial"]), np.median(times["serial"])
    serial_cpu = min(cpu["serial"])
    print(title)
    print(
        f"{'variant':<10}{'tile':>10}{'best ms':>9}{'Mpx/s':>8}{'vs serial':>11}"
        f"{'median ms':>11}{'vs serial':>11}{'slowest 10%':>12}{'CPU ms':>8}{'CPU +%':>8}"
        f"{'same':>6}"
    )
    for name, runs in times.items():
        workers = 1 if name == "serial" else int(name.split()[0])
        tile = default_tile(tones.shape, workers, parameters)
        tile = "-" if name == "serial" else "%dx%d" % tile
        best, median = min(runs), np.median(runs)
        print(
            f"{name:<10}{tile:>10}{best * 1e3:>9.1f}{tones.size / best / 1e6:>8.0f}"
            f"{serial / best:>10.2f}x{median * 1e3:>11.1f}{serial_median / median:>10.2f}x"
            f"{serial_median / np.percentile(runs, 90):>11.2f}x{min(cpu[name]) * 1e3:>8.1f}"
            f"{100 * (min(cpu[name]) / serial_cpu - 1):>+8.1f}"
            f"{'yes' if same[name] else 'NO':>6}"
        )
    from napari_labyrinth._engine import idle_cores

    print(
        f"({load()}; idle cores seen by labyrinth() now: {idle_cores()}; slowest 10%: the"
        " serial median over the 90th percentile of the variant's times, the speed-up one run"
        " in ten falls below; CPU: best process CPU time of all threads, +% over the serial"
        " pass: for 1 thr the tiles' own cost)"
    )


@contextlib.contextmanager
def busy_core():
    """Another process keeping one core busy (a Python loop), stopped on exit."""
    process = subprocess.Popen([sys.executable, "-c", "while True: pass"])
    try:
        time.sleep(0.5)
        yield process
    finally:
        process.kill()  # the process started above, by its handle
        process.wait()


def bench_exact(sizes, repeats, cores, presets=PRESETS):
    from napari_labyrinth import resolve_parameters

    thread_counts = sorted({1, 2, cores})
    for preset in presets:
        parameters = resolve_parameters(preset)
        for size in sizes:
            tones = tones_of(size)
            print_threads(
                f"exact order, one {size}^2 plane, preset {preset!r}, 1 pass "
                f"(best of {repeats}, interleaved)",
                tones,
                parameters,
                repeats if size <= 4096 else max(2, repeats // 3),
                thread_counts,
            )
            print()


def bench_loaded(repeats, cores, presets=PRESETS):
    from napari_labyrinth import resolve_parameters

    tones = tones_of(2048)
    with busy_core() as process:
        for preset in presets:
            print_threads(
                f"exact order, 2048^2, preset {preset!r}, while process {process.pid} keeps a "
                "core busy",
                tones,
                resolve_parameters(preset),
                repeats,
                sorted({1, 2, cores}),
            )
            print()


def bench_tiles(repeats, presets=PRESETS):
    from napari_labyrinth import resolve_parameters
    from napari_labyrinth._engine import run_pass

    tones = tones_of(2048)
    repeats = max(3, repeats)
    for preset in presets:
        parameters = resolve_parameters(preset)
        serial, _ = timed(
            lambda: run_pass(tones.copy(), parameters, has_nonfinite=False), repeats
        )
        diagonals = (64, 128, 256, 512, 1024)
        print(
            f"tile sizes, 2048^2, preset {preset!r}, 2 threads: speed-up over the serial pass"
            f" (best of {repeats})"
        )
        print(f"{'rows | diagonals':<18}" + "".join(f"{d:>8}" for d in diagonals))
        for rows in (8, 16, 32, 64, 128):
            line = f"{rows:<18}"
            for d in diagonals:
                seconds, _ = timed(
                    lambda: tiled_pass(tones.copy(), parameters, 2, (rows, d)), repeats
                )
                line += f"{serial / seconds:>7.2f}x"
            print(line)
        print(f"({load()})")
        print()


def tile_times(tones, parameters, tile):
    """CPU seconds of every tile, run one after the other on this thread (band by band)."""
    from napari_labyrinth._engine import exact_order_tiles, new_changes
    from napari_labyrinth._engine.passes import pass_kernel_for, pass_parameters
    from napari_labyrinth.core._kernel_arguments import PassRegion, PlanePass
    from napari_labyrinth.core.codes import DIAGNOSTIC_FIELDS

    kernel_parameters = pass_parameters(parameters)
    labyrinth_pass = pass_kernel_for(kernel_parameters)
    rows, diagonals = tile
    height = tones.shape[0]
    tiles = exact_order_tiles(tones.shape, rows, diagonals)
    plane_pass = PlanePass(np.uint64(0), 0, 0, False)
    counts = np.zeros(len(DIAGNOSTIC_FIELDS), np.int64)
    changes = new_changes(0)
    times = []
    for band, js in enumerate(tiles):
        row_start, row_stop = band * rows, min(height, (band + 1) * rows)
        band_times = []
        for j in js:
            start = time.thread_time()
            tile = PassRegion(-1, row_start, row_stop, j * diagonals, (j + 1) * diagonals)
            labyrinth_pass(tones, kernel_parameters, plane_pass, tile, counts, changes)
            band_times.append(time.thread_time() - start)
        times.append(band_times)
    return tiles, times


def simulate(tiles, times, workers, overhead):
    """Finish time of ``tiles.run_exact_order``'s schedule on ``workers`` cores, from tile times.

    The same rules: a band's next tile may run once the band above is done up
    to it; a free core takes the upper ready band's tile; ``overhead`` is added
    to every tile.
    """
    bands = len(tiles)
    position, finished, waiting = [0] * bands, [0] * bands, [True] * bands
    ready, running = [], []

    def queue_if_ready(band):
        if band >= bands or not waiting[band] or position[band] == len(tiles[band]):
            return
        j = tiles[band][position[band]]
        if band == 0 or finished[band - 1] >= min(j, tiles[band - 1][-1]) + 1:
            waiting[band] = False
            heapq.heappush(ready, band)

    queue_if_ready(0)
    now, idle, remaining = 0.0, workers, sum(map(len, tiles))
    while remaining:
        while idle and ready:
            band = heapq.heappop(ready)
            seconds = times[band][position[band]] + overhead
            heapq.heappush(running, (now + seconds, band))
            idle -= 1
        now, band = heapq.heappop(running)
        finished[band] = tiles[band][position[band]] + 1
        position[band] += 1
        waiting[band] = True
        remaining -= 1
        idle += 1
        queue_if_ready(band)
        queue_if_ready(band + 1)
    return now


def bench_model(sizes, repeats):
    from napari_labyrinth import resolve_parameters
    from napari_labyrinth._engine import default_tile, run_pass

    print("model: tile CPU times measured on one thread, the schedule simulated on N cores")
    print(
        f"{'preset':<10}{'size':>6}{'cores':>6}{'tile':>9}{'bands':>6}{'waves':>6}"
        f"{'tiles':>7}{'serial ms':>10}{'model ms':>9}{'speed-up':>9}{'bound':>7}"
    )
    for preset in ("labyrinth", "paper"):
        parameters = resolve_parameters(preset)
        for size in sizes:
            tones = tones_of(size)
            serial, _ = timed(
                lambda: run_pass(tones.copy(), parameters, has_nonfinite=False),
                repeats,
                time.thread_time,
            )
            for workers in (1, 2, 4, 8, 16):
                tile = default_tile(tones.shape, workers, parameters)
                best = None
                for _ in range(max(2, repeats // 2)):  # the fastest run of each tile
                    tiles, times = tile_times(tones.copy(), parameters, tile)
                    best = times if best is None else [
                        [min(a, b) for a, b in zip(x, y)] for x, y in zip(best, times)
                    ]
                n_tiles = sum(map(len, tiles))
                # the per-tile cost of the threads (waking, Python), from the 1-thread run
                one, _ = timed(
                    lambda: tiled_pass(tones.copy(), parameters, 1, tile),
                    repeats,
                    time.thread_time,
                )
                overhead = max(0.0, (one - sum(map(sum, best))) / n_tiles)
                model = simulate(tiles, best, workers, overhead)
                waves = len(tiles) + max(len(js) for js in tiles) - 1
                bound = sum(map(sum, best)) / workers  # perfect division of the work
                print(
                    f"{preset:<10}{size:>6}{workers:>6}{'%dx%d' % tile:>9}{len(tiles):>6}"
                    f"{waves:>6}{n_tiles:>7}{serial * 1e3:>10.1f}{model * 1e3:>9.1f}"
                    f"{serial / model:>8.2f}x{serial / bound:>6.1f}x"
                )
    print(
        "(CPU times, little disturbed by a busy machine; serial: the one-call pass; bound: the"
        f" speed-up if the tiles' work divided perfectly; {load()})"
    )
    print()


def bench_stack(planes: int, size: int, cores: int) -> None:
    from napari_labyrinth import labyrinth

    stack = textured_stack(planes, size)
    limits = (0, 51000)
    labyrinth(stack[:2], passes=1, tone_limits=limits)  # compile
    print(f"{planes} x {size}^2 uint16 stack, preset 'labyrinth' with 1 pass")
    print(f"{'threads':>8}{'seconds':>10}{'planes/s':>10}{'Mpx/s':>9}{'speed-up':>10}")
    outputs, seconds = {}, {}
    for workers in sorted({1, cores}):
        seconds[workers], outputs[workers] = timed(
            lambda w=workers: labyrinth(stack, passes=1, tone_limits=limits, workers=w)
        )
        print(
            f"{workers:>8}{seconds[workers]:>10.2f}{planes / seconds[workers]:>10.1f}"
            f"{stack.size / seconds[workers] / 1e6:>9.0f}{seconds[1] / seconds[workers]:>9.2f}x"
        )
    print("bit-identical across thread counts:", np.array_equal(outputs[1], outputs[cores]))
    print(f"({load()})")
    print()


def bench_checkerboard(size: int, cores: int) -> None:
    from napari_labyrinth import labyrinth, metrics

    big = textured_stack(1, size)[0]
    limits = (0, 51000)
    print(f"one {size}^2 uint16 plane, preset 'labyrinth' with 1 pass")
    print(f"{'scan':<14}{'threads':>8}{'seconds':>10}{'Mpx/s':>9}")
    outputs = {}
    for scan, workers in [("raster", 1), ("raster", cores), ("checkerboard", 1),
                          ("checkerboard", cores)]:  # fmt: skip
        labyrinth(big[:64, :64], passes=1, scan=scan, tone_limits=limits)  # compile
        seconds, outputs[(scan, workers)] = timed(
            lambda s=scan, w=workers: labyrinth(
                big, passes=1, scan=s, tone_limits=limits, workers=w
            ),
            repeats=2,
        )
        print(f"{scan:<14}{workers:>8}{seconds:>10.2f}{big.size / seconds / 1e6:>9.0f}")
    same = np.array_equal(outputs[("checkerboard", 1)], outputs[("checkerboard", cores)])
    print("checkerboard bit-identical across thread counts:", same)
    same = np.array_equal(outputs[("raster", 1)], outputs[("raster", cores)])
    print("raster (exact-order tiles) bit-identical across thread counts:", same)

    centre = size // 2
    crop = (slice(centre - 512, centre + 512), slice(centre - 512, centre + 512))
    print("pattern, raster against checkerboard (central 1024^2 of the big plane, 1 pass):")
    raster = metrics.describe(big[crop], outputs[("raster", 1)][crop])
    checker = metrics.describe(big[crop], outputs[("checkerboard", 1)][crop])
    print(f"{'metric':<24}{'raster':>10}{'checkerboard':>14}")
    for name in raster:
        print(f"{name:<24}{raster[name]:>10.3f}{checker[name]:>14.3f}")
    print(f"({load()})")


SECTIONS = ("exact", "loaded", "tiles", "model", "stack", "checkerboard")


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--sections", nargs="+", choices=SECTIONS, default=list(SECTIONS))
    parser.add_argument("--repeats", type=int, default=5)
    parser.add_argument("--planes", type=int, default=200)
    parser.add_argument("--size", type=int, default=1024)
    parser.add_argument("--big", type=int, default=8192)
    parser.add_argument(
        "--presets", nargs="+", choices=PRESETS, default=list(PRESETS),
        help="presets of the exact, loaded and tiles sections",
    )  # fmt: skip
    args = parser.parse_args(argv)
    cores = os.cpu_count() or 1
    print(f"{cores} cores, {load()}")
    print()
    if "exact" in args.sections:
        bench_exact((2048, args.big), args.repeats, cores, args.presets)
    if "loaded" in args.sections:
        bench_loaded(args.repeats, cores, args.presets)
    if "tiles" in args.sections:
        bench_tiles(args.repeats, args.presets)
    if "model" in args.sections:
        bench_model((2048, args.big), args.repeats)
    if "stack" in args.sections:
        bench_stack(args.planes, args.size, cores)
    if "checkerboard" in args.sections:
        bench_checkerboard(args.big, cores)


if __name__ == "__main__":
    main()
