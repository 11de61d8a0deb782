"""Speed of ``metrics.describe``: the previous implementation, a baseline tree and this one.

Prints figures, asserts nothing. For each size, the input is scikit-image's
``camera`` resized, and the rendering a real one, ``labyrinth(image)`` with
the default preset. Timed, interleaved round after round (best of the
rounds; the machine may be shared, so the load average is printed with
every round):

- ``reference``: the previous implementation, kept as ``tests/metrics/_metrics_reference.py``;
- ``first pass``: ``Comparison(original).describe(rendered)``, the original's
  own maps included (what ``describe`` costs the first time it sees an input);
- ``next passes``: ``comparison.describe(rendered)`` on a ``Comparison`` that
  already holds the original's maps (every pass of a stack after the first);
- ``describe()``: ``metrics.describe(original, rendered)`` called again with
  the same original: the original's maps come from its content-keyed cache;
- ``new originals``: five other images (scikit-image's astronaut, rocket,
  immunohistochemistry, retina, coffee; grey, resized), one after the other
  in the same warm process, each ``Comparison(original).describe(rendered)``
  for an original never seen: the mean per call (a user stepping through
  images, or a stack of a new plane).

Each tree's code runs in a fresh process per round (``this`` is the tree
holding this script; ``--against DIR`` adds another checkout, e.g. the main
branch, as ``before``), so both pay the same first-call costs. Besides the
wall time, each call's CPU time (all threads) is recorded: CPU / wall near
the number of cores means the call used them all.

After the timings each tree reports the new memory of a first call (the
most numpy arrays alive at once during it, ``tracemalloc``, the original's
copy included, bytes per pixel: the memory a first call touches for the
first time, whose page faults are system time), and the run prints the
kernel's transparent huge page settings: with ``defrag`` at ``madvise``, a
first touch of numpy's large arrays may wait for the kernel to compact memory.

``--stages`` prints instead where a first call's time goes: each map and
metric of ``Comparison(original).describe(rendered)`` computed one after the
other on one thread (``workers=1``), with its wall, user and system time and
page faults (``getrusage``), in a fresh process per tree and round: round 1
is a first call in the process (new memory), the later rounds are calls on
new originals in a warm process.

``--first-calls N`` times what a user's first call costs: ``N`` fresh
processes per tree (interleaved), each loading the planes, making a small
call that loads numba's cache (64 x 64), then timing one
``metrics.describe(original, rendered)`` at each size, with its user and
system time and page faults; the reference is timed once per round. It
prints every call, then each tree's median, worst, how many calls reach
30x the best reference time and the new memory of a first call (measured
after the timings, on another original). With ``--render-first`` each process renders
the plane itself (``labyrinth(original, seed=0)``, the default preset)
before the call, as a stack run does: memory freed just before changes
what the first touches of new memory cost.

``--bands`` prints, for one ``describe()`` per round in a fresh process per
tree (round 1 a first call, the later rounds new originals), each threaded
step's wall time beside the time its bands of rows took on the threads:
``2 x wall - bands' time`` is what two cores left unused during the step.

``--passes`` times a stack's passes: ``--rounds`` calls of
``comparison.describe(rendered)`` on one ``Comparison`` in a fresh process
(``--repeats`` processes per tree, interleaved), with each call's user and
system time and page faults.

``--compile N`` times first calls after an install: in ``N`` rounds, two fresh processes
per tree (interleaved), each with an empty numba cache of its own (``NUMBA_CACHE_DIR``),
render a 1024 x 1024 uint16 plane (``labyrinth()``, which compiles the renderer's kernels:
numba's start in the process is paid there). The first then times ``metrics.describe`` of
it as float32 against the rendering (:func:`compile_planes`: a smooth plane whose rendering
has walls on under 1 % of its pixels, so the wall metrics are NaN), then the ``describe``
of scikit-image's camera at 1024 x 1024 (walls: the structure tensors, the local mean and
the wall sums compile there); the second times ``Comparison(original).edge_enhancement``
of the uint16 plane, its first metric (what ``window.find_window`` calls). Each call's wall
time is printed with the compile time of every metrics kernel (numba's compile events, CPU
time of the compiling thread; its helpers inside).

``--release`` times the pool letting its arrays go (``_SHARED_POOL.clear()``,
what its timer does 10 s after the last use) after a first call, in a fresh
process per tree and round, and the longest gap a thread ticking every
0.5 ms saw meanwhile (how long the GIL was held at once).

Run: ``python benchmarks/bench_metrics.py [--against /path/to/main] [--sizes 512 2048 4096]
[--rounds 3] [--stages] [--bands] [--passes] [--first-calls N] [--compile N] [--release]``.
The reference takes about a minute per call at 4096 x 4096 on two cores.
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "tests" / "metrics"))  # the previous implementation

MODES = ("first pass", "next passes", "describe()", "new originals")
#: scikit-image images behind ``new originals``.
OTHERS = ("astronaut", "rocket", "immunohistochemistry", "retina", "coffee")


def camera(size: int) -> np.ndarray:
    from skimage import data, transform

    image = transform.resize(data.camera(), (size, size), order=1, preserve_range=True)
    return image.astype(np.uint8)


def other_images(size: int) -> list[np.ndarray]:
    """The :data:`OTHERS`, grey, resized to ``size`` x ``size``, as uint8."""
    from skimage import color, data, transform

    images = []
    for name in OTHERS:
        image = getattr(data, name)()
        if image.ndim == 3:
            image = color.rgb2gray(image[..., :3]) * 255
        image = transform.resize(image, (size, size), order=1, preserve_range=True)
        images.append(image.astype(np.uint8))
    return images


def _metrics_modules() -> list:
    """``napari_labyrinth.metrics`` and its modules imported so far: the tree's private names
    are in the module (a tree before it became a package) or in the package's modules."""
    from napari_labyrinth import metrics

    prefix = f"{metrics.__name__}."
    return [metrics] + [m for n, m in list(sys.modules.items()) if n.startswith(prefix)]


