"""What a widget run will do: no napari, no Qt.

The napari widget (:mod:`napari_labyrinth._qt`) takes two plain snapshots on
the main thread when Run is pressed: the input layer and the user's choices
(:mod:`napari_labyrinth.widget.choices`). :func:`make_plan` turns them into
a :class:`RenderPlan`: one run of :func:`~napari_labyrinth.labyrinth_steps`
in a mode, which planes it renders, its tone limits and plane offset, the
progress total, and the result layer's name, transforms, contrast settings
and metadata record, from which the API call it names
(:func:`~napari_labyrinth.labyrinth`, :func:`~napari_labyrinth.labyrinth_stack`
or :func:`~napari_labyrinth.labyrinth_sweep`) reproduces the result exactly.
:mod:`napari_labyrinth.widget.run` carries a plan out.
"""

from __future__ import annotations

import dataclasses
import threading
from collections.abc import Callable, Mapping, Sequence
from typing import Any

from ..api import MODES
from ..core.colour import resolve_colour
from ..core.parameters import SWEEPABLE, LabyrinthParameters
from ..core.planes import first_plane_index, step_count
from ..core.presets import resolve_parameters, resolve_sweep
from ..io.bands import array_plane_bands
from ..lazy import is_in_memory
from ..provenance import FUNCTIONS, call_arguments, input_record, rendering_record
from .choices import CURRENT_PLANE, Choices, LayerSnapshot
from .layer_kwargs import METADATA_KEY, result_layer_kwargs
from .multiscale import level_snapshot, shown_level, shown_part
from .streamed_level import band_count, streams
from .text import parse_sweep_values, plane_label, result_description, result_name, tone_limits

__all__ = ["MODES", "Cancelled", "RenderPlan", "make_plan", "run_steps"]


class Cancelled(Exception):
    """Raised in a run when its plan asks it to stop (:meth:`RenderPlan.should_stop`)."""


def run_steps(
    shape: tuple[int, ...],
    rgb: bool,
    passes_per_run: Sequence[int],
    stack_passes: int = 0,
    colour: str | None = None,
) -> int:
    """Number of yields of a run of data of ``shape`` (the progress bar's total).

    One per plane and pass of every run (colour: per channel, alpha not
    rendered), one per pass whose metrics a stack computes, and one for
    assembling the result.
    """
    return step_count(shape, -1 if rgb else None, passes_per_run, colour) + stack_passes + 1


@dataclasses.dataclass
class RenderPlan:
    """Everything a run needs, captured on the main thread when Run is pressed.

    The run reads only this (arrays and plain values), never the viewer.

    Attributes
    ----------
    mode : {"single", "stack", "sweep"}
    function : str
        Name of the API function called.
    arguments : dict
        Its keyword arguments (every parameter, seed, tone limits, ...).
    data : array_like
        What the run renders: the whole layer data, or one plane of it
        (then ``arguments`` holds its ``plane_offset``).
    source_index : tuple of int or None
        Index of that plane in the layer data, None for the whole data.
    visible_index : tuple of int
        Index of the plane the viewer shows (for the metrics table).
    lazy_source : array_like or None
        Lazy layer data of which the rest of the result stays lazy.
    rgb : bool
        Whether the data holds colour channels on its last axis.
    total_steps : int
        Number of yields of the run (the progress bar's total).
    metrics : bool
        Whether a stack run measures every pass on the plane on screen.
    levels : int
        Levels of the result: 1, or those of a multiscale input, the lower ones
        made from the rendered full level (:func:`.multiscale.lower_levels`).
    layer_kwargs : dict
        Keyword arguments of the result layer (name, transforms, contrast, metadata).
    streamed : LabyrinthParameters or None
        The parameters of a run that renders a multiscale layer's full level band
        by band into a pyramid on disk (:mod:`.streamed_level`); None for a run in
        memory.
    """

    mode: str
    function: str
    arguments: dict[str, Any]
    data: Any
    source_index: tuple[int, ...] | None
    visible_index: tuple[int, ...]
    lazy_source: Any
    rgb: bool
    total_steps: int
    layer_kwargs: dict[str, Any]
    metrics: bool = False
    levels: int = 1
    streamed: LabyrinthParameters | None = None
    cancel: threading.Event = dataclasses.field(default_factory=threading.Event)
    abort_requested: Callable[[], bool] = lambda: False

    @property
    def name(self) -> str:
        """Name of the result layer."""
        return self.layer_kwargs["name"]

    @property
    def source_region(self) -> list[list[int]] | None:
        """The rows and columns of the level a multiscale preview renders (the part on
        screen), None for the whole level or layer."""
        return self.layer_kwargs["metadata"][METADATA_KEY].get("source_region")

    @property
    def description(self) -> str:
        """What the result holds, in one line (its metadata record's ``description``)."""
        return self.layer_kwargs["metadata"][METADATA_KEY]["description"]

    @property
    def source(self) -> str:
        """Name of the input layer."""
        return self.layer_kwargs["metadata"][METADATA_KEY]["source_layer"]

    def should_stop(self) -> bool:
        """Whether the user (or napari's activity panel) asked the run to stop."""
        return self.cancel.is_set() or self.abort_requested()


