"""Full garbage collections held off during runs (``_qt/collector.py``): no viewer needed."""

from __future__ import annotations

import gc

import pytest

from napari_labyrinth._qt import collector
from napari_labyrinth._qt.collector import HELD_THRESHOLD, hold_full_collections, hold_while_running


@pytest.fixture(autouse=True)
def _gc_as_found():
    threshold = gc.get_threshold()
    yield
    gc.set_threshold(*threshold)
    assert collector.holds() == 0, "a test left a hold on"


def test_a_hold_raises_the_oldest_threshold_and_its_release_restores_it():
    gc.set_threshold(700, 10, 10)
    release = hold_full_collections()
    assert gc.get_threshold() == (700, 10, HELD_THRESHOLD)
    release()
    assert gc.get_threshold() == (700, 10, 10)
    release()  # a second call does nothing
    assert gc.get_threshold() == (700, 10, 10)
    assert collector.holds() == 0


def test_holds_nest_and_the_last_release_restores():
    gc.set_threshold(500, 7, 9)
    first, second = hold_full_collections(), hold_full_collections()
    first()
    assert gc.get_threshold() == (500, 7, HELD_THRESHOLD)
    assert collector.holds() == 1
    second()
    assert gc.get_threshold() == (500, 7, 9)


def test_a_threshold_set_by_somebody_else_during_a_hold_is_left_as_they_set_it():
    gc.set_threshold(700, 10, 10)
    release = hold_full_collections()
    gc.set_threshold(1000, 20, 30)
    release()
    assert gc.get_threshold() == (1000, 20, 30)


class _Generations:
    """The generations Python collects by itself while on (``gc.callbacks``)."""

    def __init__(self) -> None:
        self.collected: list[int] = []

    def _callback(self, phase: str, info: dict) -> None:
        if phase == "start":
            self.collected.append(info["generation"])

    def __enter__(self):
        gc.callbacks.append(self._callback)
        return self

    def __exit__(self, *_exc) -> None:
        gc.callbacks.remove(self._callback)


def _allocate_long_lived(count: int = 400_000) -> list:
    """Many small containers kept alive: what pushes Python into full collections."""
    return [[k] for k in range(count)]


@pytest.mark.parametrize("held", [False, True])
def test_no_full_collection_starts_by_itself_while_held_and_younger_ones_go_on(held):
    gc.set_threshold(700, 10, 10)
    gc.collect()
    release = hold_full_collections() if held else (lambda: None)
    try:
        with _Generations() as generations:
            kept = _allocate_long_lived()
    finally:
        release()
    assert len(kept) == 400_000
    assert 0 in generations.collected and 1 in generations.collected
    assert (2 in generations.collected) is not held


class _Signal:
    def __init__(self) -> None:
        self.slots = []

    def connect(self, slot) -> None:
        self.slots.append(slot)

    def emit(self) -> None:
        for slot in self.slots:
            slot()


class _Worker:
    def __init__(self) -> None:
        self.started, self.finished = _Signal(), _Signal()


def test_a_worker_holds_from_its_start_to_its_end():
    gc.set_threshold(700, 10, 10)
    worker = _Worker()
    hold_while_running(worker)
    assert collector.holds() == 0  # not started: nothing held
    worker.started.emit()
    assert gc.get_threshold()[2] == HELD_THRESHOLD
    worker.finished.emit()
    assert gc.get_threshold() == (700, 10, 10)


def test_a_worker_that_never_started_releases_nothing_at_its_end():
    gc.set_threshold(700, 10, 10)
    other = hold_full_collections()
    worker = _Worker()
    hold_while_running(worker)
    worker.finished.emit()
    assert collector.holds() == 1  # the other hold is still on
    other()


def _full_collections() -> int:
    return gc.get_stats()[2]["collections"]


def test_a_full_collection_that_fell_due_during_a_hold_is_made_at_its_release():
    gc.set_threshold(700, 10, 3)
    release = hold_full_collections()
    for _ in range(5):  # five collections of the middle generation: a full one falls due
        gc.collect(1)
    assert collector.full_collection_due() is False  # held: not due by the raised threshold
    before = _full_collections()
    release()
    assert gc.get_threshold() == (700, 10, 3)
    assert _full_collections() == before + 1  # made at the release, not at a later check
    assert gc.get_count()[2] == 0


def test_a_release_makes_no_full_collection_that_is_not_due():
    gc.set_threshold(700, 10, 50)
    gc.collect()
    release = hold_full_collections()
    gc.collect(1)
    before = _full_collections()
    release()
    assert _full_collections() == before