def private(name: str):
    """The private name ``name`` of the tree's metrics, wherever its layout keeps it."""
    for module in _metrics_modules():
        if name in vars(module):
            return vars(module)[name]
    raise AttributeError(f"napari_labyrinth.metrics has no {name}")


def set_private(name: str, value) -> None:
    """``name`` = ``value`` in every module of the tree's metrics that holds ``name``."""
    for module in _metrics_modules():
        if name in vars(module):
            setattr(module, name, value)


def _is_metrics_kernel(module: str) -> bool:
    """Whether ``module`` holds metrics kernels (``_metrics_kernels`` in a tree before the
    metrics became a package, ``metrics._kernels``'s modules after)."""
    return module.endswith("_metrics_kernels") or ".metrics._kernels" in module


def usage() -> tuple[float, float, float, int]:
    """Wall clock, user and system CPU seconds, and minor page faults of this process."""
    import resource

    r = resource.getrusage(resource.RUSAGE_SELF)
    return time.perf_counter(), r.ru_utime, r.ru_stime, r.ru_minflt


def warm_camera_pair(size: int) -> tuple[np.ndarray, np.ndarray]:
    """The camera at ``size`` and its rendering, after a 64 x 64 ``describe`` that
    compiles or loads numba's cache."""
    from napari_labyrinth import labyrinth, metrics

    small = camera(64)
    metrics.describe(small, labyrinth(small, seed=0))
    original = camera(size)
    return original, labyrinth(original, seed=0)


def timed(function, *arguments):
    """``(wall seconds, CPU seconds of the process, function(*arguments))``."""
    start, cpu = time.perf_counter(), time.process_time()
    result = function(*arguments)
    return time.perf_counter() - start, time.process_time() - cpu, result


def cases(sizes):
    from napari_labyrinth import labyrinth

    return {size: (camera(size), labyrinth(camera(size), seed=0)) for size in sizes}


