"""A new result layer is shown over several turns of the event loop, and going away
between two of them adds nothing."""

from __future__ import annotations

import numpy as np
import pytest

pytest.importorskip("napari")
pytest.importorskip("pytestqt")

from napari_labyrinth._qt.worker import main_window
from napari_labyrinth.widget.layer_kwargs import METADATA_KEY

from .helpers import RUN_TIMEOUT_MS, noise, reproduce, run

#: The steps of a new layer, as ``show_result`` yields them.
NEW_LAYER_STEPS = ["built", "inserted", "selected", "shown"]


def _steps_until(step: str) -> list[str]:
    return NEW_LAYER_STEPS[: NEW_LAYER_STEPS.index(step) + 1]


@pytest.fixture
def watched_steps(monkeypatch):
    """Every step the widget runs of ``show_result``, with the state of the viewer after it:
    (step, turned, result in the viewer, visible, active, the window repaints). ``turned``:
    whether the event loop ran a zero-delay timer between the previous step and this one
    (it is started at the end of each step), i.e. the step had a turn of its own."""
    from qtpy.QtCore import QTimer

    import napari_labyrinth._qt.widget as widget_module

    show_result = widget_module.show_result
    seen: list[tuple] = []
    actions: dict[str, object] = {}

    def watched(viewer, plan, outcome, previous=None, **options):
        window = options.get("window")
        steps = show_result(viewer, plan, outcome, previous, **options)
        turned = [True]
        try:
            while True:
                step = next(steps)
                name = plan.layer_kwargs["name"]  # (the widget's viewer is napari's proxy:
                layers = [layer for layer in viewer.layers if layer.name == name]  # not `is`)
                active = viewer.layers.selection.active
                seen.append(
                    (
                        step,
                        turned[0],
                        bool(layers),
                        bool(layers) and layers[0].visible,
                        active is not None and active.name == name,
                        window is not None and window.updatesEnabled(),
                    )
                )
                turned[0] = False
                QTimer.singleShot(0, lambda: turned.__setitem__(0, True))
                if step in actions:
                    actions.pop(step)()
                yield step
        except StopIteration as done:
            return done.value
        finally:
            steps.close()

    monkeypatch.setattr(widget_module, "show_result", watched)
    return seen, actions


def test_a_new_result_is_shown_step_by_step_each_in_a_turn_of_its_own(
    qtbot, viewer, widget, watched_steps
):
    seen, _ = watched_steps
    source = viewer.add_image(noise((48, 64)), name="cell")
    widget.replace.value = False
    run(qtbot, widget)
    assert [step for step, *_ in seen] == NEW_LAYER_STEPS
    assert all(turned for _, turned, *_ in seen)
    assert [state for _, _, *state in seen] == [
        [False, False, False, True],  # built, not in the viewer
        # inserted hidden (napari selects a layer it inserts); the window not repainted
        # in this turn
        [True, False, True, False],
        [True, False, True, True],  # still hidden; the window repaints again
        [True, True, True, True],  # shown
    ]
    assert main_window(widget) is viewer.window._qt_window
    result = viewer.layers["cell · labyrinth"]
    assert widget.last_result is result and result.visible
    assert viewer.layers.selection.active is result
    assert [layer.name for layer in viewer.layers] == ["cell", "cell · labyrinth"]
    assert result.metadata[METADATA_KEY]["source_layer"] == "cell"
    np.testing.assert_array_equal(result.data, reproduce(result, source.data))
    assert "Added" in widget.status.value and widget.run_button.enabled
    assert widget.worker is None and not widget.progress_bar.isVisible()


def test_a_stack_moves_the_slider_to_its_last_pass_before_it_is_shown(
    qtbot, viewer, widget, watched_steps
):
    viewer.add_image(noise((32, 32)), name="cell")
    widget.mode.value = "stack"
    widget.fields["passes"].value = 3
    run(qtbot, widget)
    result = viewer.layers["cell · stack"]
    assert result.visible and viewer.dims.current_step[0] == 3  # the input and 3 passes
    assert widget.metrics_table.columnCount() == 3


def test_an_update_in_place_is_one_step(qtbot, viewer, widget, watched_steps):
    seen, _ = watched_steps
    viewer.add_image(noise((32, 32)), name="cell")
    run(qtbot, widget)
    first = viewer.layers["cell · labyrinth"]
    seen.clear()
    widget.seed.value = 5
    run(qtbot, widget)
    assert [step for step, *_ in seen] == ["updated in place"]
    assert viewer.layers["cell · labyrinth"] is first and first.visible
    assert first.metadata[METADATA_KEY]["seed"] == 5


