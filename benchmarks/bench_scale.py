"""Memory and speed of the command line on a stack larger than memory: prints figures, asserts nothing.

Usage::

    python benchmarks/bench_scale.py                 # 5000 x 1024 x 1024 uint16: 10.5 GB
    python benchmarks/bench_scale.py --planes 200    # a quick run
    python benchmarks/bench_scale.py --workdir /big/disk --keep

1. Creates (once; reused while its parameters match) a uint16 zarr stack
   with one chunk per plane: a few distinct textured planes (ramps, ripples,
   blobs and noise over most of the 16-bit range), each plane shifted by a
   different amount, so that every plane is different and the rendering
   does real work.
2. Renders it zarr -> zarr with ``napari-labyrinth render`` in a subprocess,
   with ``--tone-limits`` (so the run is one read, one render and one write
   of every plane), and polls the resident memory of the whole process tree.
3. Renders it again with ``--scheduler local:W``: a LocalCluster of W
   single-threaded worker processes on 127.0.0.1, started and stopped by the
   command; the memory is summed over the client/scheduler process, the
   nannies and the workers.
4. Optionally (``--with-scan``) renders without ``--tone-limits``: one more
   streaming pass over the stack finds the default (percentile) limits.

Each run's output is spot-checked against ``labyrinth()`` on single planes
(``plane_offset``) and deleted unless ``--keep``.

Peak RSS is the largest sum, over the processes alive at a poll (every
0.1 s), of their resident set sizes: shared pages (numba, numpy, the Python
runtime) count once per process, so for the cluster it overstates the
memory actually used; PSS (proportional set size, polled every 0.5 s) shares
them out and is given beside it.
"""

from __future__ import annotations

import argparse
import os
import platform
import shutil
import subprocess
import sys
import tempfile
import threading
import time
from pathlib import Path

import numpy as np

#: Textured planes the stack is tiled from.
BASE_PLANES = 16


def textured_planes(size: int, count: int = BASE_PLANES, seed: int = 0) -> np.ndarray:
    """``count`` different uint16 planes: ramps, ripples, blobs and noise."""
    rng = np.random.default_rng(seed)
    y, x = np.mgrid[:size, :size].astype(np.float32) / size
    planes = np.empty((count, size, size), dtype=np.uint16)
    for k in range(count):
        angle = rng.uniform(0, np.pi)
        ramp = np.cos(angle) * x + np.sin(angle) * y
        ripple = np.sin(2 * np.pi * rng.uniform(3, 12) * (x + 0.3 * np.sin(2 * np.pi * y)))
        blobs = np.zeros_like(x)
        for _ in range(12):
            cy, cx, r = rng.uniform(0, 1), rng.uniform(0, 1), rng.uniform(0.02, 0.12)
            blobs += np.exp(-((y - cy) ** 2 + (x - cx) ** 2) / (2 * r * r))
        noise = rng.standard_normal(x.shape).astype(np.float32)
        value = 0.35 * ramp + 0.2 * ripple + 0.3 * blobs + 0.05 * noise
        value = (value - value.min()) / (value.max() - value.min())
        planes[k] = (2000 + 60000 * value).astype(np.uint16)
    return planes


def create_stack(path: Path, planes: int, size: int) -> float:
    """Create the input store unless a complete one is there; return seconds spent."""
    import zarr

    if path.exists():
        try:
            existing = zarr.open_array(str(path), mode="r")
            if existing.shape == (planes, size, size) and existing.attrs.get("complete"):
                return 0.0
        except Exception as exc:  # noqa: BLE001 - anything unreadable is made again
            print(f"  {path} is unreadable ({type(exc).__name__}): making it again")
        shutil.rmtree(path)
    start = time.perf_counter()
    base = textured_planes(size)
    array = zarr.create_array(
        store=str(path), shape=(planes, size, size), chunks=(1, size, size), dtype=np.uint16
    )
    batch = 32
    for first in range(0, planes, batch):
        count = min(batch, planes - first)
        block = np.empty((count, size, size), dtype=np.uint16)
        for j in range(count):
            i = first + j
            shift = ((i * 37) % size, (i * 91) % size)
            block[j] = np.roll(base[i % BASE_PLANES], shift, axis=(0, 1))
        array[first : first + count] = block
        print(f"\r  writing the input: {first + count}/{planes} planes", end="", flush=True)
    array.attrs["complete"] = True
    print()
    return time.perf_counter() - start


