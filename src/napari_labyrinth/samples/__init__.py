"""Sample images: synthetic liquid-crystal textures and two scikit-image photographs.

The synthetic textures are what liquid-crystal researchers put under a
polarising microscope, the kind of pattern the labyrinthine tiling evokes:

- :func:`nematic_schlieren`: a nematic film with point defects between
  crossed polarisers (dark brushes meeting at the defects);
- :func:`cholesteric_fingerprint`: the stripes of a cholesteric whose helix
  axis lies in the plane of the film.

Three more stand for the images on which one variance threshold does not
serve all (dark backgrounds, noise, bright low contrast):

- :func:`smectic_batonnets`: bright elongated germs of a smectic phase
  growing in a dark isotropic melt, between crossed polarisers (a near-black
  background, as in dark-field or fluorescence microscopy);
- :func:`fluorescence_stack`: a noisy 16-bit time-lapse of fluorescent cells
  (Poisson and read noise on a dim background);
- :func:`bright_fingerprint`: a cholesteric fingerprint seen in bright field,
  low contrast on a bright background.

They depend on numpy and scipy only and are deterministic for a given seed.
:func:`camera` and :func:`cell` return scikit-image's images (imported on
first use, so importing this module stays light).
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from .liquid_crystals import (
    bright_fingerprint,
    cholesteric_fingerprint,
    director_angle,
    nematic_schlieren,
    schlieren_defects,
    smectic_batonnets,
)
from .microscopy import camera, cell, fluorescence_stack

__all__ = [
    "SAMPLES",
    "bright_fingerprint",
    "camera",
    "cell",
    "cholesteric_fingerprint",
    "fluorescence_stack",
    "smectic_batonnets",
    "director_angle",
    "nematic_schlieren",
    "schlieren_defects",
]

SAMPLES: dict[str, Callable[[], np.ndarray]] = {
    "nematic_schlieren": nematic_schlieren,
    "cholesteric_fingerprint": cholesteric_fingerprint,
    "camera": camera,
    "cell": cell,
}
