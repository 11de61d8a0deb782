"""Does ``find_window``'s probe predict the whole image's choice of V, and how fast is it?

Prints figures, asserts nothing. For every image of the study
(``benchmarks/study.py``: five photographs and textures, and the dark-field,
noisy 16-bit and bright low-contrast images) at ``--size`` pixels square:

- the *full sweep*: the whole image rendered with the default preset at every
  V of ``find_window``'s grid, measured as the probe is (edge enhancement,
  labyrinth cover, contour alignment, changed pixels, on the 0-255 tones),
  and the V and window the criterion (``window_criterion.choose``) reads
  from it;
- ``find_window(image)``: the probe's window and its chosen V, whether that V
  lies inside the full sweep's window, and whether the probe's window is open
  (reaches the lowest or highest V probed: it may go on beyond them);
- the whole image's cover and edge enhancement at the chosen V and at the
  full sweep's (what choosing on the probe costs).

Then the time of ``find_window`` on one plane of 512² and 2048² (best of
``--rounds``, interleaved; the 2048² images are the study's images made at
that size: the synthetic ones drawn at 2048², the photographs resized), and
on a 2048² uint16 stack of 8 planes: wall time and the process's CPU time
(both threads), each the best of the rounds. The load average is printed
beside the times: on a shared machine they are upper bounds.

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


#: What the full sweep measures at each V, in the order of ``window_criterion.choose``'s curves.
_MEASURED = ("edge_enhancement", "labyrinth_cover", "contour_alignment")


def full_sweep(image, thresholds, **options):
    """The whole image rendered at each V (default preset): its edge enhancement, cover,
    contour alignment and changed pixels (four lists), and the input's own cover."""
    from napari_labyrinth import labyrinth, metrics
    from napari_labyrinth.core.tone_scale import resolve_tone_scale

    scale = resolve_tone_scale(image, None)
    before = scale.to_tones(image)
    comparison = metrics.Comparison(before)
    curves = [[] for _ in range(len(_MEASURED) + 1)]
    for value in thresholds:
        rendered = labyrinth(image, variance_threshold=value, **options)
        measured = comparison.measure(scale.to_tones(rendered), _MEASURED)
        figures = [*(measured[name] for name in _MEASURED), float(np.mean(rendered != image))]
        for curve, figure in zip(curves, figures):
            curve.append(figure)
    return curves, metrics.labyrinth_cover(before)


def compare(images, *, out=sys.stdout) -> list[dict]:
    """The table of the full sweep's choice against find_window's, one row per image."""
    from napari_labyrinth.window import find_window
    from napari_labyrinth.window_criterion import choose

    rows = []
    print(
        "| image | full-sweep window | full-sweep V | find_window window | open | chosen V | "
        "inside | cover at chosen V | cover at full-sweep V | EE at chosen V | "
        "EE at full-sweep V |",
        file=out,
    )
    print("|---|---|---|---|---|---|---|---|---|---|---|", file=out)
    for name, image in images.items():
        window = find_window(image)
        curves, input_cover = full_sweep(image, window.thresholds)
        full = choose(*curves, input_cover=input_cover)
        v = window.thresholds
        low, best, high, found = v[full.low], v[full.best], v[full.high], full.found
        chosen = v.index(window.best)
        curve, cover = curves[0], curves[1]
        at_chosen, at_best = curve[chosen], curve[full.best]
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
        ends = [end for end, is_open in (("low", window.low_open), ("high", window.high_open))
                if is_open]  # fmt: skip
        print(
            f"| {name} | {low:.4g}-{high:.4g} | {best:.4g} | "
            f"{window.low:.4g}-{window.high:.4g} | {' '.join(ends) or '-'} | {window.best:.4g} | "
            f"{'yes' if inside else 'NO'} | {cover[chosen]:.3f} | {cover[full.best]:.3f} | "
            f"{at_chosen:.3f} | {at_best:.3f} |",
            file=out,
            flush=True,
        )
    return rows


def time_it(function, rounds: int) -> tuple[float, float]:
    """Best wall time and best CPU time (seconds) of ``rounds`` calls."""
    wall = cpu = float("inf")
    for _ in range(rounds):
        start, start_cpu = time.perf_counter(), time.process_time()
        function()
        wall = min(wall, time.perf_counter() - start)
        cpu = min(cpu, time.process_time() - start_cpu)
    return wall, cpu


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

    print("\n## Time of find_window (best of rounds, seconds: wall / CPU of both threads)\n")
    large = images(2048)
    stack = np.stack([np.roll(large["fluorescence-16bit"], 37 * k, axis=1) for k in range(8)])
    print("| image | 512² | 2048² | load |")
    print("|---|---|---|---|")
    for name in small:
        t_small = time_it(lambda: find_window(small[name]), args.rounds)
        t_large = time_it(lambda: find_window(large[name]), args.rounds)
        load = os.getloadavg()[0]
        print(
            f"| {name} | {t_small[0]:.3f} / {t_small[1]:.3f} | {t_large[0]:.3f} / "
            f"{t_large[1]:.3f} | {load:.2f} |",
            flush=True,
        )
    wall, cpu = time_it(lambda: find_window(stack), args.rounds)
    print(f"| 8-plane 2048² uint16 stack | | {wall:.3f} / {cpu:.3f} | {os.getloadavg()[0]:.2f} |")
    print(f"\nload average after: {os.getloadavg()}")


if __name__ == "__main__":
    main()
