"""Warm speed of the shipped kernels against numba's compile for this machine. Prints only.

Two processes of the same install stay up side by side: ``shipped`` loads the kernels the
platform wheel carries (compiled for its portable target, x86-64-v3 on x86_64) and
``host`` has them off (``NAPARI_LABYRINTH_SHIPPED_KERNELS=0``: numba compiles for this
CPU, once, before the timing). The parent asks each in turn to time one call of a row,
``--repeats`` rounds with the order alternating, and keeps each one's best: a load that
comes and goes falls on both alike.

The rows are those of ``make bench-speed`` that run the package's kernels:
``bench_kernel.py``'s kernel pass and ``labyrinth()`` (one worker) per preset, dtype and
pass count on the camera image, and on its seventeen other images (``--images``); then
``bench_parallel.py``'s exact-order pass on 1 and 2 threads (2048² and ``--big``²) and its
tile sizes (2048², 2 threads). ``metrics.describe`` of 2048² is added. Figures are
milliseconds and the ratio shipped / host (above 1: the shipped code is slower). The
``C`` reference of ``bench_kernel.py`` compiles no kernel and is left out; so is the
``loaded`` section, which runs these same passes beside a busy process.

Run with the Python of an install that carries the kernels (``make test-wheel`` makes
one: ``build/wheel-venv/bin/python benchmarks/bench_shipped_speed.py``).
"""

from __future__ import annotations

import argparse
import json
import os
import pathlib
import shutil
import subprocess
import sys
import tempfile
import time

import numpy as np

HERE = pathlib.Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))

PRESETS = ("paper", "labyrinth")
TILE_ROWS = (8, 16, 32, 64, 128)
TILE_DIAGONALS = (64, 128, 256, 512, 1024)


def rows(size: int, big: int, images: bool) -> list[str]:
    names = []
    for preset in PRESETS:
        for dtype in ("uint8", "uint16"):
            for passes in (1, 4):
                names += [f"kernel {preset} {dtype} {passes}", f"api {preset} {dtype} {passes}"]
    if images:
        from bench_kernel import other_images

        for image in other_images(64):
            for preset in PRESETS:
                names += [f"image-kernel {preset} {image}", f"image-api {preset} {image}"]
    for preset in PRESETS:
        for side in (size, big):
            for threads in (1, 2):
                names.append(f"exact {preset} {side} {threads}")
        for tile_rows in TILE_ROWS:
            for diagonals in TILE_DIAGONALS:
                names.append(f"tile {preset} {tile_rows} {diagonals}")
    names.append(f"describe {size}")
    return names


# -- the child: holds its inputs, times one call of a row at a time ----------------------


class Child:
    def __init__(self, size: int):
        self.size = size
        self.inputs: dict = {}
        self.images = None

    def _input(self, key, make):
        if key not in self.inputs:
            self.inputs[key] = make()
        return self.inputs[key]

    def call(self, row: str):
        """(prepare, run) of ``row``: ``prepare()`` untimed, its result ``run``'s argument."""
        from bench_kernel import camera, other_images
        from bench_parallel import tiled_pass, tones_of

        from napari_labyrinth import labyrinth, metrics, resolve_parameters
        from napari_labyrinth._engine import run_pass
        from napari_labyrinth.core.tone_scale import resolve_tone_scale

        kind, *fields = row.split()
        if kind in ("kernel", "api"):
            preset, dtype, passes = fields[0], np.dtype(fields[1]), int(fields[2])
            image = self._input(("camera", dtype.name), lambda: camera(self.size, dtype.type))
            if kind == "api":
                return image.copy, lambda x: labyrinth(x, preset=preset, passes=passes, workers=1)
            tones = self._input(("tones", dtype.name),
                                lambda: resolve_tone_scale(image, None).to_tones(image))  # fmt: skip
            parameters = resolve_parameters(preset, passes=passes)

            def kernel(work):
                for pass_index in range(passes):
                    run_pass(work, parameters, pass_index=pass_index, has_nonfinite=False)

            return tones.copy, kernel
        if kind in ("image-kernel", "image-api"):
            preset, name = fields[0], " ".join(fields[1:])
            if self.images is None:
                self.images = other_images(self.size)
            image = self.images[name]
            if kind == "image-api":
                return image.copy, lambda x: labyrinth(x, preset=preset, passes=1, workers=1)
            tones = self._input(("image-tones", name),
                                lambda: resolve_tone_scale(image, None).to_tones(image))  # fmt: skip
            parameters = resolve_parameters(preset, passes=1)
            return tones.copy, lambda work: run_pass(work, parameters, has_nonfinite=False)
        if kind == "exact":
            preset, side, threads = fields[0], int(fields[1]), int(fields[2])
            from napari_labyrinth._engine import default_tile

            tones = self._input(("textured", side), lambda: tones_of(side))
            parameters = resolve_parameters(preset)
            tile = default_tile(tones.shape, threads, parameters)
            return tones.copy, lambda work: tiled_pass(work, parameters, threads, tile)
        if kind == "tile":
            preset, tile = fields[0], (int(fields[1]), int(fields[2]))
            tones = self._input(("textured", 2048), lambda: tones_of(2048))
            parameters = resolve_parameters(preset)
            return tones.copy, lambda work: tiled_pass(work, parameters, 2, tile)
        if kind == "describe":
            image = self._input(("camera", "uint8"), lambda: camera(self.size, np.uint8))
            rendered = self._input(("rendered",), lambda: labyrinth(image))
            return (lambda: None), lambda _: metrics.describe(image, rendered)
        raise ValueError(row)

    def time(self, row: str) -> float:
        prepare, run = self.call(row)
        argument = prepare()
        start = time.perf_counter()
        run(argument)
        return time.perf_counter() - start