def child(sizes) -> None:
    """One round of the current ``napari_labyrinth`` (from PYTHONPATH); JSON on stdout."""
    from napari_labyrinth import labyrinth, metrics

    planes = cases(sizes)
    others = {
        size: [(image, labyrinth(image, seed=0)) for image in other_images(size)] for size in sizes
    }
    small = camera(64)
    metrics.describe(small, labyrinth(small, seed=0))  # compile or load numba's cache
    rows = []
    for size, (original, rendered) in planes.items():
        comparison = metrics.Comparison(original)
        wall, cpu, result = timed(comparison.describe, rendered)
        rows.append((size, "first pass", wall, cpu))
        wall, cpu, _ = timed(comparison.describe, rendered)
        rows.append((size, "next passes", wall, cpu))
        metrics.describe(original, rendered)  # the original's maps now in describe's cache
        wall, cpu, _ = timed(metrics.describe, original, rendered)
        rows.append((size, "describe()", wall, cpu))
        rows.append((size, "values", result, None))
        rows.append((size, "bytes per pixel", _first_call_bytes(original, rendered), None))
    for size in sizes:
        calls = [
            timed(lambda o, r: metrics.Comparison(o).describe(r), original, rendered)[:2]
            for original, rendered in others[size]
        ]
        wall, cpu = np.mean(calls, axis=0).tolist()
        rows.append((size, "new originals", wall, cpu))
    print(json.dumps({"source": str(Path(metrics.__file__).parent), "rows": rows}))


def _first_call_bytes(original, rendered) -> float:
    """Bytes per pixel of new numpy arrays a first ``describe()`` in a process makes: the
    largest amount of them alive at once during the call (``tracemalloc``), the copy of
    the original included; the memory whose first touch is a page fault."""
    import gc
    import tracemalloc

    from napari_labyrinth import metrics

    try:
        pool = private("_SHARED_POOL")
    except AttributeError:  # a tree without the pool
        pool = None
    if pool is not None:
        pool.clear()  # the arrays of earlier calls: a first call in a process has none
    gc.collect()
    tracemalloc.start()
    metrics.Comparison(original).describe(rendered)
    peak = tracemalloc.get_traced_memory()[1]
    tracemalloc.stop()
    return peak / original.size


def _huge_pages() -> str:
    """The kernel's transparent huge page settings (Linux), as ``enabled / defrag``."""
    base = Path("/sys/kernel/mm/transparent_hugepage")
    try:
        return " / ".join((base / name).read_text().strip() for name in ("enabled", "defrag"))
    except OSError:
        return "unknown"


def stages(size: int, rounds: int) -> None:
    """Per-stage times of ``Comparison(original).describe(rendered)`` on one thread, printed."""
    from napari_labyrinth import metrics

    original, rendered = warm_camera_pair(size)

    def _contours(comparison, after):
        if hasattr(after, "give_back_fine"):  # as Comparison.describe does before the contours
            after.give_back_fine()
        return comparison._maps.contours(metrics.CONTOUR_SIGMA, after.walls()[0])

    steps = (
        ("original's own maps", lambda c, a: c._maps._fine()),
        ("rendering's h", lambda c, a: a._full_fine()),
        ("wall pass", lambda c, a: a.walls()),
        ("local mean", lambda c, a: a.above_local_mean()),
        ("wall_width", lambda c, a: private("_wall_width")(a)),
        ("walls' orientation", lambda c, a: a.wall_orientation()),
        ("orientation_coherence", lambda c, a: private("_orientation_coherence")(a)),
        ("contours", _contours),
        ("contour_alignment", lambda c, a: private("_contour_alignment")(c._maps, a)),
        ("edge_enhancement", lambda c, a: private("_edge_enhancement")(c._maps, a)),
    )
    print(f"{size} x {size}, napari_labyrinth from {Path(metrics.__file__).parent}")
    for round_number in range(rounds):
        print(f"  round {round_number + 1} (load average {os.getloadavg()})")
        begin = usage()
        comparison = metrics.Comparison(original, workers=1)
        after = comparison._rendering_maps(rendered)
        lines = [("copies of both planes", begin, usage())]
        for name, step in steps:
            before = usage()
            step(comparison, after)
            lines.append((name, before, usage()))
        after.release()
        lines.append(("total", begin, usage()))
        for name, (w0, u0, s0, f0), (w1, u1, s1, f1) in lines:
            print(
                f"    {name:<24}{(w1 - w0) * 1e3:7.1f} ms wall {(u1 - u0) * 1e3:7.1f} user"
                f" {(s1 - s0) * 1e3:6.1f} system {f1 - f0:7d} page faults"
            )
        del comparison


