"""One plane on one thread: C reference, numba kernel, ``labyrinth()``. Prints, asserts nothing.

For each preset, dtype (uint8, uint16) and pass count (1, 4) on a camera image
of ``--size``² pixels, three variants are timed *interleaved* (one run of each
in turn, ``--repeats`` rounds, best kept), so that a load that comes and goes
on a shared machine disturbs them alike:

- ``C``: ``c_reference.c`` (gcc -O3 -march=native
  -ffp-contract=off), the same readings; checked bit for bit against the
  kernel first (planes and counts). Skipped, saying so, without a compiler.
- ``kernel``: ``_engine.run_pass`` on the tones (what a pass costs).
- ``labyrinth()``: the public call on the integer image, one worker: tone
  limits, tones, passes, write-back.

Each variant's input is a fresh copy made (untimed) just before it runs: the
kernel's must be (the pass works in place), and a fresh copy lies in the
processor's cache, so the others' are too.

Figures are Mpx/s per pass (wall clock, and thread CPU time, which a busy
machine disturbs less) and ratios; the load average is printed beside them.
Also: the pure-Python oracle, import time and the first call in a new
process (cold and warm numba cache); with ``--overhead``, the steps of
``labyrinth()`` around the pass timed on their own (paper, uint16, 1 pass: the
engine's render with the tone scale given, the default tone limits, ...),
the default tone limits just after a pass, again at once and with the caches
evicted, and the default tone limits of seventeen uint16 images (photographs, textures,
noise, a dark field: the route each takes); with ``--images``, ``labyrinth()``
against the kernel on those images too (1 pass, both presets).
Run: ``make bench`` or ``python benchmarks/bench_kernel.py [--size 2048]
[--repeats 7] [--overhead] [--images]``.
"""

from __future__ import annotations

import argparse
import functools
import os
import pathlib
import subprocess
import sys
import tempfile
import time

import numpy as np

sys.path.insert(0, str(pathlib.Path(__file__).parent))

import c_reference  # noqa: E402


def camera(size, dtype):
    from skimage import data, transform

    image = transform.resize(data.camera(), (size, size), order=1, preserve_range=True)
    if dtype == np.uint16:
        return (image * 256).astype(np.uint16)
    return image.astype(np.uint8)


def load():
    return "load %.2f %.2f %.2f" % os.getloadavg()


def interleaved(variants, repeats, *, warm=False):
    """Best wall and thread-CPU seconds of each variant, run in turn ``repeats`` times.

    A variant is ``(prepare, run)``: ``prepare()`` (untimed) returns the
    argument of ``run``. With ``warm``, each runs once untimed first (numba
    compiles or loads its cache).
    """
    if warm:
        for prepare, run in variants.values():
            run(prepare())
    wall = dict.fromkeys(variants, np.inf)
    cpu = dict.fromkeys(variants, np.inf)
    for _ in range(repeats):
        for name, (prepare, run) in variants.items():
            argument = prepare()
            start, start_cpu = time.perf_counter(), time.thread_time()
            run(argument)
            cpu[name] = min(cpu[name], time.thread_time() - start_cpu)
            wall[name] = min(wall[name], time.perf_counter() - start)
    return wall, cpu


def check_c_against_kernel(c, image, parameters, passes):
    """True if the C reference gives the kernel's planes and counts, bit for bit."""
    from napari_labyrinth._engine import run_pass
    from napari_labyrinth.core.tone_scale import resolve_tone_scale

    tones = resolve_tone_scale(image, None).to_tones(image)
    a, b = tones.copy(), tones.copy()
    for pass_index in range(passes):
        counts_a = run_pass(a, parameters, seed=7, plane_index=2, pass_index=pass_index)
        counts_b = c.run_pass(b, parameters, seed=7, plane_index=2, pass_index=pass_index)
        if not np.array_equal(counts_a, counts_b):
            return False
    with_holes = tones[:300, :301].copy()
    with_holes[::17, ::13] = np.nan
    a, b = with_holes.copy(), with_holes.copy()
    same_holes = np.array_equal(run_pass(a, parameters), c.run_pass(b, parameters))
    return same_holes and np.array_equal(a.view(np.uint32), b.view(np.uint32))