def child_main(size: int) -> int:
    child = Child(size)
    for line in sys.stdin:
        request = json.loads(line)
        if "warm" in request:
            for row in request["warm"]:
                child.time(row)
            answer = {"warmed": True}
        else:
            answer = {"seconds": child.time(request["row"])}
        from napari_labyrinth.core._shipped import shipped

        answer["refused"] = shipped().refused
        print(json.dumps(answer), flush=True)
    return 0


# -- the parent ------------------------------------------------------------------------


class Process:
    def __init__(self, label: str, size: int, switch_off: bool):
        self.label = label
        self.cache = pathlib.Path(tempfile.mkdtemp(prefix=f"shipped-speed-{label}-"))
        env = dict(os.environ, NUMBA_CACHE_DIR=str(self.cache))
        env.pop("NUMBA_CPU_NAME", None)
        env.pop("NUMBA_CPU_FEATURES", None)
        env.pop("NAPARI_LABYRINTH_SHIPPED_KERNELS", None)
        if switch_off:
            env["NAPARI_LABYRINTH_SHIPPED_KERNELS"] = "0"
        self.process = subprocess.Popen(
            [sys.executable, str(pathlib.Path(__file__).resolve()), "--child", "--size", str(size)],
            env=env, stdin=subprocess.PIPE, stdout=subprocess.PIPE, text=True,
        )  # fmt: skip

    def ask(self, request: dict) -> dict:
        self.process.stdin.write(json.dumps(request) + "\n")
        self.process.stdin.flush()
        line = self.process.stdout.readline()
        if not line:
            raise RuntimeError(f"the {self.label} process ended")
        return json.loads(line)

    def close(self) -> None:
        self.process.stdin.close()
        self.process.wait(timeout=60)
        shutil.rmtree(self.cache, ignore_errors=True)


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--size", type=int, default=2048)
    parser.add_argument("--big", type=int, default=8192)
    parser.add_argument("--repeats", type=int, default=5)
    parser.add_argument("--images", action="store_true", help="the seventeen other images too")
    parser.add_argument("--child", action="store_true", help=argparse.SUPPRESS)
    args = parser.parse_args(argv)
    if args.child:
        return child_main(args.size)

    import numba

    import napari_labyrinth

    names = rows(args.size, args.big, args.images)
    print(f"napari-labyrinth from {pathlib.Path(napari_labyrinth.__file__).parent}, numba "
          f"{numba.__version__}; {len(names)} rows, best of {args.repeats} interleaved rounds; "
          f"cores {os.cpu_count()}, load {os.getloadavg()[0]:.2f}")  # fmt: skip
    processes = [Process("shipped", args.size, False), Process("host", args.size, True)]
    try:
        for process in processes:  # one untimed call of every row: the host's compile
            answer = process.ask({"warm": names})
            print(f"{process.label}: ready (shipped kernels "
                  f"{'refused: ' + answer['refused'] if answer['refused'] else 'loaded'})",
                  flush=True)  # fmt: skip
        if processes[0].ask({"warm": []})["refused"]:
            print("the shipped kernels do not load here: nothing to compare")
            return 1
        best = {process.label: dict.fromkeys(names, np.inf) for process in processes}
        for round_index in range(args.repeats):
            for name in names:
                order = processes if (round_index + names.index(name)) % 2 == 0 else processes[::-1]
                for process in order:
                    seconds = process.ask({"row": name})["seconds"]
                    best[process.label][name] = min(best[process.label][name], seconds)
    finally:
        for process in processes:
            process.close()
    print(f"\n{'row':<44}{'shipped ms':>11}{'host ms':>9}{'ratio':>7}")
    ratios = []
    for name in names:
        shipped, host = best["shipped"][name], best["host"][name]
        ratios.append(shipped / host)
        print(f"{name:<44}{shipped * 1e3:>11.2f}{host * 1e3:>9.2f}{shipped / host:>7.3f}")
    ratios = np.array(ratios)
    print(
        f"\nshipped / host over {len(ratios)} rows: median {np.median(ratios):.3f}, "
        f"min {ratios.min():.3f}, max {ratios.max():.3f}; within 3 %: "
        f"{int(np.sum(np.abs(ratios - 1) <= 0.03))} of {len(ratios)}, slower by more: "
        f"{int(np.sum(ratios > 1.03))}; load {os.getloadavg()[0]:.2f}"
    )
    return 0


if __name__ == "__main__":
    sys.exit(main())