def first_call(sizes, folder: Path, render: bool = False) -> None:
    """One fresh process's first ``metrics.describe`` at each size (planes saved in
    ``folder``, see :func:`first_calls`; with ``render``, the rendering made here), after
    a 64 x 64 call; JSON on stdout."""
    from napari_labyrinth import labyrinth, metrics

    small = [np.load(folder / f"{name}-64.npy") for name in ("original", "rendered")]
    metrics.describe(*small)  # compile or load numba's cache
    rows = []
    for size in sizes:
        original, rendered = (
            np.load(folder / f"{name}-{size}.npy") for name in ("original", "rendered")
        )
        if render:
            rendered = labyrinth(original, seed=0)
        begin = usage()
        metrics.describe(original, rendered)
        end = usage()
        rows.append([size, *(b - a for a, b in zip(begin, end))])
    # after the timings: the new memory of a first call, on another original
    for row, size in zip(rows, sizes):
        original, rendered = (
            np.load(folder / f"{name}-{size}.npy") for name in ("original", "rendered")
        )
        row.append(_first_call_bytes(original[::-1].copy(), rendered))
    print(json.dumps({"source": str(Path(metrics.__file__).parent), "rows": rows}))


def first_calls(trees: dict[str, Path], sizes, runs: int, render: bool = False) -> None:
    """``runs`` first calls of ``metrics.describe`` per tree and size, printed (see the module)."""
    import tempfile

    import _metrics_reference as reference

    calls: dict[tuple[str, int], list] = {}
    memory: dict[tuple[str, int], float] = {}
    references: dict[int, list[float]] = {}
    with tempfile.TemporaryDirectory() as name:
        folder = Path(name)
        planes = cases([64, *sizes])
        for size, (original, rendered) in planes.items():
            np.save(folder / f"original-{size}.npy", original)
            np.save(folder / f"rendered-{size}.npy", rendered)
        print("wall ms (user ms + system ms, page faults) of a first describe() in a fresh process")
        if render:
            print("(each process renders the plane itself first)")
        for run in range(runs):
            print(f"round {run + 1}/{runs}, load average {os.getloadavg()}", flush=True)
            order = list(trees) if run % 2 == 0 else list(reversed(trees))
            for tree in order:
                environment = dict(os.environ, PYTHONPATH=str(trees[tree] / "src"))
                command = [sys.executable, __file__, "--child", "--first-call", str(folder)]
                command += ["--sizes", *map(str, sizes)] + ["--render-first"] * render
                output = subprocess.run(
                    command, env=environment, capture_output=True, text=True, check=True
                )
                report = json.loads(output.stdout.splitlines()[-1])
                for size, wall, user, system, faults, pixel_bytes in report["rows"]:
                    calls.setdefault((tree, size), []).append(wall)
                    memory[(tree, size)] = pixel_bytes
                    print(
                        f"  {tree:<7}{size:>5}^2 {wall * 1e3:7.1f} ms ({user * 1e3:5.0f} user"
                        f" + {system * 1e3:4.0f} system, {faults:6d} page faults)"
                    )
            for size in sizes:
                original, rendered = planes[size]
                if size <= 2048 or run == 0:
                    wall, _, _ = timed(reference.describe, original, rendered)
                    references.setdefault(size, []).append(wall)
                    print(f"  reference {size:>5}^2 {wall:.3f} s")
                    time.sleep(1.0)  # let BLAS's worker threads go back to sleep
    print(f"\nload average at the end {os.getloadavg()}, {os.cpu_count()} cores")
    print(f"transparent huge pages (enabled / defrag): {_huge_pages()}")
    for size in sizes:
        best = min(references[size])
        print(f"\n{size} x {size}: reference {best:.3f} s (best of {len(references[size])});")
        print(f"  30x needs a first call of {best / 30 * 1e3:.0f} ms or less")
        for tree in trees:
            walls = np.array(calls[(tree, size)])
            median = float(np.median(walls))
            print(
                f"  {tree:<7} median {median * 1e3:6.1f} ms ({best / median:4.0f}x),"
                f" best {walls.min() * 1e3:6.1f} ms ({best / walls.min():4.0f}x),"
                f" worst {walls.max() * 1e3:6.1f} ms ({best / walls.max():4.0f}x);"
                f" {np.sum(best / walls >= 30)} of {walls.size} calls at 30x or more;"
                f" new memory {memory[(tree, size)]:.1f} bytes a pixel"
            )


