"""The widget's run: render a plan, yield progress, compute the metrics; no napari, no Qt.

:func:`render` is a generator that drives
:func:`~napari_labyrinth.labyrinth_steps`, yields after every pass of every
plane (napari draws a determinate progress bar from its yields), computes the
per-pass metrics of a stack (:mod:`~napari_labyrinth.widget.pass_metrics`), and returns an :class:`Outcome`, a
:class:`Failure` with a message for the user, or None when cancelled. It
reads only the plan, never the viewer, so it runs in a worker thread, or
directly in a script or a test. Cancelling: ``plan.cancel`` (or napari's
abort) stops it at the next pass, and closing it stops the API's threads at
once. :func:`result_layer` turns the outcome into the data and keyword
arguments of the result layer.

A multiscale layer's full level is rendered band by band into a pyramid on
disk (:mod:`~napari_labyrinth.widget.streamed_level`), in bounded memory,
when its parameters allow.

Lazy (dask-backed) input layers: only the plane the viewer shows is loaded
and rendered by the run; it goes to a store on disk with room for the other
planes, which render in the background afterwards (the outcome's
:class:`~napari_labyrinth.widget.lazy_result.LazyResult`), never on napari's
main thread.
"""

from __future__ import annotations

import dataclasses
import time
from collections.abc import Generator
from typing import Any

import numpy as np

from .. import api
from .layer_kwargs import METADATA_KEY
from .lazy_result import LazyResult
from .multiscale import lower_levels
from .pass_metrics import PassMetrics
from .plan import Cancelled, RenderPlan
from .pyramid_store import PyramidStore
from .streamed_level import render_level

__all__ = [
    "Failure",
    "Outcome",
    "diagnostics_record",
    "render",
    "result_layer",
]


@dataclasses.dataclass
class Failure:
    """A run that failed: the message for the user."""

    message: str


@dataclasses.dataclass
class Outcome:
    """What a finished run hands back to the main thread.

    ``background``: for a lazy input, the result whose other planes are still to
    render (``data`` is its store's array). ``store``: for a multiscale layer's
    full level rendered band by band, the store on disk its levels are (``data``,
    its arrays), to keep while the layer shows them.
    """

    data: Any
    diagnostics: Any
    metric_rows: list[dict[str, float]]
    seconds: float
    background: LazyResult | None = None
    store: PyramidStore | None = None


def _api_steps(
    plan: RenderPlan, data: Any, measure: PassMetrics | None = None
) -> Generator[int, None, tuple[Any, Any]]:
    """Drive :func:`~napari_labyrinth.labyrinth_steps`; yield after every pass of every plane.

    With ``measure``, the passes of the plane on screen are measured as they
    render (one more yield per pass). Returns (as the generator's value) the
    result and its diagnostics. Stops at the next pass, or between two
    metrics, once the plan asks to (raising :class:`~.plan.Cancelled`); the API's
    run is closed on the way out, whatever the way, so no thread of it goes
    on after this generator ends or is closed.
    """
    if plan.should_stop():
        raise Cancelled
    steps = api.labyrinth_steps(data, plan.mode, **plan.arguments)
    done = 0
    try:
        for event in steps:
            if isinstance(event, api.Result):
                return event.image, event.diagnostics
            if plan.should_stop():
                raise Cancelled
            done += 1
            yield done
            if measure is not None and measure.ready(event):
                measure.measure(
                    event.partial, event.pass_number, plan.should_stop, event.tone_limits
                )
                done += 1
                yield done
    finally:
        steps.close()
    raise AssertionError("labyrinth_steps ended without a result")  # pragma: no cover


def render(plan: RenderPlan) -> Generator[int, None, Outcome | Failure | None]:
    """The run: render, measure the passes of a stack, yield after each step.

    Returns an :class:`Outcome`, a :class:`Failure` with a message for the
    user, or None when cancelled (``plan.cancel`` set, or ``plan.abort_requested()``).
    """
    try:
        return (yield from _outcome(plan))
    except Cancelled:
        return None
    except (TypeError, ValueError) as exc:  # the API names the parameter at fault
        return Failure(str(exc))
    except MemoryError:
        return Failure("not enough memory: render the current plane only, or a smaller image")
    except Exception as exc:  # noqa: BLE001 - anything else still reaches the user as a message
        return Failure(f"{type(exc).__name__}: {exc}")


