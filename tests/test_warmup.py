"""The warm-up process that fills numba's cache outside the viewer's process."""

import subprocess
import sys

from napari_labyrinth import _warmup


def test_the_warm_up_runs_as_a_module_and_exits_cleanly():
    done = subprocess.run(
        [sys.executable, "-m", "napari_labyrinth._warmup"],
        capture_output=True,
        text=True,
        timeout=600,
        check=False,
    )
    assert done.returncode == 0, done.stderr


def test_it_starts_once_per_session_and_not_when_disabled(monkeypatch):
    started = []
    monkeypatch.setattr(_warmup.subprocess, "Popen", lambda *a, **k: started.append(a))
    monkeypatch.setattr(_warmup, "_started", False)
    monkeypatch.setenv(_warmup.DISABLE_VARIABLE, "1")
    _warmup.start_in_background()
    assert started == []
    monkeypatch.delenv(_warmup.DISABLE_VARIABLE)
    _warmup.start_in_background()
    _warmup.start_in_background()
    assert len(started) == 1 and started[0][0][1:] == ["-m", "napari_labyrinth._warmup"]
