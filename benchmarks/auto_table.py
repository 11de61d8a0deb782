"""Auto V before and after its criterion weighed what a person sees: a table, and its time.

Prints figures, asserts nothing. For every image of the study (``study.images``, 256²) and
every hard case (``hard_cases.hard_cases``, 384²):

- the V ``find_window`` chooses in the tree given by ``--before`` (default: ``main``, checked
  out with ``git archive`` into a temporary directory) and in this checkout;
- at each of them, on the whole image: the labyrinth cover, the contour alignment of its walls,
  the edge enhancement, the share of pixels changed and of the black field changed (flat
  near-black pixels, ``study.dark_mask``);
- the targets of issue 28 on the whole image, over the V probed: the best cover of a V whose
  walls are aligned (``window_criterion.ALIGNED``) and drawn (cover at least ``MIN_COVER``
  beyond the input's own, at least ``MIN_CHANGED`` of the pixels changed), Auto's cover as a
  share of it (target >= 0.8), and whether Auto draws walls when some V does;
- the time of ``find_window`` on the images made at 2048² in both trees, interleaved (each
  round runs one process per tree), best of ``--rounds``, with the load average.

Then the figures behind ``ALIGNED``: on every image's probe and every V whose walls cover 1 %,
the contour alignment of the walls with their own crops' contours, and with the same crops
turned by 180 degrees (contours of the same kind, elsewhere: no relation but the image's
overall orientations), and the share of each at or above thresholds.

``--sheets DIR`` writes the before/after contact sheets of the hard cases (96² crops at 4x).

Run: ``python benchmarks/auto_table.py [--before main] [--rounds 3] [--sheets docs/study]``
(about ten minutes on two cores).
"""

from __future__ import annotations

import argparse
import json
import math
import os
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))

#: Printed before a child's JSON result on its stdout.
MARK = "AUTO-TABLE-RESULT "

#: Side of the images find_window is timed on.
TIMED_SIZE = 2048

#: Alignment thresholds of the table behind ALIGNED.
ALIGNMENT_STEPS = (0.5, 0.55, 0.6, 0.65, 0.7, 0.75, 0.8)


def all_images(study_size: int = 256, hard_size: int | None = None) -> dict[str, np.ndarray]:
    """The study's images and the hard cases, by name."""
    from hard_cases import SIZE, hard_cases
    from study import images

    return {**images(study_size), **hard_cases(hard_size or SIZE)}


# -- the child: one tree's choices and times ------------------------------------------------------


def child() -> dict:
    """Auto V on every image, and the time of find_window at 2048² (run in a tree's process)."""
    import napari_labyrinth
    from napari_labyrinth import find_window

    find_window(np.zeros((64, 64), np.uint8) + np.arange(64, dtype=np.uint8))  # compile
    chosen = {}
    for name, image in all_images().items():
        window = find_window(image)
        chosen[name] = dict(best=window.best, summary=window.summary())
    times = {}
    for name, image in all_images(TIMED_SIZE, TIMED_SIZE).items():
        find_window(image[:256, :256])  # this dtype's kernels compiled, out of the time
        start = time.perf_counter()
        find_window(image)
        times[name] = (time.perf_counter() - start, os.getloadavg()[0])
    return dict(source=napari_labyrinth.__file__, chosen=chosen, times=times)


def run_child(tree: Path) -> dict:
    environment = dict(os.environ, PYTHONPATH=str(tree / "src"), NAPARI_LABYRINTH_NO_WARMUP="1")
    done = subprocess.run(
        [sys.executable, __file__, "--child"],
        env=environment,
        capture_output=True,
        text=True,
        check=True,
    )
    line = next(line for line in done.stdout.splitlines() if line.startswith(MARK))
    result = json.loads(line[len(MARK) :])
    if not Path(result["source"]).is_relative_to(tree):
        raise RuntimeError(f"the child imported {result['source']}, not {tree}'s package")
    return result


def before_tree(ref: str) -> Path:
    """``git archive ref src`` in a temporary directory."""
    target = Path(tempfile.mkdtemp(prefix=f"auto-table-{ref}-"))
    archive = subprocess.run(
        ["git", "-C", str(ROOT), "archive", ref, "src"], capture_output=True, check=True
    )
    subprocess.run(["tar", "-x", "-C", str(target)], input=archive.stdout, check=True)
    return target


# -- the whole image at the V chosen --------------------------------------------------------------


