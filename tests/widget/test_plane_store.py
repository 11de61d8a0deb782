"""The store of a lazy result's planes: a temporary zarr, one uncompressed chunk per plane."""

from __future__ import annotations

import gc
import os
import subprocess
import sys

import numpy as np
import pytest

pytest.importorskip("zarr")

from napari_labyrinth.widget.plane_store import STORE_PREFIX, PlaneStore, remove_stale_stores


def test_planes_written_read_back_and_the_others_blank(tmp_path):
    store = PlaneStore((3, 2, 4, 5), np.uint16, 2, tmp_path)
    assert store.path.parent == tmp_path and store.path.name.startswith(STORE_PREFIX)
    planes = np.arange(3 * 4 * 5, dtype=np.uint16).reshape(3, 4, 5)
    store.write((1,), planes, axis=1)  # a stack's passes of input plane 1
    np.testing.assert_array_equal(store.array[:, 1], planes)
    assert not np.asarray(store.array[:, 0]).any()
    assert store.array.chunks == (1, 1, 4, 5)
    assert store.array.compressors == ()  # read back at the speed of the disk


def test_remove_deletes_the_directory_and_later_writes_do_nothing(tmp_path):
    store = PlaneStore((2, 4, 4), np.uint8, 2, tmp_path)
    store.remove()
    assert store.removed and not store.path.exists()
    store.write((0,), np.ones((4, 4), np.uint8))  # a plane that ended after the removal
    assert not store.path.exists()
    store.remove()  # once is enough


def test_a_store_no_longer_referenced_is_removed(tmp_path):
    path = PlaneStore((2, 4, 4), np.uint8, 2, tmp_path).path
    gc.collect()
    assert not path.exists()


@pytest.mark.subprocess
def test_a_store_is_removed_at_interpreter_exit(tmp_path):
    code = (
        "import sys, numpy as np\n"
        "from napari_labyrinth.widget.plane_store import PlaneStore\n"
        f"keep = PlaneStore((2, 4, 4), np.uint8, 2, {str(tmp_path)!r})\n"
        "print(keep.path)\n"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert not os.path.exists(out.stdout.strip())
    assert not list(tmp_path.iterdir())


@pytest.mark.subprocess
def test_stores_of_processes_that_are_gone_are_removed_by_the_next_one(tmp_path):
    code = (
        "import os, numpy as np\n"
        "from napari_labyrinth.widget.plane_store import PlaneStore\n"
        f"store = PlaneStore((2, 4, 4), np.uint8, 2, {str(tmp_path)!r})\n"
        "print(store.path, flush=True)\n"
        "os._exit(9)\n"  # killed outright: no clean-up
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=False)
    stale = out.stdout.strip()
    assert os.path.isdir(stale)
    other = tmp_path / "napari-labyrinth-planes-of-someone-else"
    other.mkdir()
    mine = PlaneStore((2, 4, 4), np.uint8, 2, tmp_path)
    assert not os.path.exists(stale)
    assert other.exists() and mine.path.exists()
    assert remove_stale_stores(tmp_path) == []  # this process still runs
