"""numba kernels behind :mod:`napari_labyrinth.metrics`, by family.

- :mod:`.smoothing`: the fine-scale component ``h``, its energy and the
  Sobel edges in one pass (:func:`fine_scale_band`), and the plane against
  its local mean at the walls (:func:`local_mean_band`);
- :mod:`.walls`: the wall map from 12 lag correlations (:func:`wall_band`);
- :mod:`.tensor`: the structure tensors (:func:`orientation_band`,
  :func:`decimated_tensor_band`) and the counts of a mask's pixels by column
  tile that say where to compute them;
- :mod:`.reductions`: per-row sums of the maps behind each metric;
- :mod:`._rows`: the helpers they share (a plane's rows, sums of a row, a
  Gaussian along a line, scipy's ``reflect``).

Every kernel works on a band of output rows ``[y0, y1)`` of a 2-D plane, so
that the caller can share a plane's rows between threads; every kernel
releases the GIL and allocates its own buffers (no shared mutable state).
Sums are made row by row (the caller adds the rows' sums), so that results
do not depend on the bands.

A plane is given as the tuple of :func:`plane_tuple`: one slot per dtype a
plane may have (uint8, uint16, float32, float64), the plane in its own and
empty arrays in the others. Kernels read its rows through
:func:`._rows._load_row`, which converts them to float64 (exactly), so that
each kernel is compiled once for every dtype, and the results are those of
the plane's float64 copy.

Precision, chosen by what each result feeds:

- The fine-scale component, the local energy, the 12 lag correlations
  behind the wall map and the local mean are float64 and follow
  ``scipy.ndimage.gaussian_filter`` operation for operation (the same 1-D
  passes, axis 0 then axis 1, the same ``reflect`` extension, the same
  order of the taps: centre first, then the outermost pair down to the
  nearest): they are scipy's floats, bit for bit, and the wall map the
  reference's.
- The structure tensors (orientations) are float32: they only feed weighted
  means, where float32 rounding moves the result by about 1e-8. The walls'
  and the contours' tensors are decimated (:func:`decimated_tensor_band`):
  the doubled grid's products filtered 1-2-1 and smoothed on the original
  grid, a window within a few per cent of the doubled grid's Gaussian at a
  quarter of its pixels; :func:`orientation_band` is the doubled grid's.

numba compiles every kernel on its first call (then keeps it in its disk
cache), and the time grows with the code it compiles: each kernel and
helper once per signature, and a helper's code once more in every kernel
or helper that calls it (linked into it, optimized and made into machine
code again). The kernels are therefore few, their helpers called by the
kernels themselves rather than by other helpers where that can be, code
used once written where it is used, one signature per helper (a plane of
any dtype in one tuple; no literal constant passed to a helper, which
would compile it once more for its value), plain loops rather than numpy
calls that bring heavy implementations (an array assigned to a slice
compiles numba's formatting of shape errors), and each call compiles only
the kernels it runs (``docs/metrics.md``, "Compile time"). numba's disk
cache of a kernel is keyed on the kernel's own file, not on its helpers':
after a change to a helper, clear the caches of the kernels that call it.

The metrics reach the kernels through this package (``metrics._lazy_kernels``
imports it on first use, and with it numba).
"""

from ._rows import PLANE_DTYPES, plane_tuple
from .reductions import alignment_sums, edge_sums, wall_pair_counts, wall_weighted_sums
from .smoothing import X_TILE, Y_BLOCK, fine_scale_band, gaussian_weights, local_mean_band
from .tensor import (
    PREFILTER_VARIANCE,
    TENSOR_COMPONENTS,
    TENSOR_DERIVED,
    TENSOR_MIN_TILE,
    TENSOR_RING_BYTES,
    decimated_sigma,
    decimated_tensor_band,
    mask_counts,
    mask_starts,
    orientation_band,
    tensor_tiles,
)
from .walls import FAMILIES, LAG_BLOCK, LAG_DX, LAG_DY, NORMAL_FAMILY, wall_band

__all__ = [
    "FAMILIES",
    "LAG_BLOCK",
    "LAG_DX",
    "LAG_DY",
    "NORMAL_FAMILY",
    "PLANE_DTYPES",
    "PREFILTER_VARIANCE",
    "TENSOR_COMPONENTS",
    "TENSOR_DERIVED",
    "TENSOR_MIN_TILE",
    "TENSOR_RING_BYTES",
    "X_TILE",
    "Y_BLOCK",
    "alignment_sums",
    "decimated_sigma",
    "decimated_tensor_band",
    "edge_sums",
    "fine_scale_band",
    "gaussian_weights",
    "local_mean_band",
    "mask_counts",
    "mask_starts",
    "orientation_band",
    "plane_tuple",
    "tensor_tiles",
    "wall_band",
    "wall_pair_counts",
    "wall_weighted_sums",
]