def make_plan(snapshot: LayerSnapshot | None, choices: Choices) -> RenderPlan:
    """What a run with ``choices`` on the layer ``snapshot`` will do.

    A multiscale layer renders as a plain layer of one of its levels: a
    preview the part on screen of the level on screen, a run the full level,
    whose result gets as many levels as the input (:mod:`.multiscale`).

    Raises
    ------
    ValueError, TypeError
        With a message for the user when a choice is invalid (no layer, bad
        tone limits, sweep values or parameters).
    """
    _check_input(snapshot, choices.mode)
    multiscale, levels = snapshot.multiscale, 1
    if multiscale:
        level = shown_level(snapshot) if choices.preview else 0
        levels = 1 if choices.preview else len(snapshot.data)
        snapshot = level_snapshot(snapshot, level)
    region = None
    if multiscale and choices.preview:  # the part of the level on screen
        part = shown_part(snapshot)
        region = None if part is snapshot else [list(bounds) for bounds in part.shown_region]
        snapshot = part
    mode, preset, edits = choices.mode, choices.preset, dict(choices.overrides)
    resolved = resolve_parameters(preset, **edits)
    seed = SWEEPABLE["seed"].validate(choices.seed)  # 2.7 was truncated to 2
    typed = choices.tone_limits
    limits = tone_limits(snapshot.contrast_limits if typed is None else None, typed)
    channel_axis = -1 if snapshot.rgb else None
    colour = resolve_colour(choices.colour, snapshot.data.shape, -1) if snapshot.rgb else None
    sweep = None
    if mode == "sweep":
        sweep = _sweep(preset, edits, choices.sweep_parameter, choices.sweep_text)
    arguments = call_arguments(
        preset=preset,
        parameters=resolved.as_dict(),
        seed=seed,
        tone_limits=limits,
        channel_axis=channel_axis,
        colour=colour,
        sweep=sweep,
    )

    # "current plane", and lazy data: the run renders the plane on screen only;
    # the rest of a lazy result stays lazy (napari renders a plane when it shows it)
    source, n_leading = snapshot.data, snapshot.ndim - 2
    visible_index = tuple(snapshot.visible_index)
    partial = choices.planes == CURRENT_PLANE and n_leading > 0
    lazy = not is_in_memory(source) and n_leading > 0 and not partial
    source_index = visible_index if partial or lazy else None
    if source_index is not None:
        arguments["plane_offset"] = first_plane_index(source.shape, source_index, channel_axis)
    passes_per_run = [resolved.passes]
    if sweep:  # one run per value
        passes_per_run = sweep[1] if sweep[0] == "passes" else passes_per_run * len(sweep[1])
    stack_passes = resolved.passes if mode == "stack" and choices.metrics else 0
    rendered_shape = source.shape[0 if source_index is None else len(source_index) :]
    total = run_steps(rendered_shape, snapshot.rgb, passes_per_run, stack_passes, colour)
    total += levels - 1  # one step per lower level of a multiscale result
    streamed = None
    if multiscale and streams(mode, bool(snapshot.rgb), snapshot.ndim, levels, resolved):
        streamed = resolved
        total = band_count(array_plane_bands(source, snapshot.name), resolved, levels)

    label = plane_label(snapshot.axis_labels, visible_index) if partial else ""
    name = result_name(snapshot.name, mode, sweep[0] if sweep else "", label)
    # the record renders what the result shows: one plane, or the whole data
    recorded = arguments if partial else _without(arguments, "plane_offset")
    record = rendering_record(
        mode,
        recorded,
        source=input_record(snapshot.name, source.shape, source.dtype),
        overrides=edits,
        seed=seed,
    )
    record.update(
        description=result_description(
            snapshot.name, mode, resolved.passes, preset, edits, seed, sweep, label
        ),
        source_layer=snapshot.name,
        source_shape=list(source.shape),
        source_dtype=str(source.dtype),
        source_index=list(source_index) if partial else None,
        lazy=lazy,
    )
    if multiscale:
        record.update(source_level=level, levels=levels, band_by_band=streamed is not None)
        if region is not None:  # a preview of the rows and columns on screen
            record["source_region"] = region
    extra_axis = {"stack": "pass", "sweep": sweep[0] if sweep else None}.get(mode)
    layer_kwargs = result_layer_kwargs(
        snapshot, name, extra_axis, visible_index if partial else None
    )
    layer_kwargs["metadata"] = {METADATA_KEY: record}
    return RenderPlan(
        mode=mode,
        function=FUNCTIONS[mode],
        arguments=arguments,
        data=source if source_index is None else source[source_index],
        source_index=source_index,
        visible_index=visible_index,
        lazy_source=source if lazy else None,
        rgb=bool(snapshot.rgb),
        total_steps=total,
        metrics=mode == "stack" and choices.metrics,
        levels=levels,
        streamed=streamed,
        layer_kwargs=layer_kwargs,
    )


def _check_input(snapshot: LayerSnapshot | None, mode: str) -> None:
    """Raise for what no run can render: no layer, an unknown mode."""
    if snapshot is None:
        raise ValueError("choose an image layer to render (add one, or open a sample)")
    if mode not in MODES:
        raise ValueError(f"mode must be one of {', '.join(MODES)}, got {mode!r}")


def _sweep(
    preset: str, edits: Mapping[str, Any], parameter: str, text: str
) -> tuple[str, list[Any]]:
    """The swept parameter and its values, each checked now rather than in the run."""
    values = parse_sweep_values(parameter, text)
    others = {name: value for name, value in edits.items() if name != parameter}
    resolve_sweep(preset, others, None, parameter, values)  # the swept field's value is replaced
    return parameter, list(values)


def _without(arguments: Mapping[str, Any], key: str) -> dict[str, Any]:
    """``arguments`` without ``key``."""
    return {name: value for name, value in arguments.items() if name != key}
