"""Threads: planes in parallel and the checkerboard order. Prints figures, asserts nothing.

- a 200 x 1024^2 uint16 stack, 1 thread against every core (target >= 1.8x);
- one 8192^2 plane in checkerboard order, 1 against 2 threads, and the raster
  scan for reference;
- how close the checkerboard pattern is to the raster scan's (metrics).

Run: ``python benchmarks/bench_parallel.py [--planes 200] [--size 1024] [--big 8192]``.
"""

from __future__ import annotations

import argparse
import os
import time

import numpy as np


def textured_stack(planes: int, size: int) -> np.ndarray:
    """A uint16 stack of shifted, rescaled camera images (real work for the kernel)."""
    from skimage import data, transform

    base = transform.resize(data.camera(), (size, size), order=1, preserve_range=True)
    base = (base * 200).astype(np.uint16)
    stack = np.empty((planes, size, size), np.uint16)
    for k in range(planes):
        stack[k] = np.roll(base, (7 * k, 13 * k), axis=(0, 1))
    return stack


def timed(function, repeats=1):
    best = float("inf")
    for _ in range(repeats):
        start = time.perf_counter()
        result = function()
        best = min(best, time.perf_counter() - start)
    return best, result


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


def bench_big_plane(size: int, cores: int) -> None:
    from napari_labyrinth import labyrinth, metrics

    big = textured_stack(1, size)[0]
    limits = (0, 51000)
    print(f"one {size}^2 uint16 plane, preset 'labyrinth' with 1 pass")
    print(f"{'scan':<14}{'threads':>8}{'seconds':>10}{'Mpx/s':>9}")
    outputs = {}
    for scan, workers in [("raster", 1), ("checkerboard", 1), ("checkerboard", cores)]:
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

    centre = size // 2
    crop = (slice(centre - 512, centre + 512), slice(centre - 512, centre + 512))
    print("pattern, raster against checkerboard (central 1024^2 of the big plane, 1 pass):")
    raster = metrics.describe(big[crop], outputs[("raster", 1)][crop])
    checker = metrics.describe(big[crop], outputs[("checkerboard", 1)][crop])
    print(f"{'metric':<24}{'raster':>10}{'checkerboard':>14}")
    for name in raster:
        print(f"{name:<24}{raster[name]:>10.3f}{checker[name]:>14.3f}")


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--planes", type=int, default=200)
    parser.add_argument("--size", type=int, default=1024)
    parser.add_argument("--big", type=int, default=8192)
    args = parser.parse_args(argv)
    cores = os.cpu_count() or 1
    bench_stack(args.planes, args.size, cores)
    print()
    bench_big_plane(args.big, cores)


if __name__ == "__main__":
    main()
