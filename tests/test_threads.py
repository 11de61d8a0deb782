"""The thread primitives (a helper started without waiting, a wait through Ctrl-C) and the band
runs built on them."""

from __future__ import annotations

import signal
import threading
import time

import pytest

from napari_labyrinth import _threads
from napari_labyrinth.metrics import _bands


def test_shares_run_at_once_the_first_on_the_caller_s_thread():
    barrier = threading.Barrier(3, timeout=5)  # every share waits for the others: at once
    threads = {}

    def share(k):
        barrier.wait()
        threads[k] = threading.get_ident()

    _threads.run_shares(share, 3)
    assert sorted(threads) == [0, 1, 2] and len(set(threads.values())) == 3
    assert threads[0] == threading.get_ident()
    seen = []
    _threads.run_shares(seen.append, 1)
    assert seen == [0]


def test_a_failed_share_is_raised_once_every_share_has_ended():
    ended = []

    def share(k):
        if k == 1:
            raise ValueError("share 1")
        time.sleep(0.05)
        ended.append(k)

    with pytest.raises(ValueError, match="share 1"):
        _threads.run_shares(share, 3)
    assert sorted(ended) == [0, 2]


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


@pytest.mark.skipif(not hasattr(signal, "pthread_kill"), reason="POSIX signals")
class _WatchedEvent(threading.Event):
    """An event that says when a thread first waits on it."""

    def __init__(self):
        super().__init__()
        self.waited_on = threading.Event()

    def wait(self, timeout=None):
        self.waited_on.set()
        return super().wait(timeout)


def test_a_wait_through_interrupts_ends_when_the_event_is_set_and_hands_back_the_first():
    ended, handled = _WatchedEvent(), []

    def handler(signum, frame):
        handled.append(signum)
        raise KeyboardInterrupt(len(handled))

    def interrupt_twice_then_end(main_thread):
        # each Ctrl-C while the main thread is blocked in the wait, as a person's comes: one
        # raised inside threading's own lock handling could leave a lock held
        for count in (1, 2):
            ended.waited_on.wait(60)
            ended.waited_on.clear()
            time.sleep(0.2)
            signal.pthread_kill(main_thread, signal.SIGINT)
            while len(handled) < count:
                time.sleep(0.005)
        ended.waited_on.wait(60)
        ended.set()

    previous = signal.signal(signal.SIGINT, handler)
    interrupter = threading.Thread(
        target=interrupt_twice_then_end, args=(threading.main_thread().ident,), daemon=True
    )
    try:
        interrupter.start()
        is_set, interruption = _threads.wait_through_interrupts(ended, timeout=60)
    finally:
        interrupter.join(5)  # no Ctrl-C of this test may reach the tests after it
        signal.signal(signal.SIGINT, previous)
    assert is_set and len(handled) == 2
    assert isinstance(interruption, KeyboardInterrupt) and interruption.args == (1,)


def test_a_wait_through_interrupts_gives_up_after_its_timeout():
    start = time.monotonic()
    assert _threads.wait_through_interrupts(threading.Event(), timeout=0.05) == (False, None)
    assert time.monotonic() - start < 5
