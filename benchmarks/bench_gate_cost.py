"""What the noise gate costs a render: gate on against gate off, and one worker against two.

Prints, asserts nothing. Each tree runs in a process of its own that stays up (the
current tree, and with ``--before SRC`` the ``src`` folder of another one, e.g. a
``git worktree`` of the commit before a change); the parent asks each in turn to
time one call of a row, ``--repeats`` rounds with the order of the trees
alternating, and keeps each row's best and median: a load that comes and goes falls
on every variant alike. The load average is printed beside every round.

Rows, on 2048² and 4096² images (``--sizes``), the default ``labyrinth`` preset, one
pass:

- ``gate``: ``labyrinth(image, passes=1, workers=1)``, the gate on (the preset's);
- ``off``: the same with ``noise_gate=0``;
- ``sigma``: the gate's noise estimate alone (``core.noise.tone_noise_sigma``);
- ``gate-w2`` and ``off-w2`` at the largest size: ``workers=2``, the exact-order tiles
  (on this 2-core machine: every core).

Each call's wall time and the process's CPU time (every thread: a busy machine
disturbs it less) are kept. The ratios printed are gate / off (one worker) and the
speed-up of two workers (``gate`` / ``gate-w2``), from the best of the rounds; every
tree's pixels of a row are compared with the current tree's (``same``).

Images: ``camera`` (skimage's, resized: a photograph, few dark pixels; the gate leaves
most of its pixels, which costs the pass less), ``batonnets``
(``samples.smectic_batonnets``: bright rods in a black melt, the dark field's case) and
``grass`` (skimage's, resized: a texture, whose pixels the gate leaves under 1 % at
2048², 5 % at 4096²: what the estimate itself costs); ``camera-u16``, the camera in
uint16, whose tones (a map of the values) are not integers: the estimate's float path.

Run: ``python benchmarks/bench_gate_cost.py [--before /tmp/before/src] [--repeats 9]``;
``--sizes 4096 --kinds gate,gate-w2`` for the speed-up of two workers alone (which needs
both cores idle: the tiles take no more threads than ``_engine.idle_cores``).
"""

from __future__ import annotations

import argparse
import hashlib
import inspect
import json
import os
import pathlib
import subprocess
import sys
import time

import numpy as np

HERE = pathlib.Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))

IMAGES = ("camera", "batonnets", "grass", "camera-u16")


def load() -> str:
    return "load %.2f %.2f %.2f" % os.getloadavg()


def rows(sizes: list[int]) -> list[str]:
    names = []
    for size in sizes:
        for image in IMAGES:
            names += [f"gate {size} {image}", f"off {size} {image}", f"sigma {size} {image}"]
    for image in IMAGES:
        names += [f"gate-w2 {max(sizes)} {image}", f"off-w2 {max(sizes)} {image}"]
    return names


# -- the child: holds its images, times one call of a row at a time ----------------------


class Child:
    def __init__(self):
        self.images: dict = {}

    def image(self, size: int, name: str) -> np.ndarray:
        if (size, name) not in self.images:
            if name == "camera":
                from bench_kernel import camera

                self.images[size, name] = camera(size, np.uint8)
            elif name == "camera-u16":
                from bench_kernel import camera

                self.images[size, name] = camera(size, np.uint16)
            elif name == "grass":
                from skimage import data, transform

                grass = transform.resize(data.grass(), (size, size), order=1, preserve_range=True)
                self.images[size, name] = grass.astype(np.uint8)
            else:
                from napari_labyrinth import samples

                self.images[size, name] = samples.smectic_batonnets((size, size), seed=0)
        return self.images[size, name]

    def call(self, row: str):
        from napari_labyrinth import labyrinth
        from napari_labyrinth.core.noise import tone_noise_sigma
        from napari_labyrinth.core.tone_scale import resolve_tone_scale

        kind, size, name = row.split()
        image = self.image(int(size), name)
        if kind == "sigma":
            scale = resolve_tone_scale(image, None)
            return lambda: np.float64(tone_noise_sigma(image, scale))
        workers = 2 if kind.endswith("-w2") else 1
        gate = {} if kind.startswith("gate") else {"noise_gate": 0}
        return lambda: labyrinth(image, preset="labyrinth", passes=1, workers=workers, **gate)

    def time(self, row: str) -> tuple[float, float, str]:
        run = self.call(row)
        start, start_cpu = time.perf_counter(), time.process_time()
        result = run()
        cpu = time.process_time() - start_cpu
        seconds = time.perf_counter() - start
        digest = hashlib.sha256(np.ascontiguousarray(result).tobytes()).hexdigest()[:12]
        return seconds, cpu, digest


def child_main() -> int:
    import napari_labyrinth
    from napari_labyrinth.core import noise

    child = Child()
    for line in sys.stdin:
        request = json.loads(line)
        if "where" in request:
            threads = "workers" in inspect.signature(noise.tone_noise_sigma).parameters
            answer = {"where": str(pathlib.Path(napari_labyrinth.__file__).parent),
                      "sigma_threads": threads}  # fmt: skip
        else:
            seconds, cpu, digest = child.time(request["row"])
            answer = {"seconds": seconds, "cpu": cpu, "digest": digest}
        print(json.dumps(answer), flush=True)
    return 0


# -- the parent ------------------------------------------------------------------------


