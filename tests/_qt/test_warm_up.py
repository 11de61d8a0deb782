"""The warm-up process as the widget drives it: a run waits for it, a closed viewer ends it."""

from __future__ import annotations

import os
import sys

import pytest

pytest.importorskip("napari")
pytest.importorskip("pytestqt")

from napari_labyrinth import _warmup
from napari_labyrinth._qt import warm_up as warm_up_module
from napari_labyrinth._qt.warm_up import PREPARING, WarmUp

from .helpers import RUN_TIMEOUT_MS, noise

#: A stand-in for the warm-up: each of its two steps lasts until its file appears.
_SLOW_WARM_UP = """
import os, sys, time
def wait(path):
    while not os.path.exists(path):
        time.sleep(0.05)
print("step 1 of 2: the render of uint8 images", flush=True)
print("kernel labyrinth_pass", flush=True)
wait(sys.argv[1] + "1")
print("step 2 of 2: the metrics of a stack", flush=True)
wait(sys.argv[1] + "2")
print("done", flush=True)
"""


@pytest.fixture
def slow_warm_up(monkeypatch, tmp_path):
    """The widget's warm-up replaced by one whose step K ends once ``release(K)`` is called
    (``release()``: both)."""
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
    # kernels to compile, as in an install without shipped ones (an install from source)
    monkeypatch.setattr(_warmup, "needed", lambda: True)
    def release(*steps):
        for step in steps or (1, 2):
            (tmp_path / f"release{step}").write_text("")

    return commands, release

#: A stand-in whose lines each arrive in two writes: the text, then its end of line.
_SPLIT_WARM_UP = """
import os, sys, time
def say(line):
    for part in (line, "\\n"):
        sys.stdout.write(part)
        sys.stdout.flush()
        time.sleep(0.2)
say("step 1 of 2: the render of uint8 images")
say("kernel stream_key")
while not os.path.exists(sys.argv[1]):
    time.sleep(0.05)
say("step 2 of 2: the metrics of a stack")
say("done")
"""


def _open_widget(viewer):
    _, widget = viewer.window.add_plugin_dock_widget("napari-labyrinth", "Labyrinthine tiling")
    return widget


@pytest.mark.subprocess
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


@pytest.mark.subprocess
def test_a_run_waits_only_for_the_steps_it_needs(qtbot, viewer, slow_warm_up):
    _, release = slow_warm_up
    viewer.add_image(noise((64, 64)), name="cells")
    widget = _open_widget(viewer)
    qtbot.waitUntil(lambda: widget.warm_up.step != "", timeout=10_000)
    widget.mode.value = "stack"
    assert widget.run() is not None
    release(1)  # the render's kernels: a stack with metrics needs the metrics' too

    def waits_for_step_2():  # an assertion: a timeout shows what the widget said instead
        assert "step 2 of 2" in widget.status.value, (widget.status.value, widget.warm_up.step)

    qtbot.waitUntil(waits_for_step_2, timeout=10_000)
    qtbot.wait(200)
    assert widget._waiting is not None and len(viewer.layers) == 1
    release(2)
    qtbot.waitUntil(lambda: widget.worker is None, timeout=RUN_TIMEOUT_MS)
    assert len(viewer.layers) == 2
    widget.mode.value = "single"
    widget.run()  # the warm-up has ended: at once
    assert widget._waiting is None
    # the run ends before the test: a worker still rendering holds the viewer at its close
    qtbot.waitUntil(lambda: widget.worker is None, timeout=RUN_TIMEOUT_MS)


@pytest.mark.subprocess
def test_a_single_run_starts_once_the_render_is_prepared(qtbot, viewer, slow_warm_up):
    _, release = slow_warm_up
    viewer.add_image(noise((64, 64)), name="cells")
    widget = _open_widget(viewer)
    assert widget.run() is not None
    release(1)  # the metrics, still compiling in the warm-up, are not this run's
    qtbot.waitUntil(lambda: widget.worker is None, timeout=RUN_TIMEOUT_MS)
    assert len(viewer.layers) == 2 and widget.warm_up.running
    release(2)


@pytest.mark.subprocess
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


@pytest.mark.subprocess
def test_the_warm_up_ends_with_the_viewer(qtbot, make_napari_viewer, slow_warm_up):
    viewer = make_napari_viewer()
    widget = _open_widget(viewer)
    qtbot.waitUntil(lambda: widget.warm_up.running, timeout=10_000)
    pid = widget.warm_up._process.processId()
    viewer.close()
    qtbot.waitUntil(lambda: not _alive(pid), timeout=10_000)


@pytest.mark.subprocess
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


def test_no_warm_up_where_the_shipped_kernels_load(qtbot, viewer, slow_warm_up, monkeypatch):
    commands, release = slow_warm_up
    monkeypatch.setattr(_warmup, "needed", lambda: False)  # as a platform wheel's install
    viewer.add_image(noise((64, 64)), name="cells")
    widget = _open_widget(viewer)
    assert not widget.warm_up.running
    assert commands == []
    assert widget.run() is not None  # runs at once: nothing to wait for
    qtbot.waitUntil(lambda: widget.worker is None, timeout=RUN_TIMEOUT_MS)
    assert len(viewer.layers) == 2


def test_the_reader_handles_whole_lines_however_the_reads_split_them(qtbot):
    lines, ends = [], []
    warm_up = WarmUp(lines.append, lambda: ends.append(True))
    for chunk in (b"step 1 of 2: the ren", b"der of uint8 images\n", b"kernel stream_key",
                  b"\n", b"\n", b"kernel \xc3", b"\xa9t\xc3\xa9\r\n", b"done"):
        warm_up.feed(chunk)
    assert lines == ["step 1 of 2: the render of uint8 images", "kernel stream_key",
                     "kernel \u00e9t\u00e9"]
    assert warm_up.step == "step 1 of 2, the render of uint8 images"
    assert warm_up.steps_done == 0
    warm_up.feed(b"", end=True)  # the process ended: what it printed last is a line too
    assert lines[-1] == "done"
    warm_up.feed(b"", end=True)
    assert lines.count("done") == 1


@pytest.mark.subprocess
def test_the_status_names_the_kernel_when_the_lines_arrive_split(
    qtbot, viewer, slow_warm_up, tmp_path
):
    commands, release = slow_warm_up
    (tmp_path / "warm_up.py").write_text(_SPLIT_WARM_UP)
    viewer.add_image(noise((64, 64)), name="cells")
    widget = _open_widget(viewer)
    assert widget.run() is not None
    seen = []

    def names_the_kernel():
        seen.append(widget.status.value)
        assert "compiling stream_key" in widget.status.value, seen

    qtbot.waitUntil(names_the_kernel, timeout=10_000)
    qtbot.wait(500)  # the end of the kernel's line has arrived: the status still names it
    assert widget.status.value == (
        f"{PREPARING} (step 1 of 2, the render of uint8 images: compiling stream_key) …"
    )
    assert not any("()" in status or "( " in status for status in seen)
    (tmp_path / "release").write_text("")
    qtbot.waitUntil(lambda: widget.worker is None, timeout=RUN_TIMEOUT_MS)
    assert len(viewer.layers) == 2


def _alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    with open(f"/proc/{pid}/stat") as stat:  # a zombie has ended
        return stat.read().split()[2] != "Z"
