"""Sample data contributed to napari (File > Open Sample > Labyrinthine tiling).

Plain functions that return napari layer-data tuples ``(data, kwargs, "image")``;
the manifest (``napari.yaml``) names them. Nothing here imports napari or Qt:
the images come from :mod:`napari_labyrinth.samples` and scikit-image, which
ships them with its wheel (no download).
"""

from __future__ import annotations

from typing import Any

import numpy as np

from . import samples

LayerDataTuple = tuple[np.ndarray, dict[str, Any], str]


def nematic_schlieren_sample() -> list[LayerDataTuple]:
    """Synthetic Schlieren texture of a nematic film between crossed polarisers.

    Returns
    -------
    list of layer-data tuple
        One 512 x 512 float32 image in [0, 1] (seed 0).
    """
    image = samples.nematic_schlieren((512, 512), seed=0)
    return [
        (
            image,
            {
                "name": "nematic Schlieren",
                "colormap": "gray",
                "contrast_limits": (0.0, 1.0),
                "metadata": {"source": "napari_labyrinth.samples.nematic_schlieren(seed=0)"},
            },
            "image",
        )
    ]


def cholesteric_fingerprint_sample() -> list[LayerDataTuple]:
    """Synthetic fingerprint texture of a cholesteric with its helix in the plane.

    Returns
    -------
    list of layer-data tuple
        One 512 x 512 float32 image in [0, 1] (seed 0, pitch 16 pixels).
    """
    image = samples.cholesteric_fingerprint((512, 512), seed=0, pitch=16.0)
    return [
        (
            image,
            {
                "name": "cholesteric fingerprint",
                "colormap": "gray",
                "contrast_limits": (0.0, 1.0),
                "metadata": {
                    "source": "napari_labyrinth.samples.cholesteric_fingerprint(seed=0, pitch=16)"
                },
            },
            "image",
        )
    ]


def cell_sample() -> list[LayerDataTuple]:
    """The ``cell`` micrograph of scikit-image (grey, uint8).

    Returns
    -------
    list of layer-data tuple
        One 660 x 550 uint8 image.
    """
    return [
        (
            samples.cell(),
            {
                "name": "cell",
                "colormap": "gray",
                "contrast_limits": (0, 255),
                "metadata": {"source": "skimage.data.cell()"},
            },
            "image",
        )
    ]


def immunohistochemistry_sample() -> list[LayerDataTuple]:
    """The ``immunohistochemistry`` colour micrograph of scikit-image (RGB, uint8).

    Returns
    -------
    list of layer-data tuple
        One 512 x 512 x 3 uint8 RGB image.
    """
    from skimage import data

    return [
        (
            np.asarray(data.immunohistochemistry()),
            {
                "name": "immunohistochemistry",
                "rgb": True,
                "contrast_limits": (0, 255),
                "metadata": {"source": "skimage.data.immunohistochemistry()"},
            },
            "image",
        )
    ]
