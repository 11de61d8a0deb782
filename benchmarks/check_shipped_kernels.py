"""Check an install's shipped kernels: the first calls compile nothing and match the JIT's.

Run with the Python of an environment where a platform wheel was installed (the release
workflow does so in a fresh venv per wheel; ``make test-install`` here)::

    python benchmarks/check_shipped_kernels.py

Each first call below runs twice, each time in a new process with a new, empty numba
cache directory: once as installed (the shipped kernels) and once with
``NAPARI_LABYRINTH_SHIPPED_KERNELS=0`` (numba compiles them, the JIT). The table gives,
per call, the kernels numba compiled in each process (``NAPARI_LABYRINTH_COMPILE_LOG``),
the first call's time in each, and whether the results' digests are equal. Exits 1 if
the shipped kernels are refused here (the reason printed), if any call compiled a kernel
with them, or if any result differs; 0 otherwise. Prints, asserts nothing else.
"""

from __future__ import annotations

import argparse
import hashlib
import json
import os
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

MARK = "SHIPPED-CHECK "

#: The calls, each a first call of its own process.
CALLS = (
    "labyrinth-u8",
    "labyrinth-u16",
    "labyrinth-f32",
    "labyrinth-paper-u16",
    "labyrinth-1-worker-u16",
    "labyrinth-rgb-u8",
    "labyrinth_stack-u16",
    "labyrinth_sweep-u16",
    "describe",
    "find_window",
    "cli-render",
)


def _image(dtype_name: str, side: int = 512):
    import numpy as np

    rows, columns = np.indices((side, side))
    field = 0.5 + 0.4 * np.sin(columns / 3.0 + np.sin(rows / 9.0))
    field = np.clip(field + np.random.default_rng(1).normal(0, 0.02, field.shape), 0, 1)
    dtype = np.dtype(dtype_name)
    if dtype.kind in "iu":
        return (field * np.iinfo(dtype).max).astype(dtype)
    return field.astype(dtype)


def _load() -> str:
    """The 1-minute load average, where the system keeps one (not on Windows)."""
    try:
        return f"{os.getloadavg()[0]:.2f}"
    except (AttributeError, OSError):
        return "n/a"


def _digest(*arrays) -> str:
    import numpy as np

    digest = hashlib.sha256()
    for array in arrays:
        array = np.ascontiguousarray(array)
        digest.update(str((array.dtype, array.shape)).encode() + array.tobytes())
    return digest.hexdigest()[:16]


def run_call(name: str) -> dict:
    """One first call, in this process: its result's digest and its time."""
    import numpy as np

    import napari_labyrinth as nl
    from napari_labyrinth import metrics
    from napari_labyrinth.core._shipped import shipped

    dtypes = {"u8": "uint8", "u16": "uint16", "f32": "float32"}
    start = time.perf_counter()
    if name.startswith("labyrinth-") and name.count("-") == 1:
        result = nl.labyrinth(_image(dtypes[name.split("-")[1]]), seed=3)
    elif name == "labyrinth-paper-u16":
        result = nl.labyrinth(_image("uint16"), preset="paper", seed=3)
    elif name == "labyrinth-1-worker-u16":
        result = nl.labyrinth(_image("uint16"), workers=1, passes=2, seed=3)
    elif name == "labyrinth-rgb-u8":
        rgb = np.stack([_image("uint8"), _image("uint8")[::-1], _image("uint8").T], axis=-1)
        result = nl.labyrinth(rgb, channel_axis=-1, seed=3)
    elif name == "labyrinth_stack-u16":
        result = nl.labyrinth_stack(_image("uint16"), passes=3)
    elif name == "labyrinth_sweep-u16":
        result = nl.labyrinth_sweep(_image("uint16"), "variance_threshold", [0.03, 0.05])
    elif name == "describe":
        image = _image("uint8")
        values = metrics.describe(image, nl.labyrinth(image))
        result = np.array([values[key] for key in sorted(values)])
    elif name == "find_window":
        window = nl.find_window(_image("uint16"))
        result = np.array([window.low, window.high, window.best], dtype=float)
    elif name == "cli-render":
        import imageio.v3 as iio

        work = Path(tempfile.mkdtemp(prefix="shipped-check-"))
        try:
            iio.imwrite(work / "in.png", _image("uint8"))
            command = [str(Path(sys.executable).with_name("napari-labyrinth")), "render",
                       str(work / "in.png"), "-o", str(work / "out.png")]  # fmt: skip
            if not Path(command[0]).exists():
                command[:1] = [sys.executable, "-m", "napari_labyrinth.cli"]
            subprocess.run(command, check=True, capture_output=True)
            result = iio.imread(work / "out.png")
        finally:
            shutil.rmtree(work, ignore_errors=True)
    else:
        raise ValueError(name)
    seconds = time.perf_counter() - start
    return {
        "digest": _digest(result),
        "seconds": seconds,
        "refused": shipped().refused,
        "file": nl.__file__,
    }


