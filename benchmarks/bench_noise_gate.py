"""The noise gate: black fields before and after, the study's cover, and what it costs.

Prints three tables:

1. On photos with black backgrounds (:func:`black_field_images`), the share of
   the black field's pixels the default preset changes with the gate off
   (``noise_gate=0``) and on (the preset's k), the plane's noise (Immerkær's
   estimate, and the gate's σ: the larger of it and the dark field's), and the
   labyrinth cover of the whole rendering.
2. On every study image (``study.images()``), the labyrinth cover with the
   gate off and on, and their ratio.
3. The time of the noise estimate and of a 2048² rendering with the gate
   off and on (interleaved, best of several), with the machine's load.

``--k 1,1.5,2,3`` adds one column per k to tables 1 and 2 (the choice of the
preset's k). ``--sheet docs/study/sheet-noise-gate.png`` writes the
before/after picture: a crop of each black-field image at 4x.

The image set is a function (:func:`black_field_images`) that another script
can import and extend: each case is an image and the mask of its black field.

Run: ``python benchmarks/bench_noise_gate.py [--size 512] [--k ...] [--sheet PATH]``.
"""

from __future__ import annotations

import argparse
import io
import os
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).parent))

#: JPEG quality of the photographed cases (a camera's or a browser's usual).
JPEG_QUALITY = 85


def jpeg(image: np.ndarray, quality: int = JPEG_QUALITY) -> np.ndarray:
    """``image`` saved as a JPEG of ``quality`` and read back (imageio)."""
    import imageio.v3 as iio

    buffer = io.BytesIO()
    iio.imwrite(buffer, image, extension=".jpg", quality=quality)
    return iio.imread(buffer.getvalue(), extension=".jpg")


