"""A plane larger than memory rendered band by band, against the in-memory rendering. Prints.

A smooth random texture (a few random waves and a little noise, computed from
each pixel's coordinates: the generator holds one band) is written band by
band into a uint16 zarr store of ``--size``² pixels, chunked by bands of rows.
Each row of the table is one ``napari-labyrinth render in.zarr -o out.zarr``,
the whole command as a child process (its wall time, and its peak resident
memory: ``ru_maxrss`` from ``os.wait4``):

- ``streamed``: with ``NAPARI_LABYRINTH_MEMORY=--budget``, under which the
  plane's rendering in memory does not fit: read, rendered and written band by
  band (``streaming.render_plane_file``);
- ``in memory``: without a budget (the machine's memory): the plane is a block
  of a lazy zarr input, rendered whole in memory and written.

Both find the default tone limits in a streamed pass first, as the command
does. The two run interleaved, ``--repeat`` times each, best time kept; their
outputs are compared pixel for pixel, band by band. ``--no-in-memory`` runs
the streamed command only (a plane the machine cannot render in memory:
``--size 40000``). Throughput is pixels over the command's wall time. The
1-minute load average is printed with each row (2 cores shared: compare rows
run side by side).

Run: ``python benchmarks/bench_stream_plane.py [--size 8000] [--preset paper labyrinth]
[--repeat 2] [--budget 1G] [--no-in-memory] [--dir /tmp]``.
"""

from __future__ import annotations

import argparse
import os
import pathlib
import shutil
import subprocess
import sys
import tempfile
import time

import numpy as np

ROOT = pathlib.Path(__file__).resolve().parent.parent
#: Rows of the input's chunks (and of the bands it is generated in).
CHUNK_ROWS = 128


def write_texture(path: pathlib.Path, size: int, seed: int = 0) -> None:
    """A ``size``² uint16 smooth random texture, written band by band into a zarr store."""
    import zarr

    rng = np.random.default_rng(seed)
    waves = 12
    frequency = rng.uniform(0.002, 0.05, (waves, 2)) * rng.choice([-1, 1], (waves, 2))
    phase = rng.uniform(0, 2 * np.pi, waves)
    weight = rng.uniform(0.5, 1.0, waves)
    target = zarr.create_array(
        store=str(path), shape=(size, size), chunks=(CHUNK_ROWS, size), dtype="u2"
    )
    x = np.arange(size, dtype=np.float64)
    # sin(a y + b x + p) = sin(a y + p) cos(b x) + cos(a y + p) sin(b x): two products a wave
    across = [(np.cos(f[1] * x).astype(np.float32), np.sin(f[1] * x).astype(np.float32))
              for f in frequency]  # fmt: skip
    for start in range(0, size, CHUNK_ROWS):
        y = np.arange(start, min(size, start + CHUNK_ROWS), dtype=np.float64)
        band = rng.standard_normal((len(y), size), dtype=np.float32)
        band *= 0.3
        for k in range(waves):
            down = weight[k] * np.sin(frequency[k, 0] * y + phase[k]).astype(np.float32)
            down_cos = weight[k] * np.cos(frequency[k, 0] * y + phase[k]).astype(np.float32)
            band += down[:, None] * across[k][0]
            band += down_cos[:, None] * across[k][1]
        band = (band / (2 * weight.sum()) + 0.5) * 50000 + 5000
        target[start : start + len(y)] = np.clip(band, 0, 65535).astype(np.uint16)


