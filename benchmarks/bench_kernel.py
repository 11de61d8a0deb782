"""Speed of the labyrinth kernel: prints figures, asserts nothing.

Run with ``make bench`` or ``python benchmarks/bench_kernel.py``. Reports
Mpx/s per pass (best of several runs, JIT compilation excluded) for the
numba kernel alone, for ``labyrinth()`` (tone mapping and copies included)
and for the pure-Python oracle; import time; and the first call in a new
process with a cold and with a warm numba cache.
"""

import os
import subprocess
import sys
import tempfile
import time

import numpy as np


def camera(size, dtype):
    from skimage import data, transform

    image = transform.resize(data.camera(), (size, size), order=1, preserve_range=True)
    if dtype == np.uint16:
        return (image * 256).astype(np.uint16)
    return image.astype(np.uint8)


def best_of(fn, repeats):
    times = []
    for _ in range(repeats):
        start = time.perf_counter()
        fn()
        times.append(time.perf_counter() - start)
    return min(times)


def kernel_runner(image, preset):
    """A pass of the bare kernel on the image's tones, and the time of the copy it makes."""
    from napari_labyrinth import resolve_parameters
    from napari_labyrinth._engine import run_pass
    from napari_labyrinth.core.tone_scale import resolve_tone_scale

    parameters = resolve_parameters(preset)
    tones = resolve_tone_scale(image, None).to_tones(image)

    def run():
        run_pass(tones.copy(), parameters, has_nonfinite=False)

    copy_time = best_of(lambda: tones.copy(), 5)
    return run, copy_time


def subprocess_seconds(code, env):
    result = subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, env=env, check=True
    )
    return float(result.stdout.strip().splitlines()[-1])


def main():
    from napari_labyrinth import labyrinth
    from napari_labyrinth.api import resolve_parameters
    from napari_labyrinth.core._reference import reference_render

    print("labyrinth kernel benchmark: Mpx/s per pass, single thread, JIT compile excluded")
    print(
        f"{'preset':<11}{'image':<22}{'kernel Mpx/s':>14}{'labyrinth() Mpx/s':>20}{'changed':>10}"
    )
    for preset in ("paper", "labyrinth"):
        for size in (512, 2048, 4096):
            for dtype in (np.uint8, np.uint16):
                image = camera(size, dtype)
                run, copy_time = kernel_runner(image, preset)
                run()  # compile
                kernel = best_of(run, 7) - copy_time

                def render(image=image, preset=preset):
                    return labyrinth(image, preset=preset, passes=1)

                api = best_of(render, 3)
                changed = np.mean(render() != image)
                name = f"camera {size}^2 {np.dtype(dtype).name}"
                print(
                    f"{preset:<11}{name:<22}{image.size / kernel / 1e6:>14.0f}"
                    f"{image.size / api / 1e6:>20.0f}{changed:>10.2%}"
                )

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
    print(f"import + first call, new process, warm numba cache: {warm:.2f} s")


if __name__ == "__main__":
    main()
