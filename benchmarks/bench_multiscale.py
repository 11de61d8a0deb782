"""Run on a multiscale layer from the widget: a 3-level 8192² uint16 OME-Zarr in a real viewer.

Run under Xvfb: ``xvfb-run -a python benchmarks/bench_multiscale.py [--out DIR] [--runs N]
[--side 8192] [--ways napari-ome-zarr,add_image]``.
Prints figures; asserts nothing; the machine's load is printed before and after.

The OME-Zarr (8192², 4096², 2048² uint16 by default, ``--side`` the full level's; written by
``ome_zarr.writer`` from a dask array, in a process of its own so that its memory does not
count here) is opened in a viewer on screen two ways, interleaved run by run:

- ``napari-ome-zarr``: ``viewer.open(path, plugin="napari-ome-zarr")``;
- ``add_image``: ``viewer.add_image([levels], multiscale=True)`` of the zarr arrays read
  through dask, the full level counting the chunks it reads.

Each run: the widget's Run (default preset) to the multiscale result shown, wall time and
the worker's time (the status's), the process's CPU time, the progress steps the widget
received, the process's RSS before and its peak during the run (``VmHWM``, reset before each
run through ``/proc/self/clear_refs``). Then the preview on the input zoomed in at its
centre (1 data pixel = 6 screen pixels): seconds until it is shown, what it rendered, seconds
to settle after a pan of about a screen's width, its peak over the memory before it. Then
screenshots of the result zoomed in (at the centre, as the preview) and zoomed out (the whole
image, napari showing the lowest level), saved as PNGs in ``--out``.
"""

from __future__ import annotations

import argparse
import os
import re
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

from napari_labyrinth.provenance import KEY

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _qt_loop import process_events, wait_until

#: The full level's side, by default.
SIDE = 8192
#: Screen pixels per data pixel of the zoomed-in screenshot.
ZOOMED_IN = 6.0
#: Seconds the viewer is watched alone before each run.
IDLE_SECONDS = 5.0