def batonnets_on_black(size: int, noise: float, seed: int = 0) -> np.ndarray:
    """Smectic bâtonnets (``samples.smectic_batonnets``, a few) on a black field, sensor
    noise of deviation ``noise`` added over the whole frame, saved as a JPEG and read back."""
    from napari_labyrinth import samples

    rods = samples.smectic_batonnets((size, size), seed=seed, count=max(1, size * size // 150**2))
    rng = np.random.default_rng(seed + 100)
    noisy = rods.astype(np.float64) + rng.normal(0.0, noise, rods.shape)
    return jpeg(np.clip(np.rint(noisy), 0, 255).astype(np.uint8))


def dark_field_rings(size: int, noise: float = 3.0, seed: int = 0) -> np.ndarray:
    """A dark-field micrograph: bright scattering rims of round particles on black, with
    shot and read noise (uint8)."""
    rng = np.random.default_rng(seed)
    y, x = np.mgrid[:size, :size].astype(np.float64)
    light = np.zeros((size, size))
    for _ in range(max(2, size * size // 120**2)):
        cy, cx, radius = rng.uniform(0, size), rng.uniform(0, size), rng.uniform(8, 30)
        distance = np.hypot(y - cy, x - cx) - radius
        light = np.maximum(light, rng.uniform(0.5, 1.0) * np.exp(-((distance / 1.8) ** 2)))
    photons = 3.0 + 200.0 * light
    counts = rng.poisson(photons) + rng.normal(0.0, noise, light.shape)
    return np.clip(np.rint(counts), 0, 255).astype(np.uint8)


def black_field_images(size: int = 512) -> dict[str, tuple[np.ndarray, np.ndarray]]:
    """The black-field cases: name -> (image, mask of its black field).

    The black field is ``study.dark_mask``: flat near-black pixels (local mean
    under 20 tones, weak gradient), the same definition on every case. The two
    black-field JPEGs of ``hard_cases.hard_cases()`` come at their own size.
    """
    from hard_cases import SIZE, hard_cases
    from study import dark_mask
    from study import images as study_images

    cases = {
        "batonnets, noise 2, JPEG 85": batonnets_on_black(size, 2.0, seed=1),
        "batonnets, noise 4, JPEG 85": batonnets_on_black(size, 4.0, seed=2),
        "dark-field rings, noise 3": dark_field_rings(size, 3.0, seed=3),
        "dark-field rings, noise 3, JPEG 85": jpeg(dark_field_rings(size, 3.0, seed=4)),
        "study dark-field": study_images(size)["dark-field"],
    }
    hard = hard_cases(SIZE)
    for name in ("batonnets-jpeg", "droplets-jpeg"):
        cases[f"hard case {name}, {SIZE} x {SIZE}"] = hard[name]
    return {name: (image, dark_mask(image)) for name, image in cases.items()}


def render(image: np.ndarray, k: float | None = None) -> np.ndarray:
    """The default preset's rendering; ``k`` the noise gate (None: the preset's)."""
    from napari_labyrinth import labyrinth

    return labyrinth(image, seed=0) if k is None else labyrinth(image, seed=0, noise_gate=k)


def black_field_table(cases, ks) -> list[str]:
    from napari_labyrinth import metrics
    from napari_labyrinth.core.noise import noise_sigma, tone_noise_sigma
    from napari_labyrinth.core.tone_scale import resolve_tone_scale

    head = "| image | Immerkær σ | gate's σ | field | changed, gate off | changed, gate on |"
    rule = "|---|---|---|---|---|---|"
    head += "".join(f" changed k={k:g} |" for k in ks)
    rule += "---|" * len(ks)
    head += " cover off | cover on |"
    rule += "---|---|"
    lines = [head, rule]
    for name, (image, field) in cases.items():
        off, on = render(image, 0.0), render(image)
        share = [float((rendered != image)[field].mean()) for rendered in (off, on)]
        extra = [float((render(image, k) != image)[field].mean()) for k in ks]
        covers = [metrics.labyrinth_cover(rendered) for rendered in (off, on)]
        sigma = tone_noise_sigma(image, resolve_tone_scale(image, None))
        lines.append(
            f"| {name} | {noise_sigma(image):.2f} | {sigma:.2f} | {field.mean():.2f} | "
            f"{share[0]:.1%} | "
            f"{share[1]:.1%} |"
            + "".join(f" {s:.1%} |" for s in extra)
            + f" {covers[0]:.3f} | {covers[1]:.3f} |"
        )
    return lines


def study_table(size: int, ks) -> list[str]:
    from study import images as study_images

    from napari_labyrinth import metrics
    from napari_labyrinth.core.noise import tone_noise_sigma
    from napari_labyrinth.core.tone_scale import resolve_tone_scale

    head = "| image | gate's σ | cover, gate off | cover, gate on | on / off |"
    rule = "|---|---|---|---|---|"
    head += "".join(f" k={k:g} on / off |" for k in ks)
    rule += "---|" * len(ks)
    lines = [head, rule]
    for name, image in study_images(size).items():
        scale = resolve_tone_scale(image, None)
        sigma = tone_noise_sigma(image, scale)
        # the cover is measured on the tones the kernel saw (as the study does)
        off = metrics.labyrinth_cover(scale.to_tones(render(image, 0.0)))
        on = metrics.labyrinth_cover(scale.to_tones(render(image)))
        extra = [metrics.labyrinth_cover(scale.to_tones(render(image, k))) / off for k in ks]
        lines.append(
            f"| {name} | {sigma:.2f} | {off:.3f} | {on:.3f} | {on / off:.2f} |"
            + "".join(f" {ratio:.2f} |" for ratio in extra)
        )
    return lines


def timing_table(size: int = 2048, repeats: int = 5) -> list[str]:
    from napari_labyrinth import labyrinth, samples
    from napari_labyrinth.core.noise import noise_sigma, tone_noise_sigma
    from napari_labyrinth.core.tone_scale import resolve_tone_scale

    image = samples.smectic_batonnets((size, size), seed=0)
    labyrinth(image[:64, :64])  # compiled (or loaded) before the clock starts
    labyrinth(image[:64, :64], noise_gate=0)
    scale = resolve_tone_scale(image, None)
    times: dict[str, list[float]] = {
        "Immerkær σ alone": [],
        "gate's σ (Immerkær and dark field)": [],
        "render, gate off": [],
        "render, gate on": [],
    }
    load = os.getloadavg()
    for _ in range(repeats):  # interleaved: a change in the machine's load hits every variant
        start = time.perf_counter()
        noise_sigma(image)
        times["Immerkær σ alone"].append(time.perf_counter() - start)
        start = time.perf_counter()
        tone_noise_sigma(image, scale)
        times["gate's σ (Immerkær and dark field)"].append(time.perf_counter() - start)
        for label, k in (("render, gate off", 0.0), ("render, gate on", None)):
            start = time.perf_counter()
            render(image, k)
            times[label].append(time.perf_counter() - start)
    load = tuple(max(a, b) for a, b in zip(load, os.getloadavg()))
    header = (
        f"{size}² uint8 (smectic_batonnets), default preset (4 passes), default workers, "
        f"best of {repeats}, load average {load[0]:.2f} {load[1]:.2f} {load[2]:.2f}"
    )
    lines = [
        header,
        "",
        "| what | best (s) | median (s) |",
        "|---|---|---|",
    ]
    for label, values in times.items():
        lines.append(f"| {label} | {min(values):.3f} | {float(np.median(values)):.3f} |")
    return lines


def sheet(cases, path: Path, crop: int = 96, scale: int = 4) -> None:
    """Input, gate off, gate on: a crop of each case at ``scale``x, where the field meets
    an object (the crop with the most field pixels next to non-field ones)."""
    from figures import labelled_grid
    from skimage import io

    rows, labels = [], []
    for name, (image, field) in cases.items():
        top, left = _crop_corner(field, crop)
        window = (slice(top, top + crop), slice(left, left + crop))
        off, on = render(image, 0.0), render(image)
        rows.append([image[window], off[window], on[window]])
        labels.append(name)
    grid = labelled_grid(
        rows,
        column_labels=["input", "gate off (k = 0)", "gate on (preset)"],
        row_labels=labels,
        scale=scale,
        title=f"noise gate: default preset, {crop} x {crop} crops at {scale}x",
    )
    io.imsave(path, grid, check_contrast=False)


def _crop_corner(field: np.ndarray, crop: int) -> tuple[int, int]:
    """The corner of the ``crop``² window holding about half field, half objects."""
    best, corner = -1.0, (0, 0)
    step = max(1, crop // 4)
    for top in range(0, field.shape[0] - crop + 1, step):
        for left in range(0, field.shape[1] - crop + 1, step):
            share = field[top : top + crop, left : left + crop].mean()
            score = share * (1.0 - share)
            if score > best:
                best, corner = score, (top, left)
    return corner


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--size", type=int, default=512, help="side of the images")
    parser.add_argument("--k", default="", help="more gates to compare, e.g. 1,1.5,3")
    parser.add_argument("--sheet", type=Path, help="write the before/after picture here")
    parser.add_argument("--no-timing", action="store_true")
    args = parser.parse_args(argv)
    ks = [float(k) for k in args.k.split(",") if k]
    cases = black_field_images(args.size)
    print(f"## Black fields ({args.size}²): share of the field's pixels changed\n")
    print("\n".join(black_field_table(cases, ks)))
    print(f"\n## Study images ({args.size}²): labyrinth cover\n")
    print("\n".join(study_table(args.size, ks)))
    if not args.no_timing:
        print("\n## Time\n")
        print("\n".join(timing_table()))
    if args.sheet:
        sheet(cases, args.sheet)
        print(f"\nwrote {args.sheet}")


if __name__ == "__main__":
    main()