def whole_image(image, thresholds) -> dict:
    """Cover, alignment, edge enhancement, changed and black field changed at each V."""
    from study import dark_mask, tones

    from napari_labyrinth import labyrinth, metrics

    before = tones(image)
    comparison = metrics.Comparison(before)
    names = ("edge_enhancement", "labyrinth_cover", "contour_alignment")
    black = dark_mask(image)
    rows = {}
    for value in thresholds:
        rendered = labyrinth(image, variance_threshold=value)
        measured = comparison.measure(tones(image, rendered), names)
        changed = rendered != image
        rows[value] = dict(
            edges=measured["edge_enhancement"],
            cover=measured["labyrinth_cover"],
            alignment=measured["contour_alignment"],
            changed=float(changed.mean()),
            black=float(changed[black].mean()) if black.mean() >= 0.05 else math.nan,
        )
    return dict(rows=rows, input_cover=metrics.labyrinth_cover(before))


def targets(measured: dict, chosen: float) -> tuple[float, float, bool]:
    """The best cover of aligned walls drawn, Auto's share of it, whether Auto draws walls
    when some V does."""
    from napari_labyrinth.metrics import MIN_COVER
    from napari_labyrinth.window_criterion import ALIGNED, MIN_CHANGED

    def draws(row):
        return (
            row["cover"] >= measured["input_cover"] + MIN_COVER and row["changed"] >= MIN_CHANGED
        )

    rows = measured["rows"]
    aligned = [
        row["cover"] for row in rows.values()
        if draws(row) and math.isfinite(row["alignment"]) and row["alignment"] >= ALIGNED
    ]  # fmt: skip
    best = max(aligned, default=math.nan)
    share = rows[chosen]["cover"] / best if aligned else math.nan
    return best, share, draws(rows[chosen]) or not any(draws(row) for row in rows.values())


def table(images, chosen_before, chosen_after, out=sys.stdout) -> None:
    from napari_labyrinth import find_window

    print(
        "| image | auto V before | after | cover before | after | aligned before | after | "
        "EE before | after | changed before | after | black field changed before | after | "
        "best aligned cover | Auto's share before | after | walls drawn before | after |",
        file=out,
    )
    print("|---" * 19 + "|", file=out)
    for name, image in images.items():
        before, after = chosen_before[name], chosen_after[name]
        values = sorted(set(find_window(image).thresholds) | {before, after})
        measured = whole_image(image, values)
        rows = measured["rows"]
        best, share_before, drawn_before = targets(measured, before)
        _, share_after, drawn_after = targets(measured, after)
        cells = [name, f"{before:.4g}", f"{after:.4g}"]
        for key in ("cover", "alignment", "edges", "changed", "black"):
            cells += [_figure(rows[before][key]), _figure(rows[after][key])]
        cells += [_figure(best), _figure(share_before, 2), _figure(share_after, 2)]
        cells += ["yes" if drawn_before else "NO", "yes" if drawn_after else "NO"]
        print("| " + " | ".join(cells) + " |", file=out, flush=True)


def _figure(value: float, decimals: int = 3) -> str:
    return "-" if not math.isfinite(value) else f"{value:.{decimals}f}"


# -- the figures behind ALIGNED -------------------------------------------------------------------


def alignment_null(images, out=sys.stdout) -> None:
    """Alignment of the probe's walls with their own contours and with the crops turned 180°."""
    from study import tones

    from napari_labyrinth import find_window, labyrinth, metrics

    own, turned = [], []
    for image in images.values():
        window = find_window(image)
        size = window.crop_size
        crops = [
            np.ascontiguousarray(tones(image, image[top : top + size, left : left + size]))
            for _, top, left in window.crops
        ]
        mosaic = np.concatenate(crops)
        rotated = np.concatenate([crop[::-1, ::-1] for crop in crops])
        for value in window.thresholds:
            rendered = np.concatenate(
                [labyrinth(c, variance_threshold=value, tone_limits=(0.0, 255.0)) for c in crops]
            )
            aligned = metrics.contour_alignment(mosaic, rendered)
            if math.isfinite(aligned):
                own.append(aligned)
                turned.append(metrics.contour_alignment(rotated, rendered))
    own, turned = np.array(own), np.array(turned)
    print(f"{len(own)} probes x V with walls on 1 % of the probe", file=out)
    print("| alignment >= | own contours | crops turned 180° |", file=out)
    print("|---|---|---|", file=out)
    for step in ALIGNMENT_STEPS:
        print(
            f"| {step:g} | {np.mean(own >= step):.2f} | {np.mean(turned >= step):.2f} |", file=out
        )
    print(
        f"\nown: median {np.median(own):.3f}, 5th percentile {np.percentile(own, 5):.3f}; "
        f"turned: median {np.median(turned):.3f}, 95th percentile "
        f"{np.percentile(turned, 95):.3f}; own above turned in {np.mean(own > turned):.0%} "
        "of the pairs",
        file=out,
    )