def bench_variants(size, repeats, c):
    from napari_labyrinth import labyrinth, resolve_parameters
    from napari_labyrinth._engine import run_pass
    from napari_labyrinth.core.tone_scale import resolve_tone_scale

    print(f"one {size}^2 plane, one thread; Mpx/s per pass, best of {repeats} interleaved rounds")
    if c is not None:
        print(f"C reference: {c.command}")
    header = (
        f"{'preset':<10}{'dtype':<7}{'passes':>6}{'C':>8}{'kernel':>8}{'labyr.()':>9}"
        f"{'kernel/C':>9}{'api/kernel':>11}{'  (CPU time:':>13}{'kernel/C':>9}{'api/kernel':>11}"
        f"{')':<2}{'C same':>7}  load"
    )
    print(header)
    for preset in ("paper", "labyrinth"):
        parameters = resolve_parameters(preset)
        for dtype in (np.uint8, np.uint16):
            image = camera(size, dtype)
            tones = resolve_tone_scale(image, None).to_tones(image)
            for passes in (1, 4):
                p = resolve_parameters(preset, passes=passes)

                def kernel(work, parameters=p):
                    for pass_index in range(parameters.passes):
                        run_pass(work, parameters, pass_index=pass_index, has_nonfinite=False)

                # every variant gets a fresh copy of its input, made just before it runs
                # (untimed): the kernel's must be a copy (the pass is in place), and
                # the copy leaves the input in the cache; the others' alike
                variants = {
                    "kernel": (tones.copy, kernel),
                    "api": (
                        image.copy,
                        lambda image, preset=preset, passes=passes: labyrinth(
                            image, preset=preset, passes=passes, workers=1
                        ),
                    ),
                }
                same = "-"
                if c is not None:
                    same = "yes" if check_c_against_kernel(c, image, p, passes) else "NO"

                    def c_pass(work, parameters=p):
                        for pass_index in range(parameters.passes):
                            c.run_pass(
                                work, parameters, pass_index=pass_index, has_nonfinite=False
                            )

                    variants["C"] = (tones.copy, c_pass)
                kernel(tones.copy())  # compile
                variants["api"][1](image)
                wall, cpu = interleaved(variants, repeats)
                rate = {name: image.size * passes / t / 1e6 for name, t in wall.items()}
                c_rate = f"{rate['C']:>8.0f}" if c is not None else f"{'-':>8}"
                c_ratio = f"{wall['C'] / wall['kernel']:>9.2f}" if c is not None else f"{'-':>9}"
                c_cpu = f"{cpu['C'] / cpu['kernel']:>9.2f}" if c is not None else f"{'-':>9}"
                print(
                    f"{preset:<10}{np.dtype(dtype).name:<7}{passes:>6}{c_rate}"
                    f"{rate['kernel']:>8.0f}{rate['api']:>9.0f}{c_ratio}"
                    f"{wall['kernel'] / wall['api']:>11.2f}{'':>13}{c_cpu}"
                    f"{cpu['kernel'] / cpu['api']:>11.2f}{'':<2}{same:>7}  {load()}"
                )
    print("kernel/C and api/kernel are throughput ratios (targets: >= 0.85 and >= 0.9)")


