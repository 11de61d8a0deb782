"""The run engine: drives the numba kernel over planes, passes and threads.

- ``render_loop``: :func:`render`, the generator over every pass of every
  plane (closing it cancels the run), and :class:`Progress`, its events;
- ``passes``: :func:`run_pass`, one pass over a plane of tones (the kernel's
  variant, its arguments, its threads), and ``banded_pass`` over an integer plane;
- ``tiles``: the exact-order parallelogram tiles of a raster pass on threads;
- ``cores``: :func:`idle_cores`, the threads the tiles may take;
- ``changes``: the pixels a pass writes, and their write-back as values;
- ``counts``: the diagnostics, per pass and plane and per thread.

The engine knows arrays, layouts and tone scales; argument checking and
presets belong to the API.
"""

from .changes import listed_changes, new_changes, write_changes
from .cores import idle_cores
from .counts import DIAGNOSTICS_DTYPE, padded_counts
from .passes import run_pass
from .render_loop import Progress, render, run_to_end
from .tiles import MIN_PARALLEL_PIXELS, default_tile, exact_order_refusal, exact_order_tiles

__all__ = [
    "DIAGNOSTICS_DTYPE",
    "MIN_PARALLEL_PIXELS",
    "Progress",
    "default_tile",
    "exact_order_refusal",
    "exact_order_tiles",
    "idle_cores",
    "listed_changes",
    "new_changes",
    "padded_counts",
    "render",
    "run_pass",
    "run_to_end",
    "write_changes",
]
