"""The warm-up process as the widget drives it: a run waits for it, a closed viewer ends it."""

from __future__ import annotations

import os
import sys

import pytest

pytest.importorskip("napari")
pytest.importorskip("pytestqt")

from napari_labyrinth import _warmup
from napari_labyrinth._qt import warm_up as warm_up_module
from napari_labyrinth._qt.warm_up import PREPARING

from .helpers import RUN_TIMEOUT_MS, noise

#: A stand-in for the warm-up: says two steps, then waits for its file to appear.
_SLOW_WARM_UP = """
import os, sys, time
print("step 1 of 2: the render of uint8 images", flush=True)
print("kernel labyrinth_pass", flush=True)
while not os.path.exists(sys.argv[1]):
    time.sleep(0.05)
print("done", flush=True)
"""


@pytest.fixture
def slow_warm_up(monkeypatch, tmp_path):
    """The widget's warm-up replaced by one that ends once ``release`` is called."""
    release_file = tmp_path / "release"
    script = tmp_path / "warm_up.py"
    script.write_text(_SLOW_WARM_UP)
    commands = []

    def command(*arguments):
        commands.append(arguments)
        return [sys.executable, str(script), str(release_file)]

    monkeypatch.delenv(_warmup.DISABLE_VARIABLE, raising=False)
    monkeypatch.setattr(_warmup, "command", command)
    monkeypatch.setattr(warm_up_module, "_started", False)
    return commands, lambda: release_file.write_text("")


def _open_widget(viewer):
    _, widget = viewer.window.add_plugin_dock_widget("napari-labyrinth", "Labyrinthine tiling")
    return widget


def test_a_run_waits_for_the_warm_up_and_says_so_then_renders(qtbot, viewer, slow_warm_up):
    commands, release = slow_warm_up
    viewer.add_image(noise((64, 64)), name="cells")
    widget = _open_widget(viewer)
    assert commands == [("--dtype", "uint8")]  # the selected layer's dtype
    qtbot.waitUntil(lambda: widget.warm_up.step != "", timeout=10_000)
    worker = widget.run()
    assert worker is not None
    qtbot.wait(300)
    assert widget.status.value.startswith(PREPARING)
    assert "the render of uint8 images" in widget.status.value
    assert len(viewer.layers) == 1  # nothing rendered beside the warm-up
    release()
    qtbot.waitUntil(lambda: widget.worker is None, timeout=RUN_TIMEOUT_MS)
    assert len(viewer.layers) == 2
    assert widget.status.value.startswith("Added")


def test_cancelling_a_run_that_waits_for_the_warm_up_adds_nothing(qtbot, viewer, slow_warm_up):
    _, release = slow_warm_up
    viewer.add_image(noise((64, 64)), name="cells")
    widget = _open_widget(viewer)
    assert widget.run() is not None
    widget.cancel()
    assert widget.worker is None and widget.run_button.enabled
    assert widget.status.value.startswith("Cancelled")
    release()
    qtbot.waitUntil(lambda: not widget.warm_up.running, timeout=10_000)
    qtbot.wait(100)
    assert len(viewer.layers) == 1


def test_the_warm_up_ends_with_the_viewer(qtbot, make_napari_viewer, slow_warm_up):
    viewer = make_napari_viewer()
    widget = _open_widget(viewer)
    qtbot.waitUntil(lambda: widget.warm_up.running, timeout=10_000)
    pid = widget.warm_up._process.processId()
    viewer.close()
    qtbot.waitUntil(lambda: not _alive(pid), timeout=10_000)


def test_one_warm_up_a_session_and_none_when_disabled(qtbot, viewer, slow_warm_up, monkeypatch):
    commands, release = slow_warm_up
    _open_widget(viewer)
    viewer.window.remove_dock_widget("all")
    _open_widget(viewer)
    assert len(commands) == 1
    release()
    monkeypatch.setattr(warm_up_module, "_started", False)
    monkeypatch.setenv(_warmup.DISABLE_VARIABLE, "1")
    assert not _open_widget(viewer).warm_up.running
    assert len(commands) == 1


def _alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    with open(f"/proc/{pid}/stat") as stat:  # a zombie has ended
        return stat.read().split()[2] != "Z"