class TreeMemory:
    """Polls the summed RSS (and PSS) of a process and all its descendants."""

    def __init__(self, pid: int, interval: float = 0.1, pss_every: int = 5):
        import psutil

        self.root = psutil.Process(pid)
        self.interval = interval
        self.pss_every = pss_every
        self.peak_rss = 0
        self.peak_pss = 0
        self.peak_single = 0
        self.most_processes = 0
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._poll, daemon=True)

    def __enter__(self):
        self._thread.start()
        return self

    def __exit__(self, *exc):
        self._stop.set()
        self._thread.join()

    def _poll(self):
        import psutil

        tick = 0
        while not self._stop.is_set():
            try:
                processes = [self.root, *self.root.children(recursive=True)]
            except psutil.Error:
                break
            rss = pss = 0
            for process in processes:
                try:
                    value = process.memory_info().rss
                    rss += value
                    self.peak_single = max(self.peak_single, value)
                    if tick % self.pss_every == 0:
                        pss += process.memory_full_info().pss
                except psutil.Error:
                    continue
            self.peak_rss = max(self.peak_rss, rss)
            if tick % self.pss_every == 0:
                self.peak_pss = max(self.peak_pss, pss)
            self.most_processes = max(self.most_processes, len(processes))
            tick += 1
            self._stop.wait(self.interval)


def run_cli(argv: list[str], log: Path) -> dict:
    command = [sys.executable, "-m", "napari_labyrinth.cli", *argv]
    start = time.perf_counter()
    with open(log, "w") as out:
        process = subprocess.Popen(command, stdout=out, stderr=subprocess.STDOUT)
        with TreeMemory(process.pid) as memory:
            code = process.wait()
    seconds = time.perf_counter() - start
    if code != 0:
        print(log.read_text()[-2000:])
        raise SystemExit(f"the command failed with exit code {code}: {' '.join(command)}")
    return {
        "seconds": seconds,
        "rss": memory.peak_rss,
        "pss": memory.peak_pss,
        "single": memory.peak_single,
        "processes": memory.most_processes,
    }