def compile_planes(size: int = 1024) -> tuple[np.ndarray, np.ndarray]:
    """:func:`compile_call`'s first plane, uint16, and the camera at ``size`` as uint16."""
    rng = np.random.default_rng(0)
    y, x = np.indices((size, size))
    smooth = 30000 + 20000 * np.sin(x / 40.0) * np.cos(y / 55.0) + rng.normal(0, 2000, y.shape)
    return smooth.clip(0, 65535).astype(np.uint16), camera(size).astype(np.uint16) * 257


def compile_call(edge_first: bool) -> None:
    """One fresh process's first calls (see ``--compile`` in the module; with
    ``edge_first``, the second process's); JSON on stdout."""
    import threading

    import numba.core.event as numba_event

    compiles: list[tuple[str, float]] = []
    local = threading.local()

    class Listener(numba_event.Listener):
        def on_start(self, event):
            if not hasattr(local, "starts"):
                local.starts = []
            local.starts.append(time.thread_time())

        def on_end(self, event):
            start = local.starts.pop()
            dispatcher = event.data["dispatcher"]
            function = getattr(dispatcher, "py_func", dispatcher)
            if not local.starts and _is_metrics_kernel(function.__module__):
                compiles.append((function.__name__, time.thread_time() - start))

    numba_event.register("numba:compile", Listener())
    from napari_labyrinth import labyrinth, metrics

    smooth, camera_plane = compile_planes()
    start = time.perf_counter()
    rendered = labyrinth(smooth)
    rows = [("labyrinth()", time.perf_counter() - start, [])]

    def edge(original, rendering):
        return metrics.Comparison(original, workers=1).edge_enhancement(rendering)

    steps = [("Comparison, edge", edge, smooth, rendered)]
    if not edge_first:
        steps = [
            ("describe()", metrics.describe, *(p.astype(np.float32) for p in (smooth, rendered))),
            ("describe(), walls", metrics.describe, camera_plane, labyrinth(camera_plane, seed=0)),
        ]
    for name, function, *planes in steps:
        del compiles[:]
        start = time.perf_counter()
        function(*planes)
        rows.append((name, time.perf_counter() - start, list(compiles)))
    print(json.dumps({"source": str(Path(metrics.__file__).parent), "rows": rows}))


def compile_calls(trees: dict[str, Path], runs: int) -> None:
    """``runs`` fresh processes per tree with empty numba caches (see ``--compile``), printed."""
    import tempfile

    print("first calls in a process with an empty numba cache: wall seconds, and the CPU")
    print("seconds of numba's compile of each metrics kernel (its helpers inside)")
    walls: dict[tuple[str, str], list[float]] = {}
    for run in range(runs):
        print(f"round {run + 1}/{runs}, load average {os.getloadavg()}", flush=True)
        for tree in list(trees) if run % 2 == 0 else list(reversed(trees)):
            rows = []
            for process in ("1", "2"):
                with tempfile.TemporaryDirectory() as cache:
                    environment = dict(
                        os.environ, PYTHONPATH=str(trees[tree] / "src"), NUMBA_CACHE_DIR=cache
                    )
                    command = [sys.executable, __file__, "--child", "--compile", process]
                    output = subprocess.run(
                        command, env=environment, capture_output=True, text=True, check=True
                    )
                rows += json.loads(output.stdout.splitlines()[-1])["rows"]
            for name, wall, compiles in rows:
                walls.setdefault((tree, name), []).append(wall)
                kernels = ", ".join(f"{kernel} {cpu:.2f}" for kernel, cpu in compiles)
                print(f"  {tree:<7}{name:<19}{wall:7.2f} s  {kernels}".rstrip())
    print(f"\nload average at the end {os.getloadavg()}, {os.cpu_count()} cores")
    for (tree, name), values in walls.items():
        print(
            f"  {tree:<7}{name:<19} best {min(values):6.2f} s, median {np.median(values):6.2f} s"
        )


