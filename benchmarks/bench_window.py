"""Does ``find_window``'s probe predict the whole image's window of V, and how fast is it?

Prints figures, asserts nothing. For every image of the study
(``benchmarks/study.py``: five photographs and textures, and the dark-field,
noisy 16-bit and bright low-contrast images) at ``--size`` pixels square:

- the *full sweep*: the whole image rendered with the default preset at every
  V of ``find_window``'s grid, its edge enhancement (on the 0-255 tones) and
  the window read from it as ``find_window`` reads the probe's;
- ``find_window(image)``: the probe's window and its chosen V, and whether
  that V lies inside the full sweep's window;
- the edge enhancement of the whole image at the chosen V and at the best V
  of the full sweep (what choosing on the probe costs).

Then the time of ``find_window`` on one plane of 512² and 2048² (best of
``--rounds``, interleaved; the 2048² images are the study's images made at
that size: the synthetic ones drawn at 2048², the photographs resized), and
on a 2048² stack of 8 planes. The load average is printed beside the times:
on a shared machine they are upper bounds.

Run: ``python benchmarks/bench_window.py [--size 512] [--rounds 3]`` (about two
minutes on two cores).
"""

from __future__ import annotations

import argparse
import os
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(Path(__file__).resolve().parent))


def tones(image) -> np.ndarray:
    """The image on the 0-255 tone scale the kernel sees (default tone limits)."""
    from napari_labyrinth.core.tone_scale import resolve_tone_scale

    return resolve_tone_scale(image, None).to_tones(image)


def full_sweep(image, thresholds, **options):
    """Edge enhancement of the whole image rendered at each V (default preset)."""
    from napari_labyrinth import labyrinth, metrics
    from napari_labyrinth.core.tone_scale import resolve_tone_scale

    scale = resolve_tone_scale(image, None)
    before = scale.to_tones(image)
    return [
        metrics.edge_enhancement(
            before, scale.to_tones(labyrinth(image, variance_threshold=value, **options))
        )
        for value in thresholds
    ]


def compare(images, *, out=sys.stdout) -> list[dict]:
    """The table of full-sweep windows against find_window's, one row per image."""
    from napari_labyrinth.window import find_window, window_of

    rows = []
    print(
        "| image | full-sweep window | full best V | find_window window | chosen V | inside | "
        "EE at chosen V | EE at full best V |",
        file=out,
    )
    print("|---|---|---|---|---|---|---|---|", file=out)
    for name, image in images.items():
        window = find_window(image)
        curve = full_sweep(image, window.thresholds)
        low, best, high, found = window_of(window.thresholds, curve, default=float("nan"))
        at_chosen = curve[window.thresholds.index(window.best)]
        at_best = max(curve)
        inside = found and low <= window.best <= high
        rows.append(
            dict(
                image=name,
                full=(low, best, high),
                probe=(window.low, window.best, window.high),
                inside=inside,
                at_chosen=at_chosen,
                at_best=at_best,
                curve=curve,
                probe_curve=window.edge_enhancement,
                thresholds=window.thresholds,
            )
        )
        print(
            f"| {name} | {low:.4g}-{high:.4g} | {best:.4g} | "
            f"{window.low:.4g}-{window.high:.4g} | {window.best:.4g} | "
            f"{'yes' if inside else 'NO'} | {at_chosen:.3f} | {at_best:.3f} |",
            file=out,
            flush=True,
        )
    return rows


def time_it(function, rounds: int) -> float:
    best = float("inf")
    for _ in range(rounds):
        start = time.perf_counter()
        function()
        best = min(best, time.perf_counter() - start)
    return best


def main(argv=None):
    from study import images

    from napari_labyrinth.window import find_window

    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--size", type=int, default=512, help="side of the compared images")
    parser.add_argument("--rounds", type=int, default=3)
    parser.add_argument("--no-compare", action="store_true", help="only the timings")
    args = parser.parse_args(argv)

    print(f"load average before: {os.getloadavg()}, {os.cpu_count()} cores")
    find_window(np.zeros((64, 64), np.uint8) + np.arange(64, dtype=np.uint8))  # compile
    small = images(512)
    if not args.no_compare:
        print(f"\n## Probe against full sweep, {args.size}² (default preset, 4 passes)\n")
        compare(small if args.size == 512 else images(args.size))

    print("\n## Time of find_window (best of rounds, seconds)\n")
    large = images(2048)
    stack = np.stack([np.roll(large["fluorescence-16bit"], 37 * k, axis=1) for k in range(8)])
    print("| image | 512² | 2048² | load |")
    print("|---|---|---|---|")
    for name in small:
        t_small = time_it(lambda: find_window(small[name]), args.rounds)
        t_large = time_it(lambda: find_window(large[name]), args.rounds)
        load = os.getloadavg()[0]
        print(f"| {name} | {t_small:.3f} | {t_large:.3f} | {load:.2f} |", flush=True)
    t_stack = time_it(lambda: find_window(stack), args.rounds)
    print(f"| 8-plane 2048² uint16 stack | | {t_stack:.3f} | {os.getloadavg()[0]:.2f} |")
    print(f"\nload average after: {os.getloadavg()}")


if __name__ == "__main__":
    main()
