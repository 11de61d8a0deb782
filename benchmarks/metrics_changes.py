"""The metrics before and after a change of their definitions, on the study's images.

For every image of ``benchmarks/study.py`` (256 x 256) and its renderings by
the default preset (passes 1 and 4, seed 0), on the 0-255 tones the kernel
sees: every metric of the previous implementation (``tests/_metrics_reference.py``,
"before") and of ``napari_labyrinth.metrics`` ("after"), their relative
difference, and the fraction of pixels where the two wall maps differ.
Prints a Markdown table (the one in ``docs/metrics.md``) and the largest
relative difference of every metric.

Run: ``python benchmarks/metrics_changes.py`` (a few seconds).
"""

from __future__ import annotations

import math
import sys
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "tests"))  # the previous implementation
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


if __name__ == "__main__":
    main()