def release(size: int) -> None:
    """The pool's release of a first call's arrays at ``size``, with a ticking thread; printed."""
    import gc
    import threading

    from napari_labyrinth import metrics

    original, rendered = warm_camera_pair(size)
    comparison = metrics.Comparison(original)
    comparison.describe(rendered)
    del comparison  # the original's arrays go to the pool too
    gc.collect()
    pool = private("_SHARED_POOL")
    kept = pool.nbytes
    gaps: list[float] = []
    running = threading.Event()
    running.set()

    def tick():
        last = time.perf_counter()
        while running.is_set():
            time.sleep(0.0005)
            now = time.perf_counter()
            gaps.append(now - last)
            last = now

    ticker = threading.Thread(target=tick)
    ticker.start()
    time.sleep(0.05)
    gaps.clear()
    start = time.perf_counter()
    pool.clear()
    took = time.perf_counter() - start
    time.sleep(0.02)
    running.clear()
    ticker.join()
    print(
        f"    {size:>5}^2 {Path(metrics.__file__).parent}: {kept / 1e6:6.0f} MB let go in"
        f" {took * 1e3:6.1f} ms; longest gap of the 0.5 ms ticker {max(gaps) * 1e3:5.1f} ms"
    )


def bands(size: int, rounds: int) -> None:
    """Each threaded step (the metrics' ``_in_bands``) of ``describe()`` at ``size``: its wall
    time, the time its bands took on the threads, and what is left of two cores; printed.

    Round 1 is a first call in a fresh process, the later rounds new originals (the
    camera flipped) in the same process.
    """
    from napari_labyrinth import metrics

    original, rendered = warm_camera_pair(size)
    in_bands = private("_in_bands")
    log = []

    def traced(kernel, height, workers, *arguments):
        spans = []

        def timed_kernel(*a):
            start = time.perf_counter()
            result = kernel(*a)
            spans.append(time.perf_counter() - start)
            return result

        start = time.perf_counter()
        results = in_bands(timed_kernel, height, workers, *arguments)
        log.append((kernel.__name__, time.perf_counter() - start, sum(spans), len(spans)))
        return results

    set_private("_in_bands", traced)
    print(f"{size} x {size}, napari_labyrinth from {Path(metrics.__file__).parent}")
    for round_number in range(rounds):
        log.clear()
        plane = original if round_number % 2 == 0 else original[::-1].copy()
        start, cpu = time.perf_counter(), time.process_time()
        metrics.describe(plane, rendered)
        wall, cpu = time.perf_counter() - start, time.process_time() - cpu
        threaded = sum(entry[1] for entry in log)
        print(
            f"  round {round_number + 1}: {wall * 1e3:.1f} ms wall, {cpu * 1e3:.1f} ms CPU"
            f" [{cpu / wall:.2f}]; {threaded * 1e3:.1f} ms in threaded steps,"
            f" {(wall - threaded) * 1e3:.1f} ms outside (load average {os.getloadavg()[0]:.2f})"
        )
        print("    step                       wall   bands' time   2 x wall - bands' time  bands")
        for name, step_wall, busy, count in log:
            print(
                f"    {name:<24}{step_wall * 1e3:8.1f}{busy * 1e3:14.1f}"
                f"{(2 * step_wall - busy) * 1e3:25.1f}{count:7d}"
            )
        set_private("_ORIGINALS", private("_LastPlane")())


def passes(size: int, rounds: int) -> None:
    """A stack's passes: ``rounds`` calls of ``comparison.describe(rendered)`` on one
    ``Comparison`` in a fresh process, each with its wall, user and system time and page
    faults (the first is a first call; the pool serves the later ones); printed."""
    from napari_labyrinth import metrics

    original, rendered = warm_camera_pair(size)

    print(f"  {Path(metrics.__file__).parent} (load average {os.getloadavg()[0]:.2f})")
    comparison = metrics.Comparison(original)
    for number in range(rounds):
        begin = usage()
        comparison.describe(rendered)
        end = usage()
        wall, user, system, faults = (b - a for a, b in zip(begin, end))
        print(
            f"    pass {number + 1}: {wall * 1e3:6.1f} ms wall ({user * 1e3:5.0f} user"
            f" + {system * 1e3:4.0f} system, {faults:6d} page faults)"
        )


def run_mode_child(tree: Path, mode: str, *options: str) -> None:
    """Run ``--child --<mode> <options>`` on ``tree``'s ``napari_labyrinth`` in a fresh
    process, its output printed as it comes."""
    environment = dict(os.environ, PYTHONPATH=str(tree / "src"))
    command = [sys.executable, __file__, "--child", f"--{mode}", *options]
    subprocess.run(command, env=environment, check=True)


