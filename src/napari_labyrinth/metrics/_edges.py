"""How the texture a rendering adds follows the edges of its input."""

from __future__ import annotations

import math

from ._lazy_kernels import _numba_kernels
from ._maps import _Maps
from ._planes import _kernel_plane, _plane, _same_shape


def edge_enhancement(original, rendered) -> float:
    """Correlation of the texture a rendering adds with the edges of the input.

    Pearson correlation between the fine-scale energy added locally,
    ``G_2 * h_rendered**2 - G_2 * h_original**2``, and the Sobel gradient
    magnitude of the input. Near 1 when the rendering draws texture on the
    input's edges (the edge-detector look of the paper's Fig. 4), near 0 when
    it adds texture everywhere alike (noise), negative when it removes
    texture from the edges (blur), 0 when nothing changed.
    """
    before = _plane(original, "original")
    after = _plane(rendered, "rendered")
    _same_shape(before, after)
    original_maps = _Maps(_kernel_plane(before), walls=False)  # the energy with the edges
    return _edge_enhancement(original_maps, _Maps(_kernel_plane(after)))


def _edge_enhancement(before: _Maps, after: _Maps) -> float:
    # the energies first: their passes give the sums behind ``finite`` (no ``h`` kept)
    energy_after, total_after = after.energy()
    energy_before, total_before = before.energy()
    if not (after.finite and before.finite):
        return math.nan  # NaN or infinity in either image: so is the correlation
    edges, edges_mean, edges_constant = before.edges()
    added_mean = (total_after - total_before) / edges.size
    sums = after._row_sums(5)
    after._bands(
        _numba_kernels().edge_sums,
        energy_after,
        energy_before,
        edges,
        added_mean,
        edges_mean,
        sums,
    )
    cross = math.fsum(sums[:, 0])
    spread = math.fsum(sums[:, 1])
    edges_spread = math.fsum(sums[:, 4])
    added_constant = bool(sums[:, 2].min() == sums[:, 3].max())
    if added_constant or edges_constant:
        return 0.0
    correlation = cross / math.sqrt(spread * edges_spread)
    return min(1.0, max(-1.0, correlation)) if not math.isnan(correlation) else math.nan