def test_a_cancel_or_a_removed_input_between_the_steps_adds_nothing(
    qtbot, viewer, widget, watched_steps
):
    seen, actions = watched_steps
    widget.replace.value = False
    for after in NEW_LAYER_STEPS[:-1]:
        for leave in ("cancel", "remove the input"):
            source = viewer.add_image(noise((32, 32)), name="cell")
            seen.clear()
            if leave == "cancel":
                actions[after] = widget.cancel
            else:
                actions[after] = lambda source=source: viewer.layers.remove(source)
            run(qtbot, widget)
            qtbot.wait(10)
            assert [step for step, *_ in seen] == _steps_until(after)
            assert [layer.name for layer in viewer.layers] == (
                [] if leave == "remove the input" else ["cell"]
            ), (leave, after)
            assert widget.last_result is None
            assert "Cancelled" in widget.status.value and widget.run_button.enabled
            assert viewer.window._qt_window.updatesEnabled()  # repaints again
            viewer.layers.clear()


@pytest.mark.parametrize(
    ("leave", "after"),
    [
        ("close the dock", "built"),
        ("close the dock", "inserted"),
        ("close the dock", "selected"),
        ("close the viewer", "inserted"),
    ],
)
def test_closing_the_dock_or_the_viewer_between_the_steps_adds_nothing(
    qtbot, make_napari_viewer, watched_steps, shown_errors, leave, after
):
    viewer = make_napari_viewer(show=leave == "close the viewer")
    _, widget = viewer.window.add_plugin_dock_widget("napari-labyrinth", "Labyrinthine tiling")
    seen, actions = watched_steps
    viewer.add_image(noise((32, 32)), name="cell")
    widget.replace.value = False
    if leave == "close the dock":
        actions[after] = lambda: viewer.window.remove_dock_widget(widget)
    else:
        actions[after] = viewer.close
    run(qtbot, widget)
    qtbot.wait(50)
    assert widget._closed
    assert [step for step, *_ in seen] == _steps_until(after)
    # a closed viewer has no layers left
    names = [layer.name for layer in viewer.layers]
    assert names == ([] if leave == "close the viewer" else ["cell"])
    assert widget.last_result is None and not shown_errors


def test_a_result_removed_by_the_user_before_it_is_shown_ends_the_steps(
    qtbot, viewer, widget, watched_steps
):
    seen, actions = watched_steps
    viewer.add_image(noise((32, 32)), name="cell")
    widget.replace.value = False
    actions["inserted"] = lambda: viewer.layers.remove("cell · labyrinth")
    run(qtbot, widget)
    assert [step for step, *_ in seen] == ["built", "inserted"]
    assert [layer.name for layer in viewer.layers] == ["cell"]
    assert widget.last_result is None and widget.run_button.enabled
    assert "removed" in widget.status.value
    assert viewer.window._qt_window.updatesEnabled()


def test_a_result_that_replaces_a_layer_of_other_axes_takes_its_place(
    qtbot, viewer, widget, watched_steps
):
    """Replace last, but the new result cannot hold the data of the last one (a stack has
    one more axis): the new layer is inserted above it, and the old one removed last."""
    seen, _ = watched_steps
    viewer.add_image(noise((32, 32)), name="cell")
    viewer.add_image(noise((32, 32), seed=1), name="other")
    widget.image_layer.value = viewer.layers["cell"]
    widget.mode.value = "stack"
    widget.fields["passes"].value = 2
    run(qtbot, widget)
    stack = viewer.layers["cell · stack"]
    viewer.layers.move(viewer.layers.index(stack), 0)
    widget._results[(widget.plan().source, "single")] = stack  # as if the last single run
    widget.mode.value = "single"
    seen.clear()
    run(qtbot, widget)
    assert [step for step, *_ in seen] == [*NEW_LAYER_STEPS, "previous removed"]
    assert stack not in viewer.layers
    assert [layer.name for layer in viewer.layers] == ["cell · labyrinth", "cell", "other"]


def test_a_step_that_fails_is_reported_and_leaves_no_layer(
    qtbot, viewer, widget, shown_errors, monkeypatch
):
    import napari_labyrinth._qt.worker as worker_module

    def fail(*_args):
        raise ValueError("no slider here")

    monkeypatch.setattr(worker_module, "_go_to_last_plane", fail)  # in the "selected" step
    viewer.add_image(noise((32, 32)), name="cell")
    widget.replace.value = False
    run(qtbot, widget)
    assert [layer.name for layer in viewer.layers] == ["cell"]
    assert len(shown_errors) == 1 and "no slider here" in shown_errors[0]
    assert "Failed" in widget.status.value and widget.run_button.enabled
    assert viewer.window._qt_window.updatesEnabled()