def run_child(tree: Path, sizes) -> dict:
    environment = dict(os.environ, PYTHONPATH=str(tree / "src"))
    command = [sys.executable, __file__, "--child", "--sizes", *map(str, sizes)]
    output = subprocess.run(command, env=environment, capture_output=True, text=True, check=True)
    return json.loads(output.stdout.splitlines()[-1])


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--sizes", type=int, nargs="+", default=[512, 2048, 4096])
    parser.add_argument("--rounds", type=int, default=3)
    parser.add_argument(
        "--repeats", type=int, default=3, help="with --passes: fresh processes per tree"
    )
    parser.add_argument("--against", type=Path, default=None, help="a baseline checkout")
    parser.add_argument(
        "--reference-rounds",
        type=int,
        default=None,
        help="rounds of the reference above 2048 x 2048 (default: 1; it is slow)",
    )
    parser.add_argument(
        "--stages", action="store_true", help="where a first call's time goes, stage by stage"
    )
    parser.add_argument(
        "--first-calls",
        type=int,
        default=0,
        metavar="N",
        help="N fresh processes per tree, each timing its first describe() (see above)",
    )
    parser.add_argument(
        "--render-first",
        action="store_true",
        help="with --first-calls: each process renders the plane before describing it",
    )
    parser.add_argument(
        "--compile",
        type=int,
        default=0,
        metavar="N",
        help="N fresh processes per tree with empty numba caches: first calls' compile",
    )
    parser.add_argument(
        "--release", action="store_true", help="the pool letting a first call's arrays go"
    )
    parser.add_argument(
        "--bands",
        action="store_true",
        help="each threaded step of describe(): wall time, the bands' time on the threads",
    )
    parser.add_argument(
        "--passes",
        action="store_true",
        help="a stack's passes (--rounds of them) on one Comparison, in a fresh process",
    )
    parser.add_argument("--first-call", type=Path, default=None, help=argparse.SUPPRESS)
    parser.add_argument("--child", action="store_true", help=argparse.SUPPRESS)
    args = parser.parse_args(argv)
    if args.child:
        if args.compile:
            compile_call(edge_first=args.compile == 2)
        elif args.first_call is not None:
            first_call(args.sizes, args.first_call, args.render_first)
        elif args.release:
            release(args.sizes[0])
        elif args.stages:
            stages(args.sizes[0], args.rounds)
        elif args.bands:
            bands(args.sizes[0], args.rounds)
        elif args.passes:
            passes(args.sizes[0], args.rounds)
        else:
            child(args.sizes)
        return
    if args.stages:
        print(f"one thread; the machine's load average {os.getloadavg()}, {os.cpu_count()} cores")
        for size in args.sizes:
            trees = [ROOT] if args.against is None else [args.against.resolve(), ROOT]
            for tree in trees:
                run_mode_child(tree, "stages", "--sizes", str(size), "--rounds", str(args.rounds))
        return

    if args.bands:
        print(f"the machine's load average {os.getloadavg()}, {os.cpu_count()} cores")
        trees = [ROOT] if args.against is None else [args.against.resolve(), ROOT]
        for tree in trees:
            run_mode_child(
                tree, "bands", "--sizes", str(args.sizes[0]), "--rounds", str(args.rounds)
            )
        return
    if args.passes:
        trees = [ROOT] if args.against is None else [args.against.resolve(), ROOT]
        for repeat in range(args.repeats):
            print(f"{args.sizes[0]} x {args.sizes[0]}, fresh processes ({repeat + 1})", flush=True)
            for tree in trees if repeat % 2 == 0 else trees[::-1]:
                run_mode_child(
                    tree, "passes", "--sizes", str(args.sizes[0]), "--rounds", str(args.rounds)
                )
        return
    if args.release:
        trees = [ROOT] if args.against is None else [args.against.resolve(), ROOT]
        for size in args.sizes:
            for round_number in range(args.rounds):
                print(f"round {round_number + 1}, load average {os.getloadavg()}", flush=True)
                for tree in trees if round_number % 2 == 0 else trees[::-1]:
                    run_mode_child(tree, "release", "--sizes", str(size))
        return
    if args.compile:
        trees = {"this": ROOT}
        if args.against is not None:
            trees = {"before": args.against.resolve(), "this": ROOT}
        compile_calls(trees, args.compile)
        return
    if args.first_calls:
        trees = {"this": ROOT}
        if args.against is not None:
            trees = {"before": args.against.resolve(), "this": ROOT}
        first_calls(trees, args.sizes, args.first_calls, args.render_first)
        return

    import _metrics_reference as reference

    trees = {"this": ROOT}
    if args.against is not None:
        trees = {"before": args.against.resolve(), "this": ROOT}
    planes = cases(args.sizes)
    times: dict[tuple[str, int, str], list[tuple[float, float]]] = {}
    values: dict[tuple[str, int], dict] = {}
    memory: dict[tuple[str, int], float] = {}
    for round_number in range(args.rounds):
        load = os.getloadavg()
        print(f"round {round_number + 1}/{args.rounds}, load average {load}", flush=True)
        order = list(trees) if round_number % 2 == 0 else list(reversed(trees))
        for name in order:
            report = run_child(trees[name], args.sizes)
            if round_number == 0:
                print(f"  {name}: napari_labyrinth from {report['source']}")
            for size, mode, wall, cpu in report["rows"]:
                if mode == "values":
                    values[(name, size)] = wall
                elif mode == "bytes per pixel":
                    memory[(name, size)] = wall
                else:
                    times.setdefault((name, size, mode), []).append((wall, cpu))
        for size, (original, rendered) in planes.items():
            reference_rounds = args.rounds if size <= 2048 else (args.reference_rounds or 1)
            if round_number < reference_rounds:
                wall, cpu, values[("reference", size)] = timed(
                    reference.describe, original, rendered
                )
                times.setdefault(("reference", size, "describe"), []).append((wall, cpu))
                time.sleep(1.0)  # let BLAS's worker threads (np.corrcoef) go back to sleep

    print(f"\nload average at the end {os.getloadavg()}, {os.cpu_count()} cores")
    print(f"transparent huge pages (enabled / defrag): {_huge_pages()}")
    print("best of the rounds, per call: wall seconds, CPU seconds (all threads; on a loaded")
    print("machine the CPU time says more about the work than the wall time), CPU / wall")
    print("(x: wall-time speed-up over the reference;")
    print(" vs before: wall- and CPU-time speed-ups over the baseline)\n")
    for size in planes:
        print(f"{size} x {size}")
        reference_best = min(times[("reference", size, "describe")])
        wall, cpu = reference_best
        print(f"  {'reference':<24}{wall:8.3f} s {cpu:7.3f} s  [{cpu / wall:.1f}]")
        for mode in MODES:
            for name in trees:
                wall = min(w for w, _ in times[(name, size, mode)])
                cpu = min(c for _, c in times[(name, size, mode)])
                line = f"  {name + ' ' + mode:<24}{wall:8.3f} s {cpu:7.3f} s  [{cpu / wall:.1f}]"
                line += f"  {reference_best[0] / wall:6.0f}x"
                if name == "this" and "before" in trees:
                    before_wall = min(w for w, _ in times[("before", size, mode)])
                    before_cpu = min(c for _, c in times[("before", size, mode)])
                    line += f"   {before_wall / wall:5.2f}x wall, "
                    line += f"{before_cpu / cpu:5.2f}x CPU vs before"
                print(line)
    print("\nthe original's own maps (first pass minus next passes, best of the rounds):")
    for size in planes:
        cells = []
        for name in trees:
            extra = min(times[(name, size, "first pass")])[0]
            extra -= min(times[(name, size, "next passes")])[0]
            cells.append(f"{name} {extra:.3f} s")
        print(f"  {size:>5} x {size:<5} " + ", ".join(cells))
    print("\nnew memory of a first call (numpy arrays, the original's copy included),")
    print("bytes a pixel:")
    for size in planes:
        cells = [f"{name} {memory[(name, size)]:.1f}" for name in trees]
        print(f"  {size:>5} x {size:<5} " + ", ".join(cells))
    print("\nlargest relative difference from the reference over the metrics:")
    for size in planes:
        old = values[("reference", size)]
        cells = []
        for name in trees:
            new = values[(name, size)]
            worst = max(
                0.0
                if (np.isnan(old[k]) and np.isnan(new[k]))
                else abs(new[k] - old[k]) / abs(old[k])
                for k in old
            )
            cells.append(f"{name} {worst:.1e}")
        print(f"  {size:>5} x {size:<5} " + ", ".join(cells))


if __name__ == "__main__":
    main()