def bench_overhead(size, repeats, dtype):
    """What ``labyrinth()`` does around the pass (paper, ``dtype``, 1 pass), interleaved:
    the kernel alone, the whole call, the steps before the pass on their own, and the
    least work any ``labyrinth()`` must add to the pass."""
    from napari_labyrinth import labyrinth, resolve_parameters
    from napari_labyrinth._engine import render, run_pass, run_to_end
    from napari_labyrinth.core import presets
    from napari_labyrinth.core.percentiles import linear_ranks, tail_rank_values
    from napari_labyrinth.core.planes import PlaneLayout
    from napari_labyrinth.core.tone_scale import DEFAULT_PERCENTILES, resolve_tone_scale

    image = camera(size, dtype)
    parameters = resolve_parameters("paper", passes=1)
    scale = resolve_tone_scale(image, None)
    tones = scale.to_tones(image)
    layout = PlaneLayout(image.shape, None)
    ranks, _ = linear_ranks(image.size, DEFAULT_PERCENTILES)
    variants = {
        "kernel (run_pass on the tones)": (
            tones.copy,
            lambda work: run_pass(work, parameters, has_nonfinite=False),
        ),
        "labyrinth()": (
            image.copy,
            lambda values: labyrinth(values, preset="paper", passes=1, workers=1),
        ),
        "the engine's render, scale given": (
            image.copy,
            lambda values: run_to_end(
                render(values, layout, scale, parameters, 0, record_passes=False)
            ),
        ),
        "default tone limits": (image.copy, lambda values: resolve_tone_scale(values, None)),
        "  the same by two sweeps": (
            image.copy,
            lambda values: tail_rank_values(values.reshape(-1), ranks),
        ),
        "resolve_parameters, first call": (
            image.copy,
            lambda values: (presets._RESOLVED.clear(), resolve_parameters("paper", passes=1)),
        ),
        "resolve_parameters, again": (
            image.copy,
            lambda values: resolve_parameters("paper", passes=1),
        ),
        "least: a read of every value": (image.copy, np.ndarray.max),
        "least: tones and a copy, no pass": (
            image.copy,
            lambda values: tones_and_copy(values, scale),
        ),
    }
    wall, _ = interleaved(variants, repeats, warm=True)
    name = np.dtype(dtype).name
    print(f"\nlabyrinth() around the pass: paper, {name}, 1 pass, {size}^2, one thread;")
    print(f"best of {repeats} interleaved rounds, each step on a fresh copy of the image")
    for name, seconds in wall.items():
        print(f"  {name:<34}{seconds * 1e3:>8.3f} ms")
    kernel = wall["kernel (run_pass on the tones)"]
    engine = wall["the engine's render, scale given"]
    around = wall["labyrinth()"] - kernel
    print(f"  {'labyrinth() - kernel':<34}{around * 1e3:>8.3f} ms  ({load()})")
    print(f"    {'of which tones in, values out':<32}{(engine - kernel) * 1e3:>8.3f} ms"
          " (the engine's render - kernel)")  # fmt: skip
    print(f"    {'and tone limits, call, checks':<32}{(wall['labyrinth()'] - engine) * 1e3:>8.3f}"
          " ms (labyrinth() - the engine's render)")  # fmt: skip
    least = wall["least: a read of every value"] + wall["least: tones and a copy, no pass"]
    print(f"  {'least any labyrinth() adds':<34}{least * 1e3:>8.3f} ms (a read for exact limits,"
          " then tones and the result's values)")  # fmt: skip
    print(f"    so api/kernel can be at most {kernel / (kernel + least):.3f}; it is"
          f" {kernel / wall['labyrinth()']:.3f}")  # fmt: skip
    if dtype == np.uint16:
        bench_limits_in_situ(image, tones, parameters, repeats)


def tones_and_copy(values, scale):
    """What ``labyrinth()`` must do to an integer plane beside its pass, and no more: make the
    tones of every row (band by band into a ring, as the banded pass does) and copy the
    values into a new array (the result, before the few changes are written)."""
    from napari_labyrinth.core._banded_pass import band_rows
    from napari_labyrinth.core.tone_scale import integer_scale

    rows = band_rows(values.shape[1])
    ring = np.empty((rows + 2, values.shape[1]), np.float32)
    target = np.empty_like(values)
    _banded_tones_and_copy()(values, ring, target, rows, integer_scale(scale, values.dtype))
    return target


@functools.cache
def _banded_tones_and_copy():
    """The loop of :func:`tones_and_copy`, compiled on its first call."""
    from numba import njit

    from napari_labyrinth.core._banded_pass import _make_tones_and_copy

    @njit(nogil=True)
    def bands(values, ring, target, rows, scale):
        height = values.shape[0]
        for start in range(0, height, rows):
            stop = min(height, start + rows)
            _make_tones_and_copy(values, ring, target, start, stop, start, scale)

    return bands


def bench_limits_in_situ(image, tones, parameters, repeats):
    """The default tone limits (one sweep over the image's values) where ``labyrinth()``
    finds them, just after a pass and a copy of the image (as in the first table), against
    the same sweep again at once, and with the caches evicted; and a plain read of every
    value (their greatest, ``ndarray.max``) just after a pass and a copy: what the memory
    costs, the rest being the sweep's own work."""
    from napari_labyrinth._engine import run_pass
    from napari_labyrinth.core.tone_scale import default_percentiles

    evict = np.zeros(64 << 20, np.uint8)  # twice the last-level cache
    read = "  a read of every value (their max)"
    seconds = {
        "after a pass and a copy": [], "the same again (hot)": [], "caches evicted": [], read: []
    }  # fmt: skip

    def timed(name, values, step=default_percentiles):
        start = time.perf_counter()
        step(values)
        seconds[name].append(time.perf_counter() - start)

    for _ in range(repeats):
        run_pass(tones.copy(), parameters, has_nonfinite=False)
        values = image.copy()
        timed("after a pass and a copy", values)
        timed("the same again (hot)", values)
        evict[::64] += 1
        timed("caches evicted", values)
        run_pass(tones.copy(), parameters, has_nonfinite=False)
        timed(read, image.copy(), np.ndarray.max)
    print(f"default tone limits of the {image.nbytes >> 20} MB of values, {repeats} rounds:")
    for name, times in seconds.items():
        print(f"  {name:<36}best {min(times) * 1e3:.3f} ms, median"
              f" {np.median(times) * 1e3:.3f} ms")  # fmt: skip


