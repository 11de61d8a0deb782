"""Running the blocks of a dask array into a writer, with per-plane progress.

``run_blocks`` computes every block and hands it to ``write``, under the
local threaded scheduler or a ``dask.distributed`` client, holding only a few
blocks in memory at a time; on failure or interruption no write it started is
left running, so that the caller may remove what they write into.

Under the local scheduler every write passes a gate (``_WriteGate``): once the run
fails or is interrupted (Ctrl-C), the gate lets no write start and waits for
those under way, through further interruptions, before the run raises. A
thread's block write can outlive the pool that ran it: a Ctrl-C handled as the
pool starts a thread (``Thread.start`` waits for it) leaves that thread running,
unknown to the pool, and a second Ctrl-C ends the wait of the pool's shutdown.
"""

from __future__ import annotations

import os
import sys
import threading
import time
import uuid
from collections.abc import Callable, Sequence
from concurrent.futures import ThreadPoolExecutor
from typing import Any

import numpy as np

from .._threads import wait_through_interrupts
from .errors import computing

ProgressCallback = Callable[[int, int], Any]

#: Seconds a failed or interrupted run waits for the block writes under way (on a cluster:
#: for its tasks) to end, before it raises and its caller removes what they write into.
WRITES_END_WITHIN = 60.0


class _WritesStopped(RuntimeError):
    """A block's write refused: the run it belongs to failed or was interrupted."""


class _WriteGate:
    """``write(block, location)`` for the threads of one run, until the run is given up.

    Parameters
    ----------
    write : callable
        ``write(block, location)``, called by the gate while it is open.

    Notes
    -----
    A write starts only while the gate is open, and is counted until it
    returns; :meth:`close` lets no more start and waits for those counted.
    """

    def __init__(self, write: Callable[[np.ndarray, tuple[tuple[int, int], ...]], Any]):
        self._write = write
        self._lock = threading.Lock()
        self._open = True
        self._writing = 0
        self._idle = threading.Event()
        self._idle.set()
        self._token = uuid.uuid4().hex

    def __call__(self, block: np.ndarray, location: tuple[tuple[int, int], ...]) -> Any:
        with self._lock:
            if not self._open:
                raise _WritesStopped("the run was stopped: this block is not written")
            self._writing += 1
            self._idle.clear()
        try:
            return self._write(block, location)
        finally:
            with self._lock:
                self._writing -= 1
                if self._writing == 0:
                    self._idle.set()

    def close(self, timeout: float = WRITES_END_WITHIN) -> BaseException | None:
        """Let no write start, and wait up to ``timeout`` seconds for those under way.

        Interruptions of the wait (Ctrl-C) do not end it early.

        Returns
        -------
        BaseException or None
            The first interruption of the wait, for the caller to raise.
        """
        interruption = None
        while True:  # a Ctrl-C as the lock is taken must not leave the gate open
            try:
                with self._lock:
                    self._open = False
                break
            except BaseException as error:  # noqa: BLE001 - handed back to the caller
                interruption = interruption or error
        _, during_wait = wait_through_interrupts(self._idle, timeout)
        return interruption or during_wait

    def __dask_tokenize__(self) -> str:
        return self._token


def current_client():
    """The ``dask.distributed`` client dask computes with, or None."""
    if "distributed" not in sys.modules:
        return None
    from distributed import default_client  # loaded already: sys.modules says so

    try:
        return default_client()
    except ValueError:
        return None


def block_locations(chunks: tuple[tuple[int, ...], ...]) -> list[tuple[tuple[int, int], ...]]:
    """``((start, stop), ...)`` of every block, in C order (that of ``to_delayed().ravel()``)."""
    starts = [np.concatenate(([0], np.cumsum(c))) for c in chunks]
    return [
        tuple((int(s[i]), int(s[i + 1])) for s, i in zip(starts, index))
        for index in np.ndindex(tuple(len(c) for c in chunks))
    ]


