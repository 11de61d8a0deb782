"""Helpers of the plan and run tests: noise images, a run driven as the worker drives it."""

from __future__ import annotations

import json

import numpy as np

import napari_labyrinth
from napari_labyrinth.widget.layer_kwargs import METADATA_KEY
from napari_labyrinth.widget.run import render


def noise(shape, dtype=np.uint8, seed=0):
    rng = np.random.default_rng(seed)
    if np.dtype(dtype).kind == "f":
        return rng.random(shape).astype(dtype)
    return rng.integers(0, 256, shape).astype(dtype)


def drive(plan, on_step=None):
    """Run the plan's generator to its end as the worker does: (yields, returned value)."""
    steps = []
    run = render(plan)
    while True:
        try:
            step = next(run)
        except StopIteration as stop:
            return steps, stop.value
        steps.append(step)
        if on_step is not None:
            on_step(step)


def reproduce(kwargs, source):
    """Render again through the API from the layer's metadata record (after JSON)."""
    record = json.loads(json.dumps(kwargs["metadata"][METADATA_KEY]))
    if record["source_index"] is not None:
        source = source[tuple(record["source_index"])]
    return np.asarray(getattr(napari_labyrinth, record["function"])(source, **record["arguments"]))


def counting_lazy(data: np.ndarray):
    """``data`` as a dask array of one chunk per plane, and the list of the planes it loads."""
    import dask.array as da

    loaded: list[int] = []

    def count(block, block_info=None):
        loaded.append(block_info[0]["array-location"][0][0])
        return block

    chunks = (1,) + data.shape[1:]
    return da.from_array(data, chunks=chunks).map_blocks(count, dtype=data.dtype), loaded
