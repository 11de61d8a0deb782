"""Compare: the input and a result side by side (napari's grid mode), and back."""

from __future__ import annotations

import inspect
from typing import Any

from napari.components.grid import GridCanvas
from napari.layers import Image
from napari.utils.notifications import show_info
from napari.viewer import Viewer

from ..widget.layer_kwargs import METADATA_KEY


class CompareView:
    """Switches a viewer between its own view and a 1 x 2 grid of an input and its result.

    The input is on the left, the result on the right, whatever lies between them in the layer
    list: up to napari 0.8 the hidden layers take squares of the grid too, and the stride is
    chosen so that they leave these two apart. Going back restores the grid settings and the
    visibility of every layer.
    """

    def __init__(self, viewer: Viewer) -> None:
        self.viewer = viewer
        self._state: dict[str, Any] | None = None

    @property
    def active(self) -> bool:
        """Whether the compare (grid) view is on."""
        return self._state is not None

    def toggle(self, last_result: Image | None) -> None:
        """Compare the selected result layer (else ``last_result``) with its input, or go back."""
        if self._state is not None:
            self._restore()
            return
        result = self.viewer.layers.selection.active
        if not (isinstance(result, Image) and METADATA_KEY in result.metadata):
            result = last_result
        if result is None or result not in self.viewer.layers:
            show_info("Run the tiling first (or select a result layer) to compare it.")
            return
        source_name = result.metadata[METADATA_KEY]["source_layer"]
        source = next((lay for lay in self.viewer.layers if lay.name == source_name), None)
        if source is None:
            show_info(f"The input layer {source_name!r} is no longer in the viewer.")
            return
        grid = self._grid()
        self._state = {
            "enabled": grid.enabled,
            "shape": tuple(grid.shape),
            "stride": grid.stride,
            "visible": {layer: layer.visible for layer in self.viewer.layers},
        }
        for layer in self.viewer.layers:
            # napari hands plugins proxies of its layers: compare with ==, not `is`
            layer.visible = layer == source or layer == result
        layers = list(self.viewer.layers)
        grid.stride = _side_by_side_stride(layers, layers.index(source), layers.index(result))
        grid.shape = (1, 2)
        grid.enabled = True

    def _restore(self) -> None:
        grid = self._grid()
        state, self._state = self._state, None
        grid.enabled = state["enabled"]
        grid.shape = state["shape"]
        grid.stride = state["stride"]
        for layer, visible in state["visible"].items():
            if layer in self.viewer.layers:
                layer.visible = visible

    def _grid(self):
        return getattr(self.viewer, "canvas", self.viewer).grid


#: The largest stride napari's grid accepts.
_MAX_STRIDE = 50


def _side_by_side_stride(layers: list, left: int, right: int) -> int:
    """The stride of a 1 x 2 grid that shows ``layers[left]`` on the left and ``layers[right]``
    on the right, as this napari lays out the grid (1 if none does)."""
    for size in range(1, min(len(layers), _MAX_STRIDE) + 1):
        for stride in (size, -size):
            trial = GridCanvas(stride=stride, shape=(1, 2), enabled=True)
            if _square(trial, layers, left) == (0, 0) and _square(trial, layers, right) == (0, 1):
                return stride
    return 1


def _square(grid: GridCanvas, layers: list, index: int) -> tuple[int, int]:
    """The (row, column) of the grid where napari draws ``layers[index]``."""
    n = len(layers)
    if not hasattr(grid, "iter_viewboxes"):
        # napari < 0.6.2 places layer i at the grid's position n - 1 - i, hidden layers included
        return tuple(grid.position(n - 1 - index, n))
    if "nlayers" in inspect.signature(grid.position).parameters:
        # napari 0.6.2 to 0.8 (a viewbox per square): layer i at position i, hidden included
        return tuple(grid.position(index, n))
    # napari 0.9: the hidden layers take no square
    return tuple(grid.position(index, layers))
