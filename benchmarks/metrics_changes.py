"""The metrics before and after a change of their definitions, on the study's images.

For every image of ``benchmarks/study.py`` (256 x 256) and its renderings by
the default preset (passes 1 and 4, seed 0), on the 0-255 tones the kernel
sees: every metric of the previous implementation (``tests/metrics/_metrics_reference.py``,
"before") and of ``napari_labyrinth.metrics`` ("after"), their relative
difference, and the fraction of pixels where the two wall maps differ.
Prints a Markdown table (the one in ``docs/metrics.md``) and the largest
relative difference of every metric.

Run: ``python benchmarks/metrics_changes.py`` (a few seconds).

``--against TREE`` asks instead whether a change left every metric the same,
bit for bit: this tree's and TREE's ``metrics.describe`` (each in its own
process) on scikit-image's camera and five other images at ``--sizes``
(default 512 and 2048), rendered with 1 and 3 passes as uint8, and once as
uint16 and as float32; prints the cases whose values differ (about a
minute).
"""

from __future__ import annotations

import argparse
import json
import math
import os
import subprocess
import sys
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "tests" / "metrics"))  # the previous implementation
sys.path.insert(0, str(ROOT / "benchmarks"))

PASSES = (1, 4)
#: The metrics whose definition changed, shown in the table (the others in the summary).
SHOWN = ("orientation_coherence", "contour_alignment")


def relative(before: float, after: float) -> float:
    if math.isnan(before) and math.isnan(after):
        return 0.0
    if before == after:
        return 0.0
    return abs(after - before) / abs(before)


def main() -> None:
    import _metrics_reference as reference
    import study

    from napari_labyrinth import labyrinth, metrics

    print("| image | passes | " + " | ".join(f"{k} before | after | rel." for k in SHOWN), end="")
    print(" | wall pixels differing |")
    print("|---|---|" + "---|---|---|" * len(SHOWN) + "---|")
    worst = {name: 0.0 for name in metrics.METRICS}
    for name, image in study.images(256).items():
        original = study.tones(image)
        for passes in PASSES:
            rendered = study.tones(image, labyrinth(image, passes=passes, seed=0))
            before = reference.describe(original, rendered)
            after = metrics.describe(original, rendered)
            for key in metrics.METRICS:
                worst[key] = max(worst[key], relative(before[key], after[key]))
            cells = []
            for key in SHOWN:
                change = relative(before[key], after[key])
                cells.append(f"{before[key]:.5f} | {after[key]:.5f} | {change:.1e}")
            walls = np.mean(metrics.wall_map(rendered) != reference.wall_map(rendered))
            print(f"| {name} | {passes} | " + " | ".join(cells) + f" | {walls:.1e} |")
    print("\nlargest relative difference over these images:")
    for key, value in worst.items():
        print(f"  {key:<24}{value:.1e}")


def values(sizes) -> dict[str, list[str]]:
    """Every metric (``repr``: every bit) of this process's ``napari_labyrinth`` on the cases
    of ``--against``."""
    from bench_metrics import camera, other_images

    from napari_labyrinth import labyrinth, metrics

    found = {}
    for size in sizes:
        for number, image in enumerate([camera(size), *other_images(size)]):
            cases = {f"uint8, {p} passes": (image, p) for p in (1, 3)}
            cases["uint16"] = (image.astype(np.uint16) * 257, 1)
            cases["float32"] = (image.astype(np.float32) / 255, 1)
            for label, (original, passes) in cases.items():
                rendered = labyrinth(original, seed=0, passes=passes)
                row = metrics.describe(original, rendered)
                found[f"{size}^2 image {number} {label}"] = [repr(v) for v in row.values()]
    return found


def compare(tree: Path, sizes) -> None:
    """Whether TREE and this tree give the same metrics, bit for bit; printed."""
    results = {}
    for name, source in (("TREE", tree), ("this", ROOT)):
        environment = dict(os.environ, PYTHONPATH=str(source / "src"))
        command = [sys.executable, __file__, "--child", "--sizes", *map(str, sizes)]
        output = subprocess.run(
            command, env=environment, capture_output=True, text=True, check=True
        )
        results[name] = json.loads(output.stdout.splitlines()[-1])
    this, other = results["this"], results["TREE"]
    differing = [case for case in this if this[case] != other[case]]
    print(f"{len(results['this'])} cases, {tree} against {ROOT}: ", end="")
    print("every metric the same, bit for bit" if not differing else f"{len(differing)} differ")
    for case in differing:
        print(f"  {case}: {results['TREE'][case]} -> {results['this'][case]}")


if __name__ == "__main__":
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--against", type=Path, default=None, help="another checkout")
    parser.add_argument("--sizes", type=int, nargs="+", default=[512, 2048])
    parser.add_argument("--child", action="store_true", help=argparse.SUPPRESS)
    arguments = parser.parse_args()
    if arguments.child:
        print(json.dumps(values(arguments.sizes)))
    elif arguments.against is not None:
        compare(arguments.against.resolve(), arguments.sizes)
    else:
        main()