#: scikit-image's own images (shipped with it) that ``other_images`` renders: photographs,
#: textures, a scan, a micrograph, a sky survey, a silhouette.
PHOTOGRAPHS = (
    "coins", "astronaut", "moon", "page", "text", "brick", "grass", "gravel", "retina",
    "rocket", "hubble_deep_field", "immunohistochemistry", "horse",
)  # fmt: skip


def other_images(size):
    """uint16 planes of ``size`` x ``size``: the :data:`PHOTOGRAPHS` (grey, resized, values
    times 250) and synthetic planes (noise, a gradient with noise, a dark field)."""
    from skimage import color, data, transform

    images = {"camera": camera(size, np.uint16)}
    for name in PHOTOGRAPHS:
        image = getattr(data, name)()
        if image.ndim == 3:
            image = color.rgb2gray(image[..., :3]) * 255
        image = transform.resize(image.astype(float), (size, size), order=1, preserve_range=True)
        images[name] = (image * 250).astype(np.uint16)
    rng = np.random.default_rng(0)
    ramp = np.add.outer(np.arange(size), np.arange(size)) * (16384 // size)
    images["noise"] = rng.integers(0, 65536, (size, size)).astype(np.uint16)
    images["gradient + noise"] = (ramp + rng.integers(0, 500, (size, size))).astype(np.uint16)
    images["dark field, 0.3 % bright"] = np.where(
        rng.random((size, size)) < 0.003, 60000, 100 + rng.integers(0, 20, (size, size))
    ).astype(np.uint16)
    return images


def tone_limit_route(image):
    """Which route ``integer_percentiles`` takes for the default tone limits of ``image``."""
    from napari_labyrinth.core.percentiles import (
        linear_ranks,
        sampled_rank_values,
        tail_rank_values,
    )
    from napari_labyrinth.core.tone_scale import DEFAULT_PERCENTILES

    flat = image.reshape(-1)
    ranks, _ = linear_ranks(flat.size, DEFAULT_PERCENTILES)
    if sampled_rank_values(flat, ranks) is not None:
        return "one sweep"
    return "two sweeps" if tail_rank_values(flat, ranks) is not None else "count all"


def bench_tone_limits(size, repeats):
    """The default tone limits of uint16 images: ``integer_percentiles`` (its one-sweep
    route, else the two sweeps, else a count of every value) against the two sweeps
    alone (then the count where they give up), interleaved; the route each image takes."""
    from napari_labyrinth.core._tone_loops import count_values
    from napari_labyrinth.core.percentiles import (
        integer_percentiles,
        linear_ranks,
        tail_rank_values,
    )
    from napari_labyrinth.core.tone_scale import DEFAULT_PERCENTILES

    def two_sweeps(values):
        flat = values.reshape(-1)
        ranks, _ = linear_ranks(flat.size, DEFAULT_PERCENTILES)
        if tail_rank_values(flat, ranks) is None:
            count_values(flat, 0, np.zeros(65536, np.int64))

    print(f"\ndefault tone limits of {size}^2 uint16 images, best of {repeats} interleaved")
    for name, image in other_images(size).items():
        variants = {
            "integer_percentiles": (
                image.copy,
                lambda values: integer_percentiles(values, DEFAULT_PERCENTILES),
            ),
            "two sweeps": (image.copy, two_sweeps),
        }
        wall, _ = interleaved(variants, repeats, warm=True)
        print(
            f"  {name:<26}{tone_limit_route(image):<11}integer_percentiles"
            f" {wall['integer_percentiles'] * 1e3:6.3f} ms, two sweeps"
            f" {wall['two sweeps'] * 1e3:6.3f} ms  ({load()})"
        )


def bench_images(size, repeats):
    """``labyrinth()`` against the kernel alone, 1 pass, one thread, on each of
    :func:`other_images`, both presets: how the ratio of the first table holds on inputs
    whose tone limits take other routes and whose passes take other times."""
    from napari_labyrinth import labyrinth, resolve_parameters
    from napari_labyrinth._engine import run_pass
    from napari_labyrinth.core.tone_scale import resolve_tone_scale

    print(f"\nlabyrinth() / kernel on other {size}^2 uint16 images, 1 pass, one thread")
    print(f"  {'image':<26}{'tone limits':<12}{'preset':<10}{'kernel ms':>10}{'labyr.() ms':>12}"
          f"{'api/kernel':>11}")  # fmt: skip
    for name, image in other_images(size).items():
        tones = resolve_tone_scale(image, None).to_tones(image)
        route = tone_limit_route(image)
        for preset in ("paper", "labyrinth"):
            parameters = resolve_parameters(preset, passes=1)
            variants = {
                "kernel": (
                    tones.copy,
                    lambda work, p=parameters: run_pass(work, p, has_nonfinite=False),
                ),
                "api": (
                    image.copy,
                    lambda values, preset=preset: labyrinth(
                        values, preset=preset, passes=1, workers=1
                    ),
                ),
            }
            wall, _ = interleaved(variants, repeats, warm=True)
            print(
                f"  {name:<26}{route:<12}{preset:<10}"
                f"{wall['kernel'] * 1e3:>10.2f}{wall['api'] * 1e3:>12.2f}"
                f"{wall['kernel'] / wall['api']:>11.2f}  ({load()})"
            )


def subprocess_seconds(code, env):
    result = subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, env=env, check=True
    )
    return float(result.stdout.strip().splitlines()[-1])