# -- the contact sheets ---------------------------------------------------------------------------


def sheets(images, chosen_before, chosen_after, directory: Path, crop: int = 96) -> list[Path]:
    """Hard cases (rows) at the V before and after (columns), a crop at 4x."""
    from figures import labelled_grid
    from hard_cases import hard_cases
    from skimage import io
    from study import tones

    from napari_labyrinth import labyrinth

    def display(image, values):
        return np.rint(tones(image, values)).astype(np.uint8)

    names = [name for name in images if name in hard_cases(32)]
    groups = {
        "sheet-auto-schlieren.png": [n for n in names if n.startswith("schlieren")],
        "sheet-auto-dark-fields.png": [n for n in names if not n.startswith("schlieren")],
    }
    written = []
    for file_name, group in groups.items():
        rows, labels = [], []
        for name in group:
            image = images[name]
            top = (image.shape[0] - crop) // 2
            window = (slice(top, top + crop), slice(top, top + crop))
            cells = [display(image, image[window])]
            for value in (chosen_before[name], chosen_after[name]):
                cells.append(display(image, labyrinth(image, variance_threshold=value)[window]))
            rows.append(cells)
            labels.append(f"{name}\nV {chosen_before[name]:g} -> {chosen_after[name]:g}")
        sheet = labelled_grid(
            rows,
            column_labels=["input", "Auto V before", "Auto V after"],
            row_labels=[label.replace("\n", ": ") for label in labels],
            scale=4,
            title="Auto V before and after the cover criterion (a 96 x 96 crop at 4x, 4 passes)",
        )
        path = directory / file_name
        io.imsave(path, sheet, check_contrast=False)
        written.append(path)
    return written


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--before", default="main", metavar="REF", help="the tree before")
    parser.add_argument("--rounds", type=int, default=3)
    parser.add_argument("--sheets", metavar="DIR", help="write the contact sheets there")
    parser.add_argument("--child", action="store_true", help=argparse.SUPPRESS)
    args = parser.parse_args(argv)
    if args.child:
        print(MARK + json.dumps(child()), flush=True)
        return 0

    print(f"load average at the start: {os.getloadavg()}, {os.cpu_count()} cores")
    trees = {"before": before_tree(args.before), "after": ROOT}
    results: dict[str, list[dict]] = {label: [] for label in trees}
    try:
        for _ in range(args.rounds):
            for label, tree in trees.items():  # interleaved: a passing load falls on both
                results[label].append(run_child(tree))
    finally:
        shutil.rmtree(trees["before"], ignore_errors=True)
    chosen = {
        label: {name: row["best"] for name, row in runs[0]["chosen"].items()}
        for label, runs in results.items()
    }
    images = all_images()

    print(f"\n## Auto V before ({args.before}) and after, on the whole image (default preset)\n")
    table(images, chosen["before"], chosen["after"])
    print("\n### Auto's line, after\n")
    for name, row in results["after"][0]["chosen"].items():
        print(f"- {name}: {row['summary']}")

    print(f"\n## Time of find_window at {TIMED_SIZE}² (seconds, best of {args.rounds} rounds)\n")
    print("| image | before | after | load (1 min) |")
    print("|---|---|---|---|")
    for name in results["after"][0]["times"]:
        best = {
            label: min(run["times"][name][0] for run in runs) for label, runs in results.items()
        }
        load = max(run["times"][name][1] for runs in results.values() for run in runs)
        print(f"| {name} | {best['before']:.3f} | {best['after']:.3f} | {load:.2f} |")

    print("\n## Contour alignment of the probe's walls: own contours against turned crops\n")
    alignment_null(images)

    if args.sheets:
        for path in sheets(images, chosen["before"], chosen["after"], Path(args.sheets)):
            print(f"wrote {path}")
    print(f"\nload average at the end: {os.getloadavg()}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
