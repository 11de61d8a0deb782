"""A plane larger than memory rendered band by band, against the in-memory rendering. Prints.

A smooth random texture (a few random waves and a little noise, computed from
each pixel's coordinates: the generator holds one band) is written band by
band into a uint16 zarr store of ``--size``² pixels, chunked by bands of rows.
Each row of the table is one ``napari-labyrinth render in.zarr -o out.zarr``,
the whole command as a child process (its wall time, and its peak resident
memory: ``VmHWM``, read from ``/proc`` until it ends):

- ``streamed``: with ``NAPARI_LABYRINTH_MEMORY=--budget``, under which the
  plane's rendering in memory does not fit: read, rendered and written band by
  band (``streaming.render_plane_file``);
- ``in memory``: without a budget (the machine's memory): the plane is a block
  of a lazy zarr input, rendered whole in memory and written.

Both find the default tone limits in a streamed pass first, as the command
does. The two run interleaved, ``--repeat`` times each, best time kept; their
outputs are compared pixel for pixel, band by band. ``--no-in-memory`` runs
the streamed command only (a plane the machine cannot render in memory:
``--size 40000``); ``--crop ROWS`` then checks it against the in-memory
rendering of the plane's first ``ROWS`` rows (its whole width, the tone limits,
seed and noise the output's record holds): the rows a pass leaves as the
whole plane's (all but the last ``passes``, which read the crop's last row)
must be identical. Throughput is pixels over the command's wall time. The
1-minute load average is printed with each row (2 cores shared: compare rows
run side by side).

``--chunks ROWS[xCOLUMNS]`` stores the input in chunks of that shape (default:
128 rows of the whole width; ``1024x1024`` is what ome-zarr and bioio write).
``--budget`` takes several budgets, each a row (a run refused prints the
reason). ``--src DIR ...`` runs the package of each tree given (``src`` of a
``git archive`` of an earlier commit, say) for a before/after comparison with
this same script, interleaved, each row named after the tree; each tree first
renders a small plane band by band, untimed (numba's kernels compiled or
loaded). The peak and load printed are those of the best run.

Run: ``python benchmarks/bench_stream_plane.py [--size 8000] [--preset paper labyrinth]
[--repeat 2] [--budget 1G ...] [--chunks 128] [--no-in-memory] [--crop ROWS]
[--src DIR ...] [--dir /tmp]``.
"""

from __future__ import annotations

import argparse
import concurrent.futures
import os
import pathlib
import shutil
import subprocess
import sys
import tempfile
import time

import numpy as np

ROOT = pathlib.Path(__file__).resolve().parent.parent
#: Rows of the input's chunks (and of the bands it is generated in), by default.
CHUNK_ROWS = 128


def write_texture(path: pathlib.Path, size: int, seed: int = 0, chunks=None) -> None:
    """A ``size``² uint16 smooth random texture, written band by band into a zarr store of
    ``chunks`` (default: ``CHUNK_ROWS`` rows of the whole width)."""
    import zarr

    chunks = tuple(chunks or (CHUNK_ROWS, size))
    rng = np.random.default_rng(seed)
    waves = 12
    frequency = rng.uniform(0.002, 0.05, (waves, 2)) * rng.choice([-1, 1], (waves, 2))
    phase = rng.uniform(0, 2 * np.pi, waves)
    weight = rng.uniform(0.5, 1.0, waves)
    target = zarr.create_array(store=str(path), shape=(size, size), chunks=chunks, dtype="u2")
    x = np.arange(size, dtype=np.float64)
    # sin(a y + b x + p) = sin(a y + p) cos(b x) + cos(a y + p) sin(b x): two products a wave
    across = [(np.cos(f[1] * x).astype(np.float32), np.sin(f[1] * x).astype(np.float32))
              for f in frequency]  # fmt: skip
    rows = chunks[0]
    for start in range(0, size, rows):
        y = np.arange(start, min(size, start + rows), dtype=np.float64)
        band = rng.standard_normal((len(y), size), dtype=np.float32)
        band *= 0.3
        for k in range(waves):
            down = weight[k] * np.sin(frequency[k, 0] * y + phase[k]).astype(np.float32)
            down_cos = weight[k] * np.cos(frequency[k, 0] * y + phase[k]).astype(np.float32)
            band += down[:, None] * across[k][0]
            band += down_cos[:, None] * across[k][1]
        band = (band / (2 * weight.sum()) + 0.5) * 50000 + 5000
        target[start : start + len(y)] = np.clip(band, 0, 65535).astype(np.uint16)


#: What the command says when it refuses a plane whose chunks do not fit.
REFUSED = "more memory than this run may use"