def _spawn(name: str, shipped: bool) -> dict:
    cache = Path(tempfile.mkdtemp(prefix="shipped-check-numba-"))
    log = cache.parent / f"{cache.name}.compiled"
    env = dict(os.environ, NUMBA_CACHE_DIR=str(cache), NAPARI_LABYRINTH_COMPILE_LOG=str(log))
    env.pop("NUMBA_CPU_NAME", None)
    env.pop("NUMBA_CPU_FEATURES", None)
    if shipped:
        env.pop("NAPARI_LABYRINTH_SHIPPED_KERNELS", None)
    else:
        env["NAPARI_LABYRINTH_SHIPPED_KERNELS"] = "0"
    try:
        done = subprocess.run(
            [sys.executable, str(Path(__file__).resolve()), "--child", name],
            env=env, capture_output=True, text=True, timeout=900, check=False,
        )  # fmt: skip
        lines = [line for line in done.stdout.splitlines() if line.startswith(MARK)]
        if done.returncode != 0 or not lines:
            tail = (done.stderr.strip().splitlines() or ["no output"])[-1]
            return {"error": f"exit {done.returncode}: {tail[:160]}"}
        result = json.loads(lines[0][len(MARK) :])
        compiled = log.read_text().splitlines() if log.exists() else []
        result["compiled"] = [line.split("\t")[0] for line in compiled]
        return result
    finally:
        shutil.rmtree(cache, ignore_errors=True)
        log.unlink(missing_ok=True)


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--calls", nargs="+", choices=CALLS, default=list(CALLS))
    parser.add_argument("--child", help=argparse.SUPPRESS)
    args = parser.parse_args(argv)
    if args.child:
        print(MARK + json.dumps(run_call(args.child)), flush=True)
        return 0

    import numba

    import napari_labyrinth
    from napari_labyrinth.core._shipped import platform_key

    print(
        f"napari-labyrinth {napari_labyrinth.__version__} from {Path(napari_labyrinth.__file__).parent}"
        f"\nnumba {numba.__version__}, Python {sys.version.split()[0]}, {platform_key()}, "
        f"load {_load()}, cores {os.cpu_count()}"
    )
    print(f"\n{'call':<24}| {'compiled':>8} | {'first s':>7} | {'JIT compiled':>12} | "
          f"{'JIT first s':>11} | same")  # fmt: skip
    failures = []
    for name in args.calls:
        shipped, jit = _spawn(name, shipped=True), _spawn(name, shipped=False)
        for label, result in (("shipped", shipped), ("JIT", jit)):
            if "error" in result:
                failures.append(f"{name} ({label}): {result['error']}")
        if "error" in shipped or "error" in jit:
            print(f"{name:<24}| failed")
            continue
        if shipped["refused"]:
            failures.append(f"{name}: the shipped kernels are refused: {shipped['refused']}")
        if shipped["compiled"]:
            failures.append(f"{name}: compiled {', '.join(sorted(set(shipped['compiled'])))}")
        same = shipped["digest"] == jit["digest"]
        if not same:
            failures.append(f"{name}: results differ ({shipped['digest']} != {jit['digest']})")
        print(
            f"{name:<24}| {len(shipped['compiled']):>8} | {shipped['seconds']:>7.2f} | "
            f"{len(jit['compiled']):>12} | {jit['seconds']:>11.2f} | {'yes' if same else 'NO'}",
            flush=True,
        )
    print(f"\nload {_load()}")
    for failure in failures:
        print(f"FAILED {failure}")
    print("the shipped kernels: " + ("FAILED" if failures else "every first call compiled "
                                      "nothing and matched the JIT bit for bit"))  # fmt: skip
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main())
