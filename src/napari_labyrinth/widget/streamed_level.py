"""A multiscale layer's full level rendered band by band: bounded memory, a pyramid on disk.

A multiscale layer is how large images are held (an OME-Zarr opened by
napari-ome-zarr: its levels dask arrays of the file's chunks), and its full
level may not fit in memory. Run on a 2-D grey multiscale layer renders the
full level as the command line renders a plane larger than memory
(:func:`napari_labyrinth.streaming.plane_stream`): read band of rows by band
of rows from the layer's array, every pass in one sweep of the bands, each
band of the result written to a :class:`.pyramid_store.PyramidStore` on disk,
the full level and its halvings. Memory holds a few bands whatever the
level's size; the full level is :func:`napari_labyrinth.labyrinth`'s
rendering of it in memory, and the lower levels
:func:`.multiscale.lower_levels`' of that, bit for bit.

The parameters that need the whole plane at once (``border="wrap"``,
``scan="checkerboard"``; Auto V is a number once planned: its button sets it), colour layers, and a stack's or
a sweep's renderings render the full level in memory, as before.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable, Generator
from typing import Any

import numpy as np

from .._engine.stream import streaming_refusal
from .._inputs import validate_workers
from ..core.parameters import LabyrinthParameters
from ..io.bands import PlaneBands, array_plane_bands
from ..streaming import plane_stream, written_rows
from .pyramid_store import PyramidStore

__all__ = ["StreamedLevel", "band_count", "band_rows", "render_level", "streams"]


def streams(
    mode: str, rgb: bool, ndim: int, levels: int, parameters: LabyrinthParameters
) -> bool:
    """Whether a run renders a multiscale layer's full level band by band: one 2-D grey
    plane rendered once (mode ``"single"``) into ``levels`` levels, with ``parameters``
    that do not need the whole plane at once."""
    return (
        mode == "single"
        and not rgb
        and ndim == 2
        and levels > 1
        and streaming_refusal(parameters) is None
    )


def band_rows(plane: PlaneBands, parameters: LabyrinthParameters, levels: int) -> int:
    """Rows of the bands the result is written in: a multiple of ``2 ** (levels - 1)``, so
    that each band halves on its own into every lower level. Raises ``ImageFileError``
    if the layer's chunks hold more rows than the run's memory allows."""
    return written_rows(plane, parameters.passes, 2 ** (levels - 1))


@dataclasses.dataclass
class StreamedLevel:
    """A full level rendered band by band.

    Attributes
    ----------
    store : PyramidStore
        The result's levels on disk (``store.arrays``, full level first).
    diagnostics : structured ndarray, shape (passes,)
        The counts of each pass, as :func:`napari_labyrinth.labyrinth` returns them.
    noise_sigma : float
        The level's noise in tones, which the noise gate took; 0 with the gate off.
    """

    store: PyramidStore
    diagnostics: np.ndarray
    noise_sigma: float


def render_level(
    data: Any,
    name: str,
    parameters: LabyrinthParameters,
    arguments: dict[str, Any],
    levels: int,
    should_stop: Callable[[], bool],
) -> Generator[int, None, StreamedLevel | None]:
    """Render the full level ``data`` of the layer ``name`` into ``levels`` levels on disk,
    band by band; yield after each band written (:func:`band_count` in all).

    ``parameters`` are those :func:`streams` allows; ``arguments`` a run's
    (``seed``, ``tone_limits``, ``workers``). Returns None, the store removed,
    once ``should_stop()`` says so (checked after each band); the store is
    removed too if the rendering fails.
    """
    plane = array_plane_bands(data, name)  # by bands of its chunks' rows
    stream = plane_stream(
        plane,
        parameters,
        arguments["seed"],
        tone_limits=arguments["tone_limits"],
        workers=validate_workers(arguments.get("workers")),
        row_multiple=2 ** (levels - 1),
    )
    if should_stop():
        return None
    store = PyramidStore(plane.shape, plane.dtype, levels, stream.rows)
    try:
        for step, (start, band) in enumerate(stream.bands, 1):
            store.write(start, band)
            if should_stop():
                store.remove()
                return None
            yield step
    except BaseException:
        store.remove()
        raise
    return StreamedLevel(store, stream.diagnostics, stream.noise_sigma)


def band_count(plane: PlaneBands, parameters: LabyrinthParameters, levels: int) -> int:
    """Bands the result is written in (the steps of :func:`render_level`)."""
    return -(-plane.shape[0] // band_rows(plane, parameters, levels))