def _write(path: str, side: int) -> None:
    """Write the OME-Zarr block by block (bounded memory): wavy stripes about 60 pixels
    apart, crossed by slower bands, over a fine weave of 3-pixel period, under broad shading
    and a little noise (the default preset's noise gate leaves a plain smooth field with
    noise as it is: its rendering showed no pattern zoomed in)."""
    import dask.array as da
    import zarr
    from ome_zarr.writer import write_image

    def block(block_info=None):
        (y0, y1), (x0, x1) = block_info[None]["array-location"]
        y, x = np.mgrid[y0:y1, x0:x1].astype(np.float32)
        rng = np.random.default_rng(y0 * side + x0)
        across, along = x / 9.0 + 4 * np.sin(y / 151.0), y / 37.0 + 3 * np.cos(x / 173.0)
        stripes = np.sin(across) * np.cos(along)
        shading = 0.5 * np.sin((x + 2 * y) / 611.0)
        weave = np.sin(x / 3.1 + 5 * np.sin(y / 23.0)) * np.sin(y / 2.7)
        values = 30000 + 12000 * (stripes + shading) + 4000 * weave + rng.normal(0, 600, x.shape)
        return np.clip(values, 0, 65535).astype(np.uint16)

    chunks = (1024,) * (side // 1024) + ((side % 1024,) if side % 1024 else ())
    image = da.map_blocks(block, chunks=(chunks, chunks), dtype=np.uint16)
    group = zarr.open_group(path, mode="w")
    write_image(image, group, scale_factors=(2, 4), axes="yx", name=f"cam{side}")


def _rss() -> tuple[float, float]:
    """The process's resident memory now and its peak since the last reset, in MB."""
    fields = dict(
        re.match(r"(\w+):\s+(\d+)", line).groups()
        for line in Path("/proc/self/status").read_text().splitlines()
        if line.startswith(("VmRSS", "VmHWM"))
    )
    return int(fields["VmRSS"]) / 1024, int(fields["VmHWM"]) / 1024


def _napari_dask_cache() -> float:
    """MB held by napari's dask cache (napari registers one for every dask compute of the
    process: the chunks a run reads through dask stay there)."""
    from napari.utils import _dask_utils

    cache = getattr(_dask_utils, "_DASK_CACHE", None)
    return cache.cache.total_bytes / 2**20 if cache is not None else float("nan")


def _thread_cpu() -> dict[str, float]:
    """CPU seconds of each thread of the process so far, by "name id" (``/proc``)."""
    seconds = {}
    for task in Path("/proc/self/task").iterdir():
        try:
            stat, name = (task / "stat").read_text(), (task / "comm").read_text().strip()
        except OSError:  # the thread ended meanwhile
            continue
        fields = stat.rsplit(")", 1)[1].split()
        main = " (main)" if task.name == str(os.getpid()) else ""
        seconds[f"{name} {task.name}{main}"] = (int(fields[11]) + int(fields[12])) / os.sysconf(
            "SC_CLK_TCK"
        )
    return seconds


def _reset_peak() -> None:
    Path("/proc/self/clear_refs").write_text("5")


def _events(seconds: float = 0.0) -> None:
    process_events(seconds, nap=0.005)


def _wait(condition, timeout: float = 600.0) -> None:
    wait_until(condition, timeout)


def _load() -> str:
    return "load " + " ".join(f"{value:.2f}" for value in os.getloadavg())


def _counting(level):
    """``level`` (dask) and the list of the chunks it reads."""
    read: list[tuple[int, ...]] = []

    def count(chunk, block_info=None):
        read.append(tuple(block_info[0]["chunk-location"]))
        return chunk

    return level.map_blocks(count, dtype=level.dtype), read


def _open(viewer, path: str, way: str, side: int):
    """The OME-Zarr as a multiscale layer, opened ``way``; the chunks its full level reads."""
    if way == "napari-ome-zarr":
        (layer,) = viewer.open(path, plugin="napari-ome-zarr")
        return layer, None
    import dask.array as da
    import zarr

    datasets = zarr.open_group(path, mode="r").attrs["ome"]["multiscales"][0]["datasets"]
    levels = [da.from_zarr(f"{path}/{dataset['path']}") for dataset in datasets]
    levels[0], read = _counting(levels[0])
    return viewer.add_image(levels, multiscale=True, name=f"cam{side}"), read


def _busiest(before: dict[str, float], count: int = 4) -> str:
    """The ``count`` threads that took the most CPU since ``before`` (``_thread_cpu``)."""
    spent = {name: value - before.get(name, 0.0) for name, value in _thread_cpu().items()}
    busiest = sorted(spent.items(), key=lambda item: -item[1])[:count]
    return ", ".join(f"{name} {value:.1f} s" for name, value in busiest)


def _run(viewer, widget, layer) -> dict:
    widget.image_layer.value = layer
    steps: list[int] = []
    _events(0.2)
    threads = _thread_cpu()
    _events(IDLE_SECONDS)  # the viewer alone, showing the layer
    idle = _busiest(threads)
    before, _ = _rss()
    _reset_peak()
    threads = _thread_cpu()
    started, cpu = time.perf_counter(), time.process_time()
    worker = widget.run()
    worker.yielded.connect(steps.append)
    _wait(lambda: widget.worker is None)
    wall, cpu = time.perf_counter() - started, time.process_time() - cpu
    _, peak = _rss()
    seconds = re.search(r"\(([\d.]+) s\)", widget.status.value)
    return {
        "wall": wall,
        "cpu": cpu,
        "threads": _busiest(threads),
        "idle": idle,
        "worker": float(seconds.group(1)) if seconds else float("nan"),
        "steps": f"{len(steps)} of {widget.progress_bar.maximum()}",
        "rss": before,
        "peak": peak,
        "status": widget.status.value,
        "dask cache": _napari_dask_cache(),
    }


def _preview(viewer, widget, layer, result, side: int) -> str:
    """The preview zoomed in at the centre (``ZOOMED_IN``): seconds to its layer shown, what
    it rendered; then seconds to settle after a pan of about a screen's width."""
    from napari_labyrinth._qt.preview import viewer_camera  # napari's, before 0.9 or since

    camera = viewer_camera(viewer)
    result.visible = False
    widget.image_layer.value = layer
    camera.center = (side / 2, side / 2)
    camera.zoom = ZOOMED_IN
    _events(1.0)
    _reset_peak()
    before, _ = _rss()
    started = time.perf_counter()
    widget.preview_toggle.value = True
    _wait(lambda: widget.preview.layer is not None and not widget.preview.busy)
    shown = time.perf_counter() - started
    preview = widget.preview.layer
    region = preview.metadata[KEY].get("source_region")
    shape = tuple(preview.data.shape)
    started = time.perf_counter()
    camera.center = (side / 2, side / 2 + 1000 / ZOOMED_IN)
    _events(0.2)
    _wait(lambda: not widget.preview.busy)
    panned = time.perf_counter() - started
    _, peak = _rss()
    widget.preview_toggle.value = False
    _events(0.5)
    result.visible = True
    viewer.reset_view()
    return (
        f"  preview zoomed in: shown after {shown:.1f} s, {shape} rendered (part {region});"
        f" settled {panned:.1f} s after a pan; peak {peak - before:+.0f} MB"
    )


def _screenshots(viewer, layer, result, out: Path, way: str, side: int) -> list[Path]:
    layer.visible = False
    viewer.reset_view()
    _events(1.0)
    zoomed_out = out / f"multiscale-{side}-{way}-zoomed-out.png"
    viewer.screenshot(str(zoomed_out), canvas_only=True)
    level_out = result.data_level
    from napari_labyrinth._qt.preview import viewer_camera  # napari's, before 0.9 or since

    camera = viewer_camera(viewer)
    camera.center = (side / 2, side / 2)
    camera.zoom = ZOOMED_IN
    _events(1.5)
    zoomed_in = out / f"multiscale-{side}-{way}-zoomed-in.png"
    viewer.screenshot(str(zoomed_in), canvas_only=True)
    print(
        f"  screenshots: {zoomed_out} (napari shows level {level_out}), "
        f"{zoomed_in} (level {result.data_level})"
    )
    layer.visible = True
    viewer.reset_view()
    return [zoomed_out, zoomed_in]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", default=None, help="folder of the zarr and the screenshots")
    parser.add_argument("--runs", type=int, default=2, help="runs of each way (best taken)")
    parser.add_argument("--side", type=int, default=SIDE, help="the full level's side")
    parser.add_argument("--ways", default="napari-ome-zarr,add_image", help="ways of opening it")
    parser.add_argument("--write", help=argparse.SUPPRESS)  # the child that writes the zarr
    arguments = parser.parse_args()
    side = arguments.side
    if arguments.write:
        _write(arguments.write, side)
        return

    os.environ.setdefault("NAPARI_LABYRINTH_NO_WARMUP", "1")
    out = Path(arguments.out or tempfile.mkdtemp(prefix="bench-multiscale-"))
    out.mkdir(parents=True, exist_ok=True)
    path = str(out / f"cam{side}.ome.zarr")
    print(_load(), f"{os.cpu_count()} cores")
    if not Path(path).exists():
        started = time.perf_counter()
        subprocess.run(
            [sys.executable, __file__, "--write", path, "--side", str(side)], check=True
        )
        print(f"wrote {path} in {time.perf_counter() - started:.1f} s")

    import napari

    viewer = napari.Viewer(show=True)
    viewer.window.resize(1500, 1000)  # a canvas of about 1000 x 900 beside the dock
    _, widget = viewer.window.add_plugin_dock_widget("napari-labyrinth", "Labyrinthine tiling")
    widget.replace.value = False  # each run adds its layer (removed after it)
    # the kernels compiled before the figures (a first run after an install compiles them)
    warm = viewer.add_image(np.zeros((64, 64), np.uint16), name="warm")
    _run(viewer, widget, warm)
    for layer in list(viewer.layers):
        viewer.layers.remove(layer)
        _events(0.05)
    print(f"viewer and widget open: RSS {_rss()[0]:.0f} MB ({_load()})")

    figures: dict[str, list[dict]] = {way: [] for way in arguments.ways.split(",")}
    for round_number in range(arguments.runs):
        for way, rows in figures.items():
            layer, read = _open(viewer, path, way, side)
            viewer.reset_view()
            _events(1.0)
            shapes = [tuple(level.shape) for level in layer.data]
            if read is not None:
                read.clear()
            figure = _run(viewer, widget, layer)
            (result,) = [other for other in viewer.layers if other.name.endswith("labyrinth")]
            figure["chunks"] = f"{len(set(read))} chunks, {len(read)} reads" if read else "-"
            figure["result"] = [tuple(level.shape) for level in result.data]
            rows.append(figure)
            print(
                f"round {round_number + 1} {way:16} levels {shapes}: wall {figure['wall']:.1f} s,"
                f" worker {figure['worker']:.1f} s, CPU {figure['cpu']:.1f} s,"
                f" steps {figure['steps']}, RSS before"
                f" {figure['rss']:.0f} MB, peak {figure['peak']:.0f} MB"
                f" (+{figure['peak'] - figure['rss']:.0f} MB), full level read:"
                f" {figure['chunks']}; napari's dask cache {figure['dask cache']:.0f} MB;"
                f" result levels {figure['result']} ({_load()})\n  busiest threads in the run:"
                f" {figure['threads']}\n  in {IDLE_SECONDS:.0f} s before it: {figure['idle']}"
            )
            print(_preview(viewer, widget, layer, result, side))
            if round_number == arguments.runs - 1:
                _screenshots(viewer, layer, result, out, way, side)
            for other in list(viewer.layers):
                viewer.layers.remove(other)
                _events(0.05)
    print("\nbest of", arguments.runs, "runs:")
    for way, rows in figures.items():
        best = min(rows, key=lambda row: row["wall"])
        print(
            f"  {way:16} wall {best['wall']:.1f} s, worker {best['worker']:.1f} s,"
            f" peak RSS {max(row['peak'] for row in rows):.0f} MB (highest of the runs),"
            f" at most {max(row['peak'] - row['rss'] for row in rows):.0f} MB over the RSS"
            " before the run"
        )
    print(_load())
    viewer.close()


if __name__ == "__main__":
    main()
