"""The one thread primitive: a helper started without waiting, and the band runs built on it."""

from __future__ import annotations

import threading

import pytest

from napari_labyrinth import _threads
from napari_labyrinth.metrics import _bands


def test_a_helper_runs_its_work_and_its_lock_says_when_it_is_done():
    started, release = threading.Event(), threading.Event()
    seen = []

    def work(value):
        started.set()
        release.wait(5)
        seen.append(value)

    done = _threads.start_helper(work, 7)
    assert started.wait(5)
    assert not done.acquire(blocking=False)  # still working
    release.set()
    assert done.acquire(timeout=5) and seen == [7]


@pytest.fixture
def no_threads(monkeypatch):
    def refuse(*_):
        raise RuntimeError("can't start new thread")

    monkeypatch.setattr(_threads._thread, "start_new_thread", refuse)


def test_without_a_thread_the_lock_is_free_at_once_and_the_work_never_runs(no_threads):
    seen = []
    done = _threads.start_helper(seen.append, 1)
    assert done.acquire(blocking=False) and seen == []


def test_the_bands_are_all_run_by_the_calling_thread_when_no_thread_can_be_had(no_threads):
    rows = []
    results = _bands._in_bands(lambda y0, y1: rows.append((y0, y1)) or y1 - y0, 1000, 4)
    assert sum(results) == 1000 and sorted(rows) == rows and rows[-1][1] == 1000
