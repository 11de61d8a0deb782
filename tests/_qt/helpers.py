"""Helpers of the viewer tests: test images, a run through the widget, its reproduction."""

from __future__ import annotations

import json

import numpy as np

import napari_labyrinth
from napari_labyrinth.plan import METADATA_KEY

#: A guard against a hung run, not a time limit: the first run of a session compiles numba's
#: kernels (the metrics' take ~20 s of CPU, 40 s on a loaded 2-core machine).
RUN_TIMEOUT_MS = 180_000


def noise(shape, dtype=np.uint8, seed=0):
    rng = np.random.default_rng(seed)
    if np.dtype(dtype).kind == "f":
        return rng.random(shape).astype(dtype)
    return rng.integers(0, 256, shape).astype(dtype)


def run(qtbot, widget):
    """Start a run and wait until its worker has finished."""
    worker = widget.run()
    assert worker is not None, widget.status.value
    qtbot.waitUntil(lambda: widget.worker is None, timeout=RUN_TIMEOUT_MS)
    return worker


def reproduce(layer, source):
    """Render again through the API from what the result layer's metadata records."""
    record = json.loads(json.dumps(layer.metadata[METADATA_KEY]))  # survives JSON
    if record["source_index"] is not None:
        source = source[tuple(record["source_index"])]
    result = getattr(napari_labyrinth, record["function"])(source, **record["arguments"])
    return np.asarray(result)


def result_data(layer):
    """The rendered data of a result layer, without the size-1 axes that place a plane."""
    record = layer.metadata[METADATA_KEY]
    data = np.asarray(layer.data)
    if record["source_index"] is not None:
        extra = 0 if record["mode"] == "single" else 1
        data = data.reshape(data.shape[:extra] + data.shape[extra + len(record["source_index"]) :])
    return data
