"""The warm-up process that fills numba's cache outside the viewer's process."""

import subprocess

import pytest

from napari_labyrinth import _warmup


@pytest.mark.subprocess
def test_the_warm_up_runs_as_a_module_says_its_steps_and_exits_cleanly():
    done = subprocess.run(
        _warmup.command("--dtype", "uint8"),
        capture_output=True,
        text=True,
        timeout=600,
        check=False,
    )
    assert done.returncode == 0, done.stderr
    lines = done.stdout.splitlines()
    assert [line for line in lines if line.startswith("step ")] == [
        "step 1 of 2: the render of uint8 images",
        "step 2 of 2: the metrics of a stack",
    ]
    assert lines[-1] == "done"


@pytest.mark.parametrize("dtype", ["uint8", "uint16", "float32"])
def test_its_steps_render_and_measure_an_image_of_the_dtype(dtype):
    steps = _warmup.warm_up_steps(dtype)
    for _, step in steps:
        step()


def test_it_is_disabled_by_its_variable(monkeypatch):
    monkeypatch.delenv(_warmup.DISABLE_VARIABLE, raising=False)
    assert not _warmup.disabled()
    monkeypatch.setenv(_warmup.DISABLE_VARIABLE, "1")
    assert _warmup.disabled()


@pytest.mark.parametrize(("refused", "needed"), [(None, False), ("this install carries none", True)])
def test_a_warm_up_is_needed_only_where_the_shipped_kernels_do_not_load(
    monkeypatch, refused, needed
):
    from napari_labyrinth.core._shipped import Shipped

    monkeypatch.setattr(_warmup, "shipped", lambda: Shipped(None, None, refused))
    assert _warmup.needed() is needed