class Process:
    def __init__(self, label: str, source: str | None):
        self.label = label
        env = dict(os.environ)
        if source:
            env["PYTHONPATH"] = os.pathsep.join(
                [source, str(HERE)] + ([env["PYTHONPATH"]] if env.get("PYTHONPATH") else [])
            )
        self.process = subprocess.Popen(
            [sys.executable, str(pathlib.Path(__file__).resolve()), "--child"],
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


def median(seconds: dict, one, two) -> float:
    """The ratio of the medians of two rows' times."""
    return float(np.median(seconds[one])) / float(np.median(seconds[two]))


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--sizes", default="2048,4096", help="sides of the images")
    parser.add_argument("--repeats", type=int, default=9)
    parser.add_argument("--before", help="the src folder of the tree to compare with")
    parser.add_argument("--kinds", default="", help="only these rows, e.g. gate,gate-w2")
    parser.add_argument("--images", default=",".join(IMAGES), help="the images, e.g. camera")
    parser.add_argument("--child", action="store_true", help=argparse.SUPPRESS)
    args = parser.parse_args(argv)
    if args.child:
        return child_main()
    sizes = [int(s) for s in args.sizes.split(",")]
    names = rows(sizes)
    if args.kinds:
        names = [n for n in names if n.split()[0] in args.kinds.split(",")]
    names = [n for n in names if n.split()[2] in args.images.split(",")]
    trees = [Process("after", None)] + ([Process("before", args.before)] if args.before else [])
    print(f"{load()}  cores: {os.cpu_count()}")
    for tree in trees:
        where = tree.ask({"where": True})
        print(f"{tree.label}: {where['where']}")
    print("warming (the first call of every row in every tree: compiles, loads)...", flush=True)
    digests: dict = {}
    for tree in trees:
        for name in names:
            digests[tree.label, name] = tree.ask({"row": name})["digest"]
    seconds: dict = {(t.label, n): [] for t in trees for n in names}
    cpu: dict = {(t.label, n): [] for t in trees for n in names}
    for round_ in range(args.repeats):
        order = trees if round_ % 2 == 0 else trees[::-1]
        before_load = os.getloadavg()[0]
        for name in names:  # each row in every tree in turn: the trees interleaved
            for tree in order:
                answer = tree.ask({"row": name})
                seconds[tree.label, name].append(answer["seconds"])
                cpu[tree.label, name].append(answer["cpu"])
                if answer["digest"] != digests[tree.label, name]:
                    digests[tree.label, name] = "varies"
        print(f"round {round_ + 1}/{args.repeats}: load {before_load:.2f} -> "
              f"{os.getloadavg()[0]:.2f}", flush=True)  # fmt: skip
    for tree in trees:
        tree.close()

    print(f"\nbest and median of {args.repeats} rounds, ms: wall time, and the process's CPU "
          f"time (every thread) ({load()})\n")  # fmt: skip
    head = f"{'row':24} "
    for tree in trees:
        head += f"| {tree.label + ' wall':>12} {'median':>7} {'CPU':>7} {'median':>7} "
    print(head + ("| same" if len(trees) > 1 else ""))
    best = {key: min(values) for key, values in seconds.items()}
    best_cpu = {key: min(values) for key, values in cpu.items()}
    for name in names:
        line = f"{name:24} "
        for tree in trees:
            wall, used = seconds[tree.label, name], cpu[tree.label, name]
            line += (f"| {1e3 * min(wall):12.1f} {1e3 * float(np.median(wall)):7.1f} "
                     f"{1e3 * min(used):7.1f} {1e3 * float(np.median(used)):7.1f} ")  # fmt: skip
        if len(trees) > 1:
            same = len({digests[t.label, name] for t in trees}) == 1
            line += f"| {'yes' if same and digests['after', name] != 'varies' else 'NO'}"
        print(line)
    print("\nratios of the best times (wall; CPU):\n")
    for tree in trees:
        label = tree.label
        for size in sizes:
            for image in IMAGES:
                gate, off = (label, f"gate {size} {image}"), (label, f"off {size} {image}")
                sigma = (label, f"sigma {size} {image}")
                if gate in best and off in best:
                    alone = ""
                    if sigma in best:
                        alone = (f"   (sigma alone / off: {best[sigma] / best[off]:.3f}; "
                                 f"{best_cpu[sigma] / best_cpu[off]:.3f})")  # fmt: skip
                    print(f"{label:6} {size}² {image:9} gate on / off, 1 worker: "
                          f"{best[gate] / best[off]:.3f}; {best_cpu[gate] / best_cpu[off]:.3f}"
                          + alone)  # fmt: skip
        size = max(sizes)
        for image in IMAGES:
            for kind in ("gate", "off"):
                one = (label, f"{kind} {size} {image}")
                two = (label, f"{kind}-w2 {size} {image}")
                if one in best and two in best:
                    cpu_ratio = best_cpu[two] / best_cpu[one]
                    print(f"{label:6} {size}² {image:9} {kind:4} 1 worker / 2 workers (wall): "
                          f"{best[one] / best[two]:.3f}; median {median(seconds, one, two):.3f}"
                          f"   (CPU of 2 / of 1: {cpu_ratio:.3f})")  # fmt: skip
        for image in IMAGES:
            one, two = (label, f"gate {size} {image}"), (label, f"gate-w2 {size} {image}")
            if one in digests and two in digests:
                same = digests[one] == digests[two] != "varies"
                print(f"{label:6} {size}² {image:9} 2 workers' pixels those of 1: "
                      f"{'yes' if same else 'NO'}")  # fmt: skip
    print(f"\n{load()}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