def spot_check(source: Path, output: Path, planes: int, options: dict) -> str:
    import zarr

    from napari_labyrinth import labyrinth

    given = zarr.open_array(str(source), mode="r")
    result = zarr.open_array(str(output), mode="r")
    for k in sorted({0, planes // 2, planes - 1}):
        expected = labyrinth(given[k], plane_offset=k, **options)
        if not np.array_equal(result[k], expected):
            return f"MISMATCH at plane {k}"
    return "equal"


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--planes", type=int, default=5000, help="planes of the stack (5000)")
    parser.add_argument("--size", type=int, default=1024, help="rows = columns of a plane (1024)")
    parser.add_argument("--workdir", type=Path, help="where the stack lives (default: a temp dir)")
    parser.add_argument("--preset", default="paper", help="preset (default paper)")
    parser.add_argument("--passes", type=int, default=1, help="passes (default 1)")
    parser.add_argument("--workers", type=int, default=2, help="LocalCluster workers (2)")
    parser.add_argument("--skip-local", action="store_true", help="no run without a cluster")
    parser.add_argument("--skip-cluster", action="store_true", help="no LocalCluster run")
    parser.add_argument(
        "--with-scan", action="store_true", help="also a run that finds the default tone limits"
    )
    parser.add_argument("--keep", action="store_true", help="keep the outputs (and the stack)")
    args = parser.parse_args(argv)

    import dask
    import zarr

    import napari_labyrinth

    temporary = None
    if args.workdir is None:
        temporary = tempfile.mkdtemp(prefix="labyrinth-scale-")
        workdir = Path(temporary)
    else:
        workdir = args.workdir
        workdir.mkdir(parents=True, exist_ok=True)
    planes, size = args.planes, args.size
    source = workdir / f"stack-{planes}x{size}x{size}-uint16.zarr"
    raw_bytes = planes * size * size * 2
    megapixels = planes * size * size / 1e6

    print("napari-labyrinth scale benchmark (prints figures, asserts nothing)")
    print(
        f"machine: {os.cpu_count()} CPUs, {_total_memory() / 2**30:.1f} GiB RAM, "
        f"Python {platform.python_version()}, napari-labyrinth {napari_labyrinth.__version__}, "
        f"dask {dask.__version__}, zarr {zarr.__version__}"
    )
    print(
        f"stack: {planes} x {size} x {size} uint16 = {raw_bytes / 1e9:.2f} GB "
        f"({raw_bytes / 2**30:.2f} GiB) of pixels, one zarr chunk per plane, at {source}"
    )
    created = create_stack(source, planes, size)
    on_disk = _disk_usage(source)
    if created:
        print(
            f"  created in {created:.0f} s ({raw_bytes / created / 1e6:.0f} MB/s); "
            f"{on_disk / 1e9:.2f} GB on disk (zstd)"
        )
    else:
        print(f"  reused ({on_disk / 1e9:.2f} GB on disk)")

    limits = ["--tone-limits", "0", "65535"]
    common = ["--preset", args.preset, "--passes", str(args.passes), "--overwrite"]
    options = {"preset": args.preset, "passes": args.passes, "tone_limits": (0.0, 65535.0)}
    runs = []
    if not args.skip_local:
        runs.append((f"local threads ({os.cpu_count()})", [*limits]))
    if not args.skip_cluster:
        runs.append(
            (
                f"LocalCluster {args.workers} workers",
                [*limits, "--scheduler", f"local:{args.workers}"],
            )
        )
    if args.with_scan:
        runs.append(("local, default limits (scan)", []))

    rows = []
    for name, extra in runs:
        output = workdir / "rendered.zarr"
        print(f"running: {name} ...", flush=True)
        figures = run_cli(
            ["render", str(source), "-o", str(output), *common, *extra],
            workdir / "last-run.log",
        )
        if extra:
            check = spot_check(source, output, planes, options)
        else:  # default limits: as labyrinth() finds them on the whole stack
            check = "not checked"
        if not args.keep:
            shutil.rmtree(output, ignore_errors=True)
        rows.append((name, figures, check))
        print(
            f"  {figures['seconds']:.0f} s, peak RSS {figures['rss'] / 2**20:.0f} MiB, "
            f"planes {check}",
            flush=True,
        )

    print()
    print(
        f"preset {args.preset}, {args.passes} pass(es); zarr -> zarr; "
        f"{planes} planes of {size} x {size}"
    )
    header = (
        f"{'run':<34}{'wall s':>8}{'planes/s':>10}{'Mpx/s':>8}"
        f"{'peak RSS sum':>14}{'largest proc':>14}{'peak PSS sum':>14}{'procs':>7}  result"
    )
    print(header)
    print("-" * len(header))
    for name, figures, check in rows:
        seconds = figures["seconds"]
        print(
            f"{name:<34}{seconds:>8.0f}{planes / seconds:>10.1f}{megapixels / seconds:>8.1f}"
            f"{_mib(figures['rss']):>14}{_mib(figures['single']):>14}{_mib(figures['pss']):>14}"
            f"{figures['processes']:>7}  {check}"
        )
    if temporary is not None and not args.keep:
        shutil.rmtree(temporary, ignore_errors=True)


def _mib(value: int) -> str:
    return f"{value / 2**20:.0f} MiB"


def _total_memory() -> int:
    import psutil

    return psutil.virtual_memory().total


def _disk_usage(path: Path) -> int:
    return sum(f.stat().st_blocks * 512 for f in path.rglob("*") if f.is_file())


if __name__ == "__main__":
    main()
