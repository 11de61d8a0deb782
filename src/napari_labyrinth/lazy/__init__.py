"""Lazy (dask) images: exact tone limits in bounded memory, lazy renderings, block runs.

What the API and the command line need when an image does not fit in memory:

- ``arrays``: whether an image is lazy (checked without importing dask), and a
  dask image checked before any block of it is read;
- ``streamed_percentiles`` and ``tone_limits``: the tone limits
  :func:`napari_labyrinth.labyrinth` would choose for the whole image, computed
  bit for bit as ``numpy.percentile`` computes them, by streaming over the
  blocks of a dask array;
- ``render``: the rendering of a dask array as a lazy dask array, whole planes
  per block, each plane drawing the random stream of its index in the whole
  array (the API's path for dask input);
- ``blocks``: every block of a dask array computed and handed to a writer,
  with per-plane progress, under the local threaded scheduler or a
  ``dask.distributed`` client;
- ``errors``: what goes wrong while computing blocks, in one line.

dask is an optional dependency, imported on first use: importing this package
does not import it.
"""

from .arrays import checked_lazy, is_in_memory, is_lazy
from .blocks import block_locations, current_client, run_blocks
from .errors import ComputeError, computing
from .render import render_lazy
from .streamed_percentiles import percentiles
from .tone_limits import default_tone_limits, lazy_luminance, rendering_tone_limits

__all__ = [
    "ComputeError",
    "block_locations",
    "checked_lazy",
    "computing",
    "current_client",
    "default_tone_limits",
    "is_in_memory",
    "is_lazy",
    "lazy_luminance",
    "percentiles",
    "render_lazy",
    "rendering_tone_limits",
    "run_blocks",
]