def run_command(source, output, preset, budget) -> tuple[float, float, str]:
    """One render as a child process: wall seconds, peak RSS (MB), its stderr's last line."""
    env = dict(os.environ, NAPARI_LABYRINTH_NO_WARMUP="1")
    env["PYTHONPATH"] = os.pathsep.join([str(ROOT / "src"), env.get("PYTHONPATH", "")])
    env.pop("NAPARI_LABYRINTH_MEMORY", None)
    if budget:
        env["NAPARI_LABYRINTH_MEMORY"] = budget
    shutil.rmtree(output, ignore_errors=True)
    command = [sys.executable, "-m", "napari_labyrinth.cli", "render", str(source), "-o",
               str(output), "--preset", preset]  # fmt: skip
    with tempfile.TemporaryFile() as errors:
        start = time.perf_counter()
        child = subprocess.Popen(command, env=env, stdout=subprocess.DEVNULL, stderr=errors)
        _, status, usage = os.wait4(child.pid, 0)
        seconds = time.perf_counter() - start
        child.returncode = os.waitstatus_to_exitcode(status)
        errors.seek(0)
        text = errors.read().decode(errors="replace").strip().splitlines()
    if child.returncode != 0:
        raise SystemExit(f"{' '.join(command)} failed:\n" + "\n".join(text[-5:]))
    streamed = any("rendered band by band" in line for line in text)
    return seconds, usage.ru_maxrss / 1024, "streamed" if streamed else "in memory"


def identical(first: pathlib.Path, second: pathlib.Path) -> bool:
    """Whether two zarr outputs hold the same pixels (compared band by band)."""
    import zarr

    a, b = zarr.open_array(str(first), mode="r"), zarr.open_array(str(second), mode="r")
    if a.shape != b.shape or a.dtype != b.dtype:
        return False
    step = 1024
    return all(
        np.array_equal(a[start : start + step], b[start : start + step])
        for start in range(0, a.shape[0], step)
    )


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--size", type=int, default=8000)
    parser.add_argument("--preset", nargs="+", default=["paper", "labyrinth"])
    parser.add_argument("--repeat", type=int, default=2)
    parser.add_argument(
        "--budget", default="1G", help="NAPARI_LABYRINTH_MEMORY of the streamed run"
    )
    parser.add_argument("--no-in-memory", action="store_true")
    parser.add_argument("--dir", default=tempfile.gettempdir())
    args = parser.parse_args()
    work = pathlib.Path(tempfile.mkdtemp(prefix="bench-stream-", dir=args.dir))
    try:
        source = work / "in.zarr"
        start = time.perf_counter()
        write_texture(source, args.size)
        pixels = args.size**2
        print(f"input: {args.size} x {args.size} uint16 ({pixels * 2 / 1e9:.2f} GB), zarr chunks "
              f"of {CHUNK_ROWS} rows, written in {time.perf_counter() - start:.1f} s")  # fmt: skip
        print(f"{'preset':<10} {'way':<10} {'best s':>8} {'Mpx/s':>7} {'peak RSS MB':>12} "
              f"{'load':>5}  runs (s)")  # fmt: skip
        ways = [("streamed", args.budget)] + ([] if args.no_in_memory else [("in memory", None)])
        for preset in args.preset:
            times: dict[str, list[float]] = {way: [] for way, _ in ways}
            peaks: dict[str, float] = {}
            for _ in range(args.repeat):
                for way, budget in ways:  # interleaved
                    seconds, peak, taken = run_command(
                        source, work / f"{way.replace(' ', '_')}.zarr", preset, budget
                    )
                    if taken != way:
                        raise SystemExit(f"the {way} run was {taken}: adjust --budget")
                    times[way].append(seconds)
                    peaks[way] = max(peaks.get(way, 0.0), peak)
            for way, _ in ways:
                best = min(times[way])
                runs = " ".join(f"{t:.1f}" for t in times[way])
                print(f"{preset:<10} {way:<10} {best:8.1f} {pixels / best / 1e6:7.1f} "
                      f"{peaks[way]:12.0f} {os.getloadavg()[0]:5.2f}  {runs}")  # fmt: skip
            if len(ways) == 2:
                ratio = min(times["in memory"]) / min(times["streamed"])
                same = identical(work / "streamed.zarr", work / "in_memory.zarr")
                print(f"{preset:<10} streamed throughput {100 * ratio:.0f} % of in memory; "
                      f"results identical: {same}")  # fmt: skip
    finally:
        shutil.rmtree(work, ignore_errors=True)


if __name__ == "__main__":
    main()