def bench_start_up():
    from napari_labyrinth.api import resolve_parameters
    from napari_labyrinth.core._reference import reference_render

    small = camera(512, np.uint8)[:64, :64].astype(np.float32)
    start = time.perf_counter()
    reference_render(small, resolve_parameters("paper"))
    oracle = time.perf_counter() - start
    print(f"pure-Python oracle, camera 64^2: {small.size / oracle / 1e6:.3f} Mpx/s")

    env = dict(os.environ)
    import_code = (
        "import time; t = time.perf_counter(); import napari_labyrinth;"
        "print(time.perf_counter() - t)"
    )
    imports = [subprocess_seconds(import_code, env) for _ in range(3)]
    print(f"import napari_labyrinth: {min(imports):.3f} s (best of 3)")
    first_call = (
        "import time; t = time.perf_counter(); import numpy as np; from napari_labyrinth import"
        " labyrinth; labyrinth(np.zeros((64, 64), np.uint8)); print(time.perf_counter() - t)"
    )
    with tempfile.TemporaryDirectory() as cache:
        env["NUMBA_CACHE_DIR"] = cache
        cold = subprocess_seconds(first_call, env)
        warm = subprocess_seconds(first_call, env)
    print(f"import + first call, new process, cold numba cache (JIT compile): {cold:.2f} s")
    print(f"import + first call, new process, warm numba cache: {warm:.2f} s  ({load()})")


def compile_counting():
    """Compile the counting of default tone limits for the dtypes timed: warm, labyrinth()
    counts them (a process whose counting kernel is neither compiled nor in numba's cache
    takes ``np.percentile``, ``percentiles.counting_pays``)."""
    from napari_labyrinth.core.percentiles import integer_percentiles

    for dtype in (np.uint8, np.uint16):
        integer_percentiles(camera(512, dtype), (1.0, 99.0))


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--size", type=int, default=2048)
    parser.add_argument("--repeats", type=int, default=7)
    parser.add_argument("--no-start-up", action="store_true", help="skip oracle and start-up")
    parser.add_argument(
        "--overhead", action="store_true", help="also time the steps around the pass"
    )
    parser.add_argument(
        "--images", action="store_true", help="also labyrinth() / kernel on other images"
    )
    args = parser.parse_args(argv)
    print(f"{os.cpu_count()} cores, {load()}")
    compile_counting()
    bench_variants(args.size, args.repeats, c_reference.load())
    if args.overhead:
        for dtype in (np.uint16, np.uint8):
            bench_overhead(args.size, 3 * args.repeats, dtype)
        bench_tone_limits(args.size, 2 * args.repeats)
    if args.images:
        bench_images(args.size, args.repeats)
    if not args.no_start_up:
        bench_start_up()


if __name__ == "__main__":
    main()