def run_command(source, output, preset, budget, src) -> tuple[float, float, str]:
    """One render as a child process: wall seconds, peak RSS (MB), and how it went
    (``streamed``, ``in memory``, or ``refused: ...``)."""
    env = dict(os.environ, NAPARI_LABYRINTH_NO_WARMUP="1")
    env["PYTHONPATH"] = os.pathsep.join([str(src), env.get("PYTHONPATH", "")])
    env.pop("NAPARI_LABYRINTH_MEMORY", None)
    if budget:
        env["NAPARI_LABYRINTH_MEMORY"] = budget
    shutil.rmtree(output, ignore_errors=True)
    command = [sys.executable, "-m", "napari_labyrinth.cli", "render", str(source), "-o",
               str(output), "--preset", preset]  # fmt: skip
    with tempfile.TemporaryFile() as errors:
        start = time.perf_counter()
        child = subprocess.Popen(command, env=env, stdout=subprocess.DEVNULL, stderr=errors)
        peak = 0.0
        while True:  # the child's own high-water mark, read until it ends
            pid, status, usage = os.wait4(child.pid, os.WNOHANG)
            if pid:
                break
            peak = max(peak, high_water_mb(child.pid))
            time.sleep(0.02)
        seconds = time.perf_counter() - start
        child.returncode = os.waitstatus_to_exitcode(status)
        errors.seek(0)
        text = errors.read().decode(errors="replace").strip().splitlines()
    if not peak:  # no /proc: the rusage's (which counts the parent's RSS at the fork too)
        peak = usage.ru_maxrss / 1024
    if child.returncode != 0:
        refusal = [line for line in text if REFUSED in line]
        if refusal:
            return seconds, peak, "refused: " + refusal[-1].split(REFUSED, 1)[1].strip(" :")
        raise SystemExit(f"{' '.join(command)} failed:\n" + "\n".join(text[-5:]))
    streamed = any("rendered band by band" in line for line in text)
    return seconds, peak, "streamed" if streamed else "in memory"


def high_water_mb(pid: int) -> float:
    """The peak resident memory of process ``pid`` so far (``VmHWM``), MB; 0 if unknown.

    Not ``ru_maxrss``: Linux carries the parent's resident memory at the fork into a child's
    (an input generated in the parent made a run refused at once peak at 788 MB)."""
    try:
        with open(f"/proc/{pid}/status", encoding="ascii") as status:
            for line in status:
                if line.startswith("VmHWM:"):
                    return int(line.split()[1]) / 1024
    except (OSError, ValueError):
        pass
    return 0.0


def crop_reference(output: pathlib.Path, source: pathlib.Path, rows: int):
    """The in-memory rendering of the input's first ``rows`` rows (its whole width) with the
    streamed ``output``'s recorded parameters, seed, tone limits and noise: ``(rendering,
    crop, record)``. Its rows but the last ``passes`` are the whole plane's: a pass reads the
    row below a row as the pass before left it, and only the crop's last row is not."""
    import zarr

    from napari_labyrinth import _rendering, labyrinth
    from napari_labyrinth.io import read_metadata

    record = read_metadata(output).provenance
    crop = np.asarray(zarr.open_array(str(source), mode="r")[:rows])
    sigma = (record.get("noise_sigma") or [None])[0]
    measure = _rendering.tone_noise_sigma
    if sigma is not None:  # the whole plane's, not the crop's
        _rendering.tone_noise_sigma = lambda *args, **kwargs: sigma
    limits = tuple(record["tone_limits"])
    try:
        expected = labyrinth(crop, preset=record["preset"], **record.get("overrides", {}),
                             seed=record["seed"], tone_limits=limits)  # fmt: skip
    finally:
        _rendering.tone_noise_sigma = measure
    return expected, crop, record


def crop_identical(output: pathlib.Path, reference) -> str:
    """Whether the streamed ``output``'s first rows are those of ``reference``
    (:func:`crop_reference`), on all but the crop's last ``passes`` rows."""
    import zarr

    from napari_labyrinth.io import read_metadata

    expected, crop, record = reference
    same_record = all(read_metadata(output).provenance.get(key) == record.get(key)
                      for key in ("parameters", "seed", "tone_limits", "noise_sigma"))  # fmt: skip
    kept = len(crop) - record["parameters"]["passes"]
    result = zarr.open_array(str(output), mode="r")[:kept]
    same = same_record and np.array_equal(result, expected[:kept])
    changed = float(np.mean(result != crop[:kept]))
    return f"{same} (rows 0-{kept - 1}, {100 * changed:.0f} % of their pixels changed)"