def run_blocks(
    array,
    write: Callable[[np.ndarray, tuple[tuple[int, int], ...]], Any],
    *,
    plane_axes: Sequence[int] = (-2, -1),
    on_client: bool = False,
    progress: ProgressCallback | None = None,
) -> None:
    """Compute every block of a dask array and pass it to ``write(block, location)``.

    Parameters
    ----------
    array : dask array
    write : callable
        ``write(block, ((start, stop), ...))``. Called inside the tasks (by
        the local threads or by the cluster's workers, so it must pickle and
        be safe to call concurrently on different blocks) unless
        ``on_client``.
    plane_axes : sequence of int, optional
        The axes of a plane: the others count the planes for ``progress``.
    on_client : bool, optional
        Bring every block to this process and call ``write`` here, one at a
        time (for a file only this process can write). Only makes a
        difference under a ``dask.distributed`` client.
    progress : callable, optional
        ``progress(planes_done, planes_total)`` after each block.

    Notes
    -----
    Memory: the local scheduler runs one chain of tasks (read, render,
    write) per thread and keeps no rendered block once written; on a cluster
    the workers write (or the blocks come back as they finish and are
    written and released at once).
    """
    plane_axes = {axis % array.ndim for axis in plane_axes}
    lead = [axis for axis in range(array.ndim) if axis not in plane_axes]
    total = int(np.prod([array.shape[axis] for axis in lead]))
    client = current_client()
    if client is not None and on_client:
        _run_on_client(client, array, write, lead, total, progress)
        return
    gate = _WriteGate(write) if client is None else None  # the local threads' writes
    counts = array.map_blocks(
        _write_block,
        write=write if gate is None else gate,
        lead=tuple(lead),
        dtype=np.int64,
        chunks=tuple((1,) * len(c) for c in array.chunks),
        meta=np.empty((0,) * array.ndim, dtype=np.int64),
    )
    if gate is None:
        _run_futures(client, counts, total, progress)
    else:
        _run_local(counts, gate, total, progress)


def _write_block(block, write, lead, block_info=None):
    location = tuple(tuple(pair) for pair in block_info[0]["array-location"])
    write(block, location)
    planes = int(np.prod([block.shape[axis] for axis in lead]))
    return np.full((1,) * block.ndim, planes, dtype=np.int64)


def _run_local(counts, gate: _WriteGate, total: int, progress: ProgressCallback | None) -> None:
    from dask.callbacks import Callback  # dask is optional: imported on first use

    name = counts.name
    done = 0

    class _Planes(Callback):
        def _posttask(self, key, result, dsk, state, worker_id):
            nonlocal done
            if isinstance(key, tuple) and key[0] == name:
                done += int(result.sum())
                if progress is not None:
                    progress(done, total)

    pool = ThreadPoolExecutor(max_workers=os.cpu_count() or 1)
    try:
        with _Planes(), computing():
            counts.compute(scheduler="threads", pool=pool)
    except BaseException as error:
        # no block is written from now on, and those being written end before the caller
        # removes what they write into; blocks still being rendered are not waited for
        # after an interruption, and those not started are dropped
        interruption = gate.close()
        pool.shutdown(wait=not isinstance(error, KeyboardInterrupt), cancel_futures=True)
        if interruption is not None and not isinstance(error, KeyboardInterrupt):
            raise interruption from error
        raise
    pool.shutdown(wait=True)


def _run_futures(client, counts, total: int, progress: ProgressCallback | None) -> None:
    from distributed import as_completed  # optional: only under a client

    futures = client.compute(list(counts.to_delayed().ravel()))
    done = 0
    try:
        for future in as_completed(futures):
            with computing():
                done += int(future.result().sum())
            future.release()
            if progress is not None:
                progress(done, total)
    except BaseException:
        _cancel_and_wait(client, futures)
        raise


def _run_on_client(client, array, write, lead, total, progress) -> None:
    from distributed import as_completed  # optional: only under a client

    locations = block_locations(array.chunks)
    futures = client.compute(list(array.to_delayed().ravel()))
    where = {future.key: location for future, location in zip(futures, locations)}
    done = 0
    try:
        for future in as_completed(futures):
            with computing():
                block = future.result()
            location = where.pop(future.key)
            future.release()
            write(block, location)
            done += int(np.prod([location[axis][1] - location[axis][0] for axis in lead]))
            if progress is not None:
                progress(done, total)
    except BaseException:
        _cancel_and_wait(client, futures)
        raise


def _cancel_and_wait(client, futures, timeout: float = WRITES_END_WITHIN) -> None:
    """Cancel ``futures`` and wait until no worker still runs one of them."""
    keys = {future.key for future in futures}
    client.cancel(futures)
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        try:
            running = client.run(_executing_keys)
        except (OSError, RuntimeError, ValueError):  # the cluster is gone: nothing runs
            return
        if not keys.intersection(key for worker in running.values() for key in worker):
            return
        time.sleep(0.05)


def _executing_keys(dask_worker) -> list:
    """Keys of the tasks a worker is running (run on the worker by ``Client.run``)."""
    return [task.key for task in dask_worker.state.executing]
