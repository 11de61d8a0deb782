"""The pixels a pass writes: noted by the kernel, gathered from threads, written back as values.

A list of changes is an int64 array: ``changes[0]`` counts the writes and
``changes[1:]`` holds the flat indices of the first ones (see
``core._kernel.labyrinth_pass``). Where every write fits, the write-back
visits only those pixels; past the room, it visits every pixel.
"""

from __future__ import annotations

import numpy as np

from .._threads import run_shares
from ..core.tone_scale import ToneScale, write_changed_values, write_listed_values


def new_changes(pixels: int) -> np.ndarray:
    """An empty list of written pixels for ``run_pass`` on a plane of ``pixels`` pixels.

    ``changes[0]`` counts the writes, ``changes[1:]`` holds the first ones'
    flat indices: room for a few percent of the plane (a pass writes far
    fewer pixels than it keeps); past it the write-back visits every pixel.
    """
    capacity = 0 if pixels == 0 else max(4096, pixels // 16)
    changes = np.empty(capacity + 1, dtype=np.int64)
    changes[0] = 0
    return changes


def listed_changes(changes: np.ndarray) -> np.ndarray | None:
    """The flat indices noted in ``changes``; None if they did not all fit."""
    written = int(changes[0])
    return changes[1 : written + 1] if written < changes.shape[0] else None


def empty_copies(changes: np.ndarray, count: int) -> list[np.ndarray]:
    """``count`` empty lists of written pixels with the room of ``changes``."""
    copies = [np.empty_like(changes) for _ in range(count)]
    for copy in copies:
        copy[0] = 0
    return copies


def gather_changes(changes: np.ndarray, parts: list[np.ndarray]) -> None:
    """Append to ``changes`` those that threads noted in lists of their own (``parts``)."""
    for part in parts:
        listed = listed_changes(part)
        written = int(changes[0])
        if listed is None or written + len(listed) >= changes.shape[0]:
            changes[0] = changes.shape[0]  # more than fit: visit every pixel
            continue
        changes[written + 1 : written + 1 + len(listed)] = listed
        changes[0] = written + len(listed)


def write_back_changes(target, values, initial, work, scale, changes, threads: int = 1) -> None:
    """The changed tones' values into ``target``: fused for an integer plane (no ``initial``),
    at the pixels the passes wrote if ``changes`` holds them all. ``threads`` share an
    integer plane's rows (or its list of changes): each pixel is written by one of them,
    or by two with the same value (a pixel listed twice, by two passes)."""
    listed = None if changes is None else listed_changes(changes)
    if listed is not None:
        bounds = shares(len(listed), threads if len(listed) >= _MIN_SHARE else 1)
        run_shares(
            lambda k: write_listed_values(
                scale, target, values, work, listed[bounds[k] : bounds[k + 1]]
            ),
            len(bounds) - 1,
        )
    elif initial is None:
        bounds = shares(target.shape[0], threads if target.size >= _MIN_SHARE else 1)
        run_shares(
            lambda k: write_changed_values(
                scale, *(a[bounds[k] : bounds[k + 1]] for a in (target, values, work))
            ),
            len(bounds) - 1,
        )
    else:
        write_changes(target, initial, work, scale)


#: Pixels (or listed changes) below which a write-back is not shared among threads.
_MIN_SHARE = 1 << 16


def shares(items: int, threads: int) -> list[int]:
    """The bounds of ``threads`` (at most ``items``, at least 1) shares of ``items`` rows or
    items, as even as can be: ``bounds[k]`` to ``bounds[k + 1]`` for share k."""
    threads = max(1, min(int(threads), int(items)))
    return [round(k * items / threads) for k in range(threads + 1)]


def write_changes(
    target: np.ndarray, initial: np.ndarray, work: np.ndarray, scale: ToneScale
) -> None:
    """Map back into ``target`` (holding the source values) the tones that changed."""
    changed = initial.view(np.uint32) != work.view(np.uint32)
    target[changed] = scale.from_tones(work[changed], target.dtype)