def warm_up(work: pathlib.Path, trees, preset: str) -> None:
    """Render a small plane band by band with each tree once, untimed: numba compiles (or
    loads) the kernels a tree's first run needs."""
    source = work / "warm.zarr"
    if not source.exists():
        write_texture(source, 512, chunks=(16, 512))
    for tree in trees:
        run_command(source, work / "warm_out.zarr", preset, "1500K", tree)


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
        "--budget", nargs="+", default=["1G"], help="NAPARI_LABYRINTH_MEMORY of the streamed run"
    )
    parser.add_argument("--chunks", default=str(CHUNK_ROWS), help="ROWS or ROWSxCOLUMNS")
    parser.add_argument("--no-in-memory", action="store_true")
    parser.add_argument("--crop", type=int, default=0, help="rows checked against memory")
    parser.add_argument("--src", nargs="+", default=[str(ROOT / "src")],
                        help="the package's source trees to run, each its rows")  # fmt: skip
    parser.add_argument("--dir", default=tempfile.gettempdir())
    args = parser.parse_args()
    rows, _, columns = args.chunks.partition("x")
    chunks = (int(rows), int(columns or args.size))
    trees = [pathlib.Path(src).resolve() for src in args.src]
    sys.path.insert(0, str(trees[-1]))  # the in-memory rendering of --crop: the last tree's
    names = {tree: tree.parent.name for tree in trees}
    work = pathlib.Path(tempfile.mkdtemp(prefix="bench-stream-", dir=args.dir))
    try:
        source = work / "in.zarr"
        start = time.perf_counter()
        with concurrent.futures.ProcessPoolExecutor(1) as pool:  # this process stays small
            pool.submit(write_texture, source, args.size, chunks=chunks).result()
        pixels = args.size**2
        took = time.perf_counter() - start
        print(f"input: {args.size} x {args.size} uint16 ({pixels * 2 / 1e9:.2f} GB), zarr chunks "
              f"of {chunks[0]} x {chunks[1]}, written in {took:.1f} s")  # fmt: skip
        for tree in trees:
            print(f"tree {names[tree]}: {tree}")
        print(f"{'preset':<10} {'tree':<18} {'way':<10} {'budget':>6} {'best s':>7} "
              f"{'Mpx/s':>6} {'peak RSS MB':>11} {'load':>5}  runs (s)")  # fmt: skip
        ways = [(tree, budget) for tree in trees for budget in args.budget]
        if not args.no_in_memory:
            ways += [(tree, None) for tree in trees]
        for preset in args.preset:
            warm_up(work, trees, preset)
            runs: dict[tuple, list[tuple[float, float, float]]] = {way: [] for way in ways}
            refused: dict[tuple, str] = {}
            for _ in range(args.repeat):
                for way in ways:  # interleaved
                    if way in refused:
                        continue
                    tree, budget = way
                    seconds, peak, taken = run_command(source, output_of(work, way, names),
                                                       preset, budget, tree)  # fmt: skip
                    runs[way].append((seconds, peak, os.getloadavg()[0]))
                    if taken.startswith("refused"):
                        refused[way] = taken
                    elif taken != ("streamed" if budget else "in memory"):
                        raise SystemExit(f"the {way} run was {taken}: adjust --budget")
            for way in ways:
                tree, budget = way
                seconds, peak, load = min(runs[way])  # the best run: its peak and load
                rate = "-" if way in refused else f"{pixels / seconds / 1e6:.1f}"
                times = " ".join(f"{t:.1f}" for t, _, _ in runs[way])
                way_name = "streamed" if budget else "in memory"
                print(f"{preset:<10} {names[tree]:<18} {way_name:<10} "
                      f"{budget or '-':>6} {seconds:7.1f} {rate:>6} {peak:11.0f} {load:5.2f}  "
                      f"{refused.get(way, times)}")  # fmt: skip
            streamed = [way for way in ways if way[1] and way not in refused]
            for way in streamed if not args.no_in_memory else []:
                memory = (way[0], None)
                ratio = min(runs[memory])[0] / min(runs[way])[0]
                same = identical(output_of(work, way, names), output_of(work, memory, names))
                print(f"{preset:<10} {names[way[0]]} streamed {way[1]}: throughput "
                      f"{100 * ratio:.0f} % of in memory; results identical: {same}")  # fmt: skip
            if streamed and args.crop:
                reference = crop_reference(output_of(work, streamed[-1], names), source, args.crop)
                for way in streamed:
                    same = crop_identical(output_of(work, way, names), reference)
                    print(f"{preset:<10} {names[way[0]]} streamed {way[1]}: as the in-memory "
                          f"rendering of the first {args.crop} rows: {same}")  # fmt: skip
    finally:
        shutil.rmtree(work, ignore_errors=True)


def output_of(work: pathlib.Path, way, names) -> pathlib.Path:
    tree, budget = way
    return work / f"{names[tree]}-{budget or 'in_memory'}.zarr"


if __name__ == "__main__":
    main()
