"""Which reading of the paper draws a labyrinth? A measured sweep.

Sweeps readings x variance thresholds x tone ranges x passes over a portrait,
a landscape, a microscopy image, a branching structure (retinal vessels) and
a liquid-crystal texture; measures every
rendering with ``napari_labyrinth.metrics``; writes

- ``docs/study/metrics.csv``: one row per (image, reading, V, ranges, pass);
- ``docs/study/window.md``: edge enhancement, cover and changed pixels against
  V for every image and reading, and the window of V where the walls follow
  the contours;
- ``docs/study/sheet-<image>.png``: contact sheets (readings x V, 4 passes).

Run: ``python benchmarks/study.py [--out docs/study] [--quick]``. It prints a
summary and takes a few minutes on two cores.

Rows also carry a *tiling score*, ``labyrinth_cover * max(edge_enhancement, 0)``.
"""

from __future__ import annotations

import argparse
import csv
import itertools
import math
import os
import sys
import time
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]

#: Readings: keyword arguments of ``labyrinth`` on top of the "paper" preset (the
#: study starts from the literal reading and changes one choice at a time).
READINGS = {
    "literal": {},
    "literal, sqrt(V)/M": {"variance_ratio": "sqrt(V)/M"},
    "push full scale, variance first": {
        "variance_action": "push_full_scale",
        "condition_order": "variance_first",
    },
    "push in range, mean first": {"variance_action": "push_in_range"},
    "push in range, variance first": {
        "variance_action": "push_in_range",
        "condition_order": "variance_first",
    },
}

#: Variance thresholds V of Eq. 4 on the printed scale sqrt(V/N)/M; readings with
#: sqrt(V)/M use the same values times sqrt(8) (the same decisions inside the image).
THRESHOLDS = (0.01, 0.02, 0.03, 0.04, 0.05, 0.06, 0.08, 0.10, 0.12, 0.16, 0.30, 0.50)
TONE_RANGES = (2, 3, 6)
PASSES = (1, 2, 4, 8)
SHEET_PASSES = 4
SHEET_THRESHOLDS = (0.02, 0.03, 0.04, 0.05, 0.06, 0.08, 0.12, 0.50)


def images(size: int = 256) -> dict[str, np.ndarray]:
    """The study's uint8 test images, ``size`` x ``size``."""
    from skimage import color, data, transform, util

    from napari_labyrinth import samples

    def gray(image):
        return util.img_as_ubyte(color.rgb2gray(image)) if image.ndim == 3 else image

    def crop(image, top, left):
        return np.ascontiguousarray(image[top : top + size, left : left + size])

    retina = transform.resize(data.retina()[..., 1], (640, 640), anti_aliasing=True)
    return {
        "portrait": crop(gray(data.astronaut()), 20, 120),
        "landscape": crop(gray(data.rocket()), 150, 100),
        "microscopy": crop(gray(data.immunohistochemistry()), 100, 100),
        "branches": crop(util.img_as_ubyte(retina), 160, 160),
        "liquid-crystal": util.img_as_ubyte(samples.nematic_schlieren((size, size), seed=0)),
    }


def threshold_for(reading: dict, value: float) -> float:
    return value * math.sqrt(8) if reading.get("variance_ratio") == "sqrt(V)/M" else value


def measure(task):
    """Render one stack and measure every recorded pass (runs in a worker)."""
    from napari_labyrinth import labyrinth_stack, metrics

    image_name, image, reading_name, value, ranges = task
    reading = READINGS[reading_name]
    stack = labyrinth_stack(
        image,
        preset="paper",
        passes=max(PASSES),
        tone_ranges=ranges,
        variance_threshold=threshold_for(reading, value),
        **reading,
    )
    rows = []
    for passes in PASSES:
        described = metrics.describe(image, stack[passes])
        described["changed"] = float(np.mean(stack[passes] != image))
        described["tiling_score"] = described["labyrinth_cover"] * max(
            described["edge_enhancement"], 0.0
        )
        rows.append(
            dict(
                image=image_name,
                reading=reading_name,
                variance_threshold=value,
                tone_ranges=ranges,
                passes=passes,
                **described,
            )
        )
    return rows


