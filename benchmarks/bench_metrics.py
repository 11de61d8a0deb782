"""Speed of ``metrics.describe``: the previous implementation against the current one.

Prints figures, asserts nothing. For each size, the input is scikit-image's
``camera`` resized, and the rendering a real one, ``labyrinth(image)`` with
the default preset. Timed, interleaved round after round (best of the
rounds; the machine may be shared, so the load average is printed):

- ``reference``: the previous implementation, kept as ``tests/_metrics_reference.py``;
- ``first pass``: ``Comparison(original).describe(rendered)``, the original's
  own maps included (what ``describe`` costs the first time it sees an input);
- ``next passes``: ``comparison.describe(rendered)`` on a ``Comparison`` that
  already holds the original's maps (every pass of a stack after the first);
- ``describe()``: ``metrics.describe(original, rendered)`` called again with
  the same original: the original's maps come from its content-keyed cache,
  the call hashes the original.

Run: ``python benchmarks/bench_metrics.py [--sizes 512 2048 4096] [--rounds 3]``.
The reference takes about a minute per call at 4096 x 4096 on two cores.
"""

from __future__ import annotations

import argparse
import os
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "tests"))  # the previous implementation, kept for the tests


def camera(size: int) -> np.ndarray:
    from skimage import data, transform

    image = transform.resize(data.camera(), (size, size), order=1, preserve_range=True)
    return image.astype(np.uint8)


def timed(function, *arguments):
    """``(seconds, function(*arguments))``."""
    start = time.perf_counter()
    result = function(*arguments)
    return time.perf_counter() - start, result


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--sizes", type=int, nargs="+", default=[512, 2048, 4096])
    parser.add_argument("--rounds", type=int, default=3)
    parser.add_argument(
        "--reference-rounds",
        type=int,
        default=None,
        help="rounds of the reference above 2048 x 2048 (default: 1; it is slow)",
    )
    args = parser.parse_args(argv)

    import _metrics_reference as reference

    from napari_labyrinth import labyrinth, metrics

    print(f"napari_labyrinth from {Path(metrics.__file__).parent}")
    cases = {}
    for size in args.sizes:
        original = camera(size)
        cases[size] = (original, labyrinth(original, seed=0))
    # compile (or load from numba's cache) and warm up
    small = camera(64)
    metrics.describe(small, labyrinth(small, seed=0))

    times: dict[tuple[int, str], list[float]] = {}
    results = {}
    for round_number in range(args.rounds):
        print(f"round {round_number + 1}/{args.rounds}, load average {os.getloadavg()}")
        for size, (original, rendered) in cases.items():
            comparison = metrics.Comparison(original)
            seconds, results[(size, "new")] = timed(comparison.describe, rendered)
            times.setdefault((size, "first pass"), []).append(seconds)
            seconds, _ = timed(comparison.describe, rendered)
            times.setdefault((size, "next passes"), []).append(seconds)
            metrics.describe(original, rendered)  # the original's maps now in describe's cache
            seconds, _ = timed(metrics.describe, original, rendered)
            times.setdefault((size, "describe()"), []).append(seconds)
            reference_rounds = args.rounds if size <= 2048 else (args.reference_rounds or 1)
            if round_number < reference_rounds:
                seconds, results[(size, "reference")] = timed(
                    reference.describe, original, rendered
                )
                times.setdefault((size, "reference"), []).append(seconds)
                time.sleep(1.0)  # let BLAS's worker threads (np.corrcoef) go back to sleep

    print(f"\nload average at the end {os.getloadavg()}, {os.cpu_count()} cores")
    print("best of the rounds, seconds per call (speed-up over the reference):\n")
    columns = ("reference", "first pass", "next passes", "describe()")
    print(f"{'size':>11} " + " ".join(f"{name:>20}" for name in columns))
    for size in cases:
        best = {name: min(times[(size, name)]) for name in columns if (size, name) in times}
        cells = []
        for name in columns:
            if name not in best:
                cells.append(f"{'-':>20}")
            elif name == "reference" or "reference" not in best:
                cells.append(f"{best[name]:>20.3f}")
            else:
                cells.append(f"{best[name]:>9.3f} ({best['reference'] / best[name]:>5.0f}x)   ")
        print(f"{size:>5} x {size:<5}" + " ".join(cells))
    print("\nthe original's own maps (first pass minus next passes, best of the rounds):")
    for size in cases:
        extra = min(times[(size, "first pass")]) - min(times[(size, "next passes")])
        print(f"{size:>5} x {size:<5} {extra:.3f} s")
    print("\nlargest relative difference from the reference over the metrics:")
    for size in cases:
        if (size, "reference") not in results:
            continue
        old, new = results[(size, "reference")], results[(size, "new")]
        worst = max(
            0.0 if (np.isnan(old[k]) and np.isnan(new[k])) else abs(new[k] - old[k]) / abs(old[k])
            for k in old
        )
        print(f"{size:>5} x {size:<5} {worst:.1e}")


if __name__ == "__main__":
    main()
