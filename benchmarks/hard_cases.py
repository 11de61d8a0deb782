"""Images the study does not hold, on which the edge-enhancement score and what a person sees
part ways (issue 28): smooth noisy textures, black fields photographed as JPEG, low-contrast
16-bit fluorescence.

``hard_cases()`` returns them by name; ``benchmarks/auto_table.py`` measures Auto V on them
beside the study's images.
"""

from __future__ import annotations

import io

import numpy as np

#: Side of the hard cases, pixels.
SIZE = 384

#: Grey-level noise (sigma, tones of 0-255) added to the smooth Schlieren texture.
SCHLIEREN_NOISE = (0, 2, 4, 8)

#: JPEG quality of the photographed black fields (a camera's or a browser's default).
JPEG_QUALITY = 80


def hard_cases(size: int = SIZE, *, seed: int = 0) -> dict[str, np.ndarray]:
    """The hard cases, ``size`` x ``size``, by name: uint8 but the 16-bit fluorescence.

    - ``schlieren-noise-<s>``: a nematic Schlieren texture without noise of its own
      (``samples.nematic_schlieren(noise=0)``) on 0-255, with Gaussian grey-level noise of
      sigma ``s`` added and rounded to uint8, as a camera adds;
    - ``batonnets-jpeg``: smectic bâtonnets on their black field with extra read noise,
      saved and read back as a JPEG;
    - ``droplets-jpeg``: nematic droplets between crossed polarisers (the Schlieren
      texture seen through round openings) on a black field with noise, as a JPEG;
    - ``fluorescence-low-contrast``: uint16 blobs at 2 % of the uint16 range above an
      offset of 1000 counts, with Poisson (shot) noise.
    """
    from napari_labyrinth import samples

    rng = np.random.default_rng(seed)
    shape = (size, size)
    smooth = samples.nematic_schlieren(shape, seed=seed, noise=0.0).astype(np.float64) * 255.0
    cases = {}
    for sigma in SCHLIEREN_NOISE:
        noisy = smooth + rng.normal(0.0, sigma, shape) if sigma else smooth
        cases[f"schlieren-noise-{sigma}"] = _uint8(noisy)

    batonnets = samples.smectic_batonnets(shape, seed=seed).astype(np.float64)
    cases["batonnets-jpeg"] = _jpeg(_uint8(batonnets + rng.normal(0.0, 2.0, shape)))

    y, x = np.mgrid[0:size, 0:size].astype(np.float64)
    openings = np.zeros(shape)
    for _ in range(max(3, size // 64)):
        cy, cx, radius = (
            rng.uniform(0, size),
            rng.uniform(0, size),
            rng.uniform(size / 10, size / 5),
        )
        edge = np.hypot(y - cy, x - cx) - radius
        openings = np.maximum(openings, 1.0 / (1.0 + np.exp(np.clip(edge, -50, 50))))
    droplets = 6.0 + 0.9 * smooth * openings + rng.normal(0.0, 2.0, shape)
    cases["droplets-jpeg"] = _jpeg(_uint8(droplets))

    signal = np.zeros(shape)
    for _ in range(max(4, size * size // 64**2)):
        cy, cx, radius = rng.uniform(0, size), rng.uniform(0, size), rng.uniform(6, 18)
        box = tuple(  # the blob within 5 radii: beyond, exp(-12.5) is below the counts' step
            slice(max(0, int(c - 5 * radius)), min(size, int(c + 5 * radius) + 1))
            for c in (cy, cx)
        )
        signal[box] += np.exp(-((y[box] - cy) ** 2 + (x[box] - cx) ** 2) / (2 * radius**2))
    peak = 0.02 * np.iinfo(np.uint16).max
    counts = rng.poisson(1000.0 + peak * np.clip(signal, 0.0, 1.0))
    cases["fluorescence-low-contrast"] = np.clip(counts, 0, 65535).astype(np.uint16)
    return cases


def _uint8(values: np.ndarray) -> np.ndarray:
    return np.clip(np.rint(values), 0, 255).astype(np.uint8)


def _jpeg(image: np.ndarray) -> np.ndarray:
    """``image`` saved as a JPEG of ``JPEG_QUALITY`` and read back (its blocks and ringing)."""
    from PIL import Image

    buffer = io.BytesIO()
    Image.fromarray(image).save(buffer, format="JPEG", quality=JPEG_QUALITY)
    buffer.seek(0)
    return np.asarray(Image.open(buffer).convert("L"))


if __name__ == "__main__":
    for name, image in hard_cases().items():
        print(f"{name}: {image.dtype} {image.shape}, {image.min()}-{image.max()}, "
              f"median {np.median(image):g}")  # fmt: skip
