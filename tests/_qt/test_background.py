"""A run's steps driven in a thread of their own, at a lower priority than the caller's."""

from __future__ import annotations

import os
import sys
import threading

import pytest

from napari_labyrinth._qt.background import NICENESS, StepsInThread, lower_priority

linux_only = pytest.mark.skipif(
    not sys.platform.startswith("linux"), reason="a priority per thread: Linux"
)


def _priority(thread_id: int | None = None) -> int:
    return os.getpriority(os.PRIO_PROCESS, thread_id or threading.get_native_id())


def _drive(steps):
    handed = []
    while True:
        try:
            handed.append(next(steps))
        except StopIteration as done:
            return handed, done.value


def test_steps_and_the_value_are_handed_on_in_order():
    def run():
        yield 1
        yield 2
        return "outcome"

    assert _drive(StepsInThread(run()).steps()) == ([1, 2], "outcome")


def test_an_error_of_the_run_is_raised_in_the_caller():
    def run():
        yield 1
        raise ValueError("passes must be at least 0")

    steps = StepsInThread(run()).steps()
    assert next(steps) == 1
    with pytest.raises(ValueError, match="passes"):
        next(steps)


def test_the_run_is_not_in_the_caller_s_thread():
    where = []

    def run():
        where.append(threading.get_ident())
        yield 0

    _drive(StepsInThread(run()).steps())
    assert where and where[0] != threading.get_ident()


@linux_only
def test_the_run_and_the_threads_it_starts_have_a_lower_priority():
    seen = {}

    def run():
        seen["run"] = _priority()
        helper = threading.Thread(target=lambda: seen.setdefault("helper", _priority()))
        helper.start()
        helper.join()
        yield 0

    caller = _priority()
    assert caller < 19  # else no priority could be lower
    _drive(StepsInThread(run()).steps())
    lower = min(19, caller + NICENESS)
    assert lower > caller
    assert seen == {"run": lower, "helper": lower}
    assert _priority() == caller  # the caller's own is left as it was


@linux_only
def test_a_niceness_of_zero_leaves_the_priority():
    seen = []

    def run():
        seen.append(_priority())
        yield 0

    _drive(StepsInThread(run(), niceness=0).steps())
    assert seen == [_priority()]
    assert lower_priority(0) is False


def test_stop_closes_the_run_in_its_thread_without_waiting_for_its_step():
    in_step, release, closed_in = threading.Event(), threading.Event(), []

    def run():
        try:
            yield 1
            in_step.set()
            release.wait(10)  # a long pass
            yield 2
            yield 3
        finally:
            closed_in.append(threading.current_thread().name)

    driver = StepsInThread(run())
    steps = driver.steps()
    assert next(steps) == 1
    assert in_step.wait(10)
    driver.stop()  # returns at once, while the pass goes on
    assert not closed_in
    release.set()
    driver.thread.join(10)
    assert not driver.thread.is_alive()
    assert closed_in == [driver.thread.name]  # closed after its step, in its own thread


def test_closing_the_steps_early_stops_the_run():
    def run():
        k = 0
        while True:
            k += 1
            yield k

    driver = StepsInThread(run())
    steps = driver.steps()
    assert next(steps) == 1
    steps.close()
    driver.thread.join(10)
    assert not driver.thread.is_alive()