def contact_sheet(image, path, scale=2, crop=128):
    """Readings (rows) x thresholds (columns) at SHEET_PASSES passes, a crop upscaled."""
    from figures import labelled_grid
    from skimage import io

    from napari_labyrinth import labyrinth

    top = (image.shape[0] - crop) // 2
    window = (slice(top, top + crop), slice(top, top + crop))
    rows = []
    for reading in READINGS.values():
        cells = [image[window]]
        for value in SHEET_THRESHOLDS:
            rendered = labyrinth(
                image,
                preset="paper",
                passes=SHEET_PASSES,
                variance_threshold=threshold_for(reading, value),
                **reading,
            )
            cells.append(rendered[window])
        rows.append(cells)
    sheet = labelled_grid(
        rows,
        column_labels=["input"] + [f"V = {v:g}" for v in SHEET_THRESHOLDS],
        row_labels=list(READINGS),
        scale=scale,
        title=f"{path.stem.removeprefix('sheet-')}: {SHEET_PASSES} passes, "
        "V on the sqrt(V/N)/M scale",
    )
    io.imsave(path, sheet, check_contrast=False)


def window_summary(rows, image_names, thresholds) -> str:
    """Markdown tables: edge enhancement, cover and changed pixels against V.

    The window of a reading on an image is the range of V whose edge
    enhancement is at least 90 % of its best: there the added texture
    follows the input's edges most; below, walls flood smooth regions;
    above, they fade.
    """
    lines = []
    for metric in ("edge_enhancement", "labyrinth_cover", "changed"):
        lines += [
            f"### {metric}, {SHEET_PASSES} passes, 3 tone ranges",
            "",
            "| image | reading | " + " | ".join(f"V={v:g}" for v in thresholds) + " |",
            "|---|---|" + "---|" * len(thresholds),
        ]
        for name, reading in itertools.product(image_names, READINGS):
            values = _row_values(rows, name, reading, thresholds, metric)
            lines.append(
                f"| {name} | {reading} | " + " | ".join(f"{v:.3f}" for v in values) + " |"
            )
        lines.append("")
    lines += ["### window: V with edge enhancement >= 90 % of its best", ""]
    lines += ["| image | reading | best V | window |", "|---|---|---|---|"]
    for name, reading in itertools.product(image_names, READINGS):
        values = _row_values(rows, name, reading, thresholds, "edge_enhancement")
        best = int(np.argmax(values))
        if values[best] <= 0:
            lines.append(f"| {name} | {reading} | - | none (no edge enhancement) |")
            continue
        inside = [v for v, e in zip(thresholds, values) if e >= 0.9 * values[best]]
        lines.append(
            f"| {name} | {reading} | {thresholds[best]:g} | {min(inside):g} - {max(inside):g} |"
        )
    return "\n".join(lines) + "\n"


def _row_values(rows, name, reading, thresholds, metric):
    found = {
        r["variance_threshold"]: r[metric]
        for r in rows
        if r["image"] == name
        and r["reading"] == reading
        and r["passes"] == SHEET_PASSES
        and r["tone_ranges"] == 3
    }
    return [found[v] for v in thresholds]


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", default=str(ROOT / "docs" / "study"))
    parser.add_argument("--quick", action="store_true", help="a small sweep, for a smoke test")
    parser.add_argument("--workers", type=int, default=os.cpu_count() or 1)
    args = parser.parse_args(argv)
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)

    test_images = images(96 if args.quick else 256)
    thresholds = (0.08, 0.5) if args.quick else THRESHOLDS
    ranges = (3,) if args.quick else TONE_RANGES
    tasks = [
        (name, image, reading, value, r)
        for (name, image), reading, value, r in itertools.product(
            test_images.items(), READINGS, thresholds, ranges
        )
    ]
    start = time.perf_counter()
    with ProcessPoolExecutor(args.workers) as pool:
        rows = [row for result in pool.map(measure, tasks, chunksize=4) for row in result]
    print(
        f"{len(tasks)} stacks, {len(rows)} measured renderings in "
        f"{time.perf_counter() - start:.0f} s",
        file=sys.stderr,
    )

    fields = list(rows[0])
    with open(out / "metrics.csv", "w", newline="") as handle:
        writer = csv.DictWriter(handle, fields)
        writer.writeheader()
        for row in rows:
            writer.writerow({k: f"{v:.4g}" if isinstance(v, float) else v for k, v in row.items()})

    summary = window_summary(rows, list(test_images), thresholds)
    (out / "window.md").write_text(summary)
    print(summary)

    if not args.quick:
        for name, image in test_images.items():
            contact_sheet(image, out / f"sheet-{name}.png")
    print(f"wrote {out}", file=sys.stderr)


if __name__ == "__main__":
    main()