def _outcome(plan: RenderPlan) -> Generator[int, None, Outcome | None]:
    """:func:`render`'s steps, raising what goes wrong; a lazy result's store is removed
    when the run does not end with an outcome."""
    started = time.perf_counter()
    if plan.streamed is not None:
        return (yield from _streamed_outcome(plan, started))
    background = None
    try:
        data = np.asarray(plan.data)  # for lazy input: loads one plane only
        measure = PassMetrics(plan, data) if plan.metrics else None
        result, diagnostics = yield from _api_steps(plan, data, measure)
        if plan.should_stop():
            raise Cancelled
        if plan.lazy_source is not None:  # the other planes render in the background
            background = LazyResult(plan, result)
            result = background.data
        if plan.levels > 1:
            result = yield from _pyramid(plan, result)
        yield plan.total_steps
        if plan.should_stop():
            raise Cancelled
    except BaseException:
        if background is not None:
            background.remove()
        raise
    rows = measure.rows if measure is not None else []
    return Outcome(result, diagnostics, rows, time.perf_counter() - started, background)


def _streamed_outcome(plan: RenderPlan, started: float) -> Generator[int, None, Outcome]:
    """:func:`render`'s steps for a multiscale layer's full level rendered band by band."""
    level = yield from render_level(
        plan.data, plan.source, plan.streamed, plan.arguments, plan.levels, plan.should_stop
    )
    if level is None:  # stopped (after the last band too): its store is removed
        raise Cancelled
    seconds = time.perf_counter() - started
    return Outcome(level.store.arrays, level.diagnostics, [], seconds, store=level.store)


def _pyramid(plan: RenderPlan, full: Any) -> Generator[int, None, list[Any]]:
    """The levels of a multiscale result, made from its rendered ``full`` level; a yield
    after each lower level (the last steps of the run but one)."""
    levels = [full]
    for level in lower_levels(full, plan.levels, plan.rgb):
        if plan.should_stop():
            raise Cancelled
        levels.append(level)
        yield plan.total_steps - plan.levels + len(levels) - 1
    return levels


# -- the result layer --------------------------------------------------------------------------


def diagnostics_record(diagnostics: np.ndarray | None) -> dict[str, Any] | None:
    """JSON-friendly form of the API's structured diagnostics array."""
    if diagnostics is None:
        return None
    return {
        "shape": list(diagnostics.shape),
        "counts": {name: diagnostics[name].tolist() for name in diagnostics.dtype.names},
    }


def result_layer(plan: RenderPlan, outcome: Outcome) -> tuple[Any, dict[str, Any]]:
    """Data and keyword arguments of the layer that shows a finished run.

    The metadata record gains the diagnostics (and which planes they count)
    and the per-pass metrics. A single plane rendered alone gets size-1
    leading axes that keep it at its place in the input. A multiscale result's
    data is the list of its levels, full level first (``multiscale=True``).
    """
    kwargs = dict(plan.layer_kwargs)
    record = dict(kwargs["metadata"][METADATA_KEY])
    if plan.mode == "sweep":
        record["diagnostics"] = [diagnostics_record(d) for d in outcome.diagnostics]
    else:
        record["diagnostics"] = diagnostics_record(outcome.diagnostics)
    if plan.source_index is None:
        record["diagnostics_scope"] = "all planes"
    elif plan.lazy_source is not None:
        record["diagnostics_scope"] = "the plane on screen (the others render in the background)"
        record["diagnostics_plane"] = list(plan.visible_index)
    else:
        record["diagnostics_scope"] = "the rendered plane"
    record["metrics"] = outcome.metric_rows
    kwargs["metadata"] = {METADATA_KEY: record}
    data = outcome.data
    if record["source_index"] is not None:
        n_extra = 0 if plan.mode == "single" else 1
        n_index = len(record["source_index"])

        def placed(level):
            return level.reshape(level.shape[:n_extra] + (1,) * n_index + level.shape[n_extra:])

        data = [placed(level) for level in data] if plan.levels > 1 else placed(data)
    if plan.levels > 1:
        kwargs["multiscale"] = True
    return data, kwargs
