"""What a widget run does, without napari or Qt: the plan, the run, its text and its layer.

The napari widget (:mod:`napari_labyrinth._qt`) only lays out fields and
wires them to this package, which a script or a test drives alike:

- :mod:`~napari_labyrinth.widget.choices`: the input layer and the user's
  choices as plain values (:class:`LayerSnapshot`, :class:`Choices`);
- :mod:`~napari_labyrinth.widget.plan`: what a run will do
  (:func:`make_plan` gives a :class:`RenderPlan`);
- :mod:`~napari_labyrinth.widget.run`: the run, a generator that yields
  progress (:func:`render`), and the result layer it hands back
  (:func:`result_layer`);
- :mod:`~napari_labyrinth.widget.lazy_result`: a lazy input's result, its
  other planes rendered in the background
  (:mod:`~napari_labyrinth.widget.plane_order`: where the user looks first;
  :mod:`~napari_labyrinth.widget.plane_store`: a temporary zarr on disk);
- :mod:`~napari_labyrinth.widget.pass_metrics`: the metrics of a stack's passes;
- :mod:`~napari_labyrinth.widget.text`: text typed and shown (sweep values,
  tone limits, layer names, labels, the metrics table);
- :mod:`~napari_labyrinth.widget.layer_kwargs`: the result layer's transforms
  and display settings.
"""

from .choices import ALL_PLANES, CURRENT_PLANE, Choices, LayerSnapshot
from .layer_kwargs import METADATA_KEY
from .plan import RenderPlan, make_plan
from .run import Failure, Outcome, render, result_layer

__all__ = [
    "ALL_PLANES",
    "CURRENT_PLANE",
    "METADATA_KEY",
    "Choices",
    "Failure",
    "LayerSnapshot",
    "Outcome",
    "RenderPlan",
    "make_plan",
    "render",
    "result_layer",
]
