"""The result layer's keyword arguments: name, transforms, units, display settings, metadata key.

A result sits where its input sits: :func:`result_layer_kwargs` carries the
input layer's transforms over (a stack's or sweep's new leading axis gets
scale 1; a plane rendered alone is moved to its place in the input) with its
display settings. The run's provenance record goes in the layer's
``metadata`` under :data:`METADATA_KEY`.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from ..provenance import KEY
from .choices import LayerSnapshot

__all__ = ["METADATA_KEY", "data_to_physical", "result_layer_kwargs"]

#: Key of the result layers' ``metadata`` under which a run is recorded
#: (the provenance record of :mod:`napari_labyrinth.provenance`).
METADATA_KEY = KEY


def _shear_matrix(shear: np.ndarray, ndim: int) -> np.ndarray:
    """An ``(ndim, ndim)`` shear matrix from napari's upper-triangular values or a matrix."""
    shear = np.asarray(shear, dtype=float)
    if shear.ndim == 2:
        return shear
    matrix = np.eye(ndim)
    matrix[np.triu_indices(ndim, k=1)] = shear
    return matrix


def data_to_physical(snapshot: LayerSnapshot) -> np.ndarray:
    """Linear part of the layer's data-to-physical transform: rotate @ shear @ scale (napari's)."""
    n = snapshot.ndim
    return (
        np.asarray(snapshot.rotate, dtype=float)
        @ _shear_matrix(snapshot.shear, n)
        @ np.diag(np.asarray(snapshot.scale, dtype=float))
    )


def result_layer_kwargs(
    snapshot: LayerSnapshot,
    name: str,
    extra_axis: str | None,
    plane_index: tuple[int, ...] | None,
) -> dict[str, Any]:
    """Name, transforms, units and contrast settings of a result layer.

    ``extra_axis`` names a new leading axis (stack, sweep), which gets
    scale 1. A single plane rendered alone (``plane_index``) sits where it is
    in the input: its translate moves by the data-to-physical image of its
    index (the extra affine transform then maps it where the input's plane is).
    """
    scale = np.asarray(snapshot.scale, dtype=float)
    translate = np.asarray(snapshot.translate, dtype=float)
    if plane_index is not None:
        offset = np.zeros(snapshot.ndim)
        offset[: len(plane_index)] = plane_index
        translate = translate + data_to_physical(snapshot) @ offset
    units = tuple(snapshot.units)
    axis_labels = tuple(snapshot.axis_labels)
    rotate = np.asarray(snapshot.rotate)
    shear = np.asarray(snapshot.shear)
    affine = np.asarray(snapshot.affine, dtype=float)
    if extra_axis is not None:
        n = snapshot.ndim
        scale = np.concatenate([[1.0], scale])
        translate = np.concatenate([[0.0], translate])
        units = ("pixel",) + units
        axis_labels = (extra_axis,) + axis_labels
        embedded = np.eye(n + 1)
        embedded[1:, 1:] = rotate
        rotate = embedded
        shear = (
            np.concatenate([np.zeros(n), shear.ravel()])
            if shear.ndim == 1
            else (np.pad(shear, ((1, 0), (1, 0))))
        )
        if shear.ndim == 2:
            shear[0, 0] = 1.0
        expanded = np.eye(n + 2)
        expanded[1:, 1:] = affine
        affine = expanded
    kwargs: dict[str, Any] = {
        "name": name,
        "scale": scale,
        "translate": translate,
        "rotate": rotate,
        "shear": shear,
        "affine": affine,
        "units": units,
        "axis_labels": axis_labels,
        "rgb": bool(snapshot.rgb),
        "contrast_limits": list(snapshot.contrast_limits),
        "gamma": snapshot.gamma,
        "opacity": snapshot.opacity,
        "blending": snapshot.blending,
        "interpolation2d": snapshot.interpolation2d,
    }
    if not snapshot.rgb:
        kwargs["colormap"] = snapshot.colormap
    return kwargs
