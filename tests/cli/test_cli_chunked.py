"""Chunked inputs and outputs of the command line: zarr stores and lazily read TIFF stacks.

Every lazy rendering must equal the in-memory ``labyrinth()`` of the same
data bit for bit, whatever the chunks of the store, and the default tone
limits found by streaming must equal those ``labyrinth()`` finds in memory.
"""

from __future__ import annotations

import asyncio
import contextlib
import os
import signal
import sys
import threading
import time
from pathlib import Path

import numpy as np
import pytest

zarr = pytest.importorskip("zarr")
da = pytest.importorskip("dask.array")

from napari_labyrinth import io as file_io
from napari_labyrinth import labyrinth, labyrinth_stack, labyrinth_sweep
from napari_labyrinth import lazy as lazy_images
from napari_labyrinth.cli import main
from napari_labyrinth.io import open_image, read_image, write_image
from napari_labyrinth.io import tiff as tiff_files
from napari_labyrinth.io import zarr as zarr_stores
from napari_labyrinth.lazy import blocks as lazy_blocks

SHAPE = (6, 64, 64)
OPTIONS = ["--passes", "2", "--seed", "7"]
API_OPTIONS = {"passes": 2, "seed": 7}


def textured(shape=SHAPE, dtype=np.uint16, seed=0) -> np.ndarray:
    """Ramps, a bright square and noise, different in every plane."""
    rng = np.random.default_rng(seed)
    _, x = np.mgrid[: shape[-2], : shape[-1]]
    planes = []
    for k in range(int(np.prod(shape[:-2]))):
        base = (
            40 + 150 * (((x + 5 * k) % shape[-1]) / shape[-1]) + 20 * rng.standard_normal(x.shape)
        )
        base[10 + k % 7 : 30, 12:40] += 60
        planes.append(np.clip(base, 0, 255))
    image = np.reshape(planes, shape)
    dtype = np.dtype(dtype)
    if dtype == np.uint16:
        return (image * 257).astype(np.uint16)
    if dtype.kind == "f":
        return (image / 255).astype(dtype)
    return image.astype(dtype)


def store(path: Path, image: np.ndarray, chunks=None) -> Path:
    """A zarr array at ``path`` (chunks: one plane by default)."""
    chunks = chunks or (1,) * (image.ndim - 2) + image.shape[-2:]
    array = zarr.create_array(store=str(path), shape=image.shape, chunks=chunks, dtype=image.dtype)
    array[...] = image
    return path


def leftovers(directory) -> list[str]:
    return [p.name for p in Path(directory).rglob("*.tmp")] + [
        p.name for p in Path(directory).rglob("*.old")
    ]


def error_lines(stderr: str) -> list[str]:
    return [line for line in stderr.splitlines() if line.startswith("napari-labyrinth: error:")]


def render(*argv) -> int:
    return main(["render", *map(str, argv)])


# -- zarr and TIFF in and out ---------------------------------------------------------------------


@pytest.mark.parametrize("dtype", [np.uint8, np.uint16, np.float32])
def test_zarr_to_zarr_equals_the_api(tmp_path, capsys, dtype):
    image = textured(dtype=dtype)
    source = store(tmp_path / "in.zarr", image)
    target = tmp_path / "out.zarr"
    assert render(source, "-o", target, *OPTIONS) == 0
    expected = labyrinth(image, **API_OPTIONS)  # default tone limits, found in memory
    assert not np.array_equal(expected, image)
    result = zarr.open_array(str(target), mode="r")
    assert result.dtype == image.dtype and result.shape == image.shape
    assert result.chunks == (1, 64, 64)  # one chunk per plane
    np.testing.assert_array_equal(result[...], expected)
    captured = capsys.readouterr()
    assert captured.out.strip() == str(target)
    if dtype != np.uint8:
        assert "tone limits" in captured.err  # streamed, and reported
    assert error_lines(captured.err) == []
    assert leftovers(tmp_path) == []


def test_zarr_to_tiff_and_tiff_to_zarr(tmp_path, monkeypatch):
    image = textured()
    expected = labyrinth(image, **API_OPTIONS)
    store(tmp_path / "in.zarr", image)
    assert render(tmp_path / "in.zarr", "-o", tmp_path / "out.tif", *OPTIONS) == 0
    np.testing.assert_array_equal(read_image(tmp_path / "out.tif"), expected)

    write_image(tmp_path / "in.tif", image)
    # a small TIFF is read into memory ...
    assert render(tmp_path / "in.tif", "-o", tmp_path / "small.zarr", *OPTIONS) == 0
    np.testing.assert_array_equal(read_image(tmp_path / "small.zarr"), expected)
    # ... a large one lazily, plane by plane
    monkeypatch.setattr(file_io, "LAZY_TIFF_BYTES", 0)
    assert lazy_images.is_lazy(open_image(tmp_path / "in.tif"))
    assert render(tmp_path / "in.tif", "-o", tmp_path / "large.zarr", *OPTIONS) == 0
    np.testing.assert_array_equal(read_image(tmp_path / "large.zarr"), expected)
    assert render(tmp_path / "in.tif", "-o", tmp_path / "large.tif", *OPTIONS) == 0
    np.testing.assert_array_equal(read_image(tmp_path / "large.tif"), expected)
    assert leftovers(tmp_path) == []


@pytest.mark.parametrize(
    "chunks",
    [(1, 16, 32), (1, 64, 17), (4, 64, 64), (4, 32, 32), (6, 64, 64)],
    ids=lambda c: "x".join(map(str, c)),
)
def test_any_store_chunks_give_the_same_result(tmp_path, chunks):
    image = textured()
    store(tmp_path / "in.zarr", image, chunks=chunks)
    lazy = open_image(tmp_path / "in.zarr")
    assert all(len(c) == 1 for c in lazy.chunks[-2:])  # whole planes, never tiles
    argv = [tmp_path / "in.zarr", "-o", tmp_path / "out.zarr", "--tone-limits", "0", "65535"]
    assert render(*argv, *OPTIONS) == 0
    expected = labyrinth(image, tone_limits=(0, 65535), **API_OPTIONS)
    np.testing.assert_array_equal(read_image(tmp_path / "out.zarr"), expected)


def test_four_dimensional_stack_and_colour(tmp_path):
    image = textured((2, 3, 32, 40))
    store(tmp_path / "tz.zarr", image, chunks=(1, 2, 32, 40))
    assert render(tmp_path / "tz.zarr", "-o", tmp_path / "tz.tif", *OPTIONS) == 0
    np.testing.assert_array_equal(read_image(tmp_path / "tz.tif"), labyrinth(image, **API_OPTIONS))
    rgba = np.moveaxis(textured((4, 32, 40), np.uint8), 0, -1)[None].repeat(3, axis=0)
    store(tmp_path / "rgba.zarr", rgba, chunks=(1, 32, 40, 4))
    argv = [tmp_path / "rgba.zarr", "-o", tmp_path / "rgba_out.zarr", "--channel-axis", "-1"]
    assert render(*argv, *OPTIONS) == 0
    out = zarr.open_array(str(tmp_path / "rgba_out.zarr"), mode="r")
    assert out.chunks == (1, 32, 40, 4)  # a plane is all its channels
    expected = labyrinth(rgba, channel_axis=-1, **API_OPTIONS)
    np.testing.assert_array_equal(out[...], expected)
    np.testing.assert_array_equal(out[..., 3], rgba[..., 3])  # alpha kept


@pytest.mark.parametrize("suffix", [".zarr", ".tif"])
def test_stack_and_sweep_of_a_store(tmp_path, suffix):
    image = textured((3, 40, 48))
    store(tmp_path / "in.zarr", image)
    out = tmp_path / "out"
    assert render(tmp_path / "in.zarr", "-o", out, "--stack", "--passes", "2") == 0
    stack = read_image(out / "in_labyrinth_stack.zarr")
    np.testing.assert_array_equal(stack, labyrinth_stack(image, passes=2))
    target = tmp_path / f"sweep{suffix}"
    assert render(tmp_path / "in.zarr", "-o", target, "--sweep", "seed=1,2", "--passes", "1") == 0
    np.testing.assert_array_equal(
        read_image(target), labyrinth_sweep(image, "seed", [1, 2], passes=1)
    )
    target = tmp_path / f"stack{suffix}"
    assert render(tmp_path / "in.zarr", "-o", target, "--stack", "--passes", "2") == 0
    np.testing.assert_array_equal(read_image(target), labyrinth_stack(image, passes=2))


def test_lazy_tiff_output_is_written_plane_by_plane(tmp_path, monkeypatch):
    """The TIFF of a lazy result is never computed whole: blocks arrive one plane at a time."""
    image = textured()
    store(tmp_path / "in.zarr", image)
    sizes = []
    real = tiff_files._write_contiguous

    def spy(fd, offset, shape, itemsize, block, location):
        sizes.append(block.shape)
        real(fd, offset, shape, itemsize, block, location)

    monkeypatch.setattr(tiff_files, "_write_contiguous", spy)
    assert render(tmp_path / "in.zarr", "-o", tmp_path / "out.tif", *OPTIONS) == 0
    assert sizes == [(1, 64, 64)] * 6
    np.testing.assert_array_equal(
        read_image(tmp_path / "out.tif"), labyrinth(image, **API_OPTIONS)
    )


def test_png_output_of_a_single_plane_store(tmp_path):
    image = textured((48, 40), np.uint8)
    store(tmp_path / "one.zarr", image)
    assert render(tmp_path / "one.zarr", "-o", tmp_path / "one.png", *OPTIONS) == 0
    np.testing.assert_array_equal(
        read_image(tmp_path / "one.png"), labyrinth(image, **API_OPTIONS)
    )


def test_directory_output_names_stores_after_the_store(tmp_path):
    image = textured()
    store(tmp_path / "a.zarr", image)
    write_image(tmp_path / "b.tif", image)
    argv = [tmp_path / "a.zarr", tmp_path / "b.tif", "-o", tmp_path / "out", "--tone-limits"]
    assert render(*argv, "0", "65535", *OPTIONS) == 0
    assert sorted(os.listdir(tmp_path / "out")) == ["a_labyrinth.zarr", "b_labyrinth.tif"]


# -- groups ---------------------------------------------------------------------------------------


def test_groups_ome_zarr_and_named_arrays(tmp_path, capsys):
    image = textured()
    expected = labyrinth(image, tone_limits=(0, 65535), **API_OPTIONS)
    limits = ["--tone-limits", "0", "65535", *OPTIONS]
    ome = zarr.open_group(str(tmp_path / "image.ome.zarr"), mode="w")
    ome.attrs["ome"] = {"multiscales": [{"datasets": [{"path": "0"}, {"path": "1"}]}]}
    ome.create_array("0", shape=image.shape, chunks=(1, 64, 64), dtype=image.dtype)[...] = image
    ome.create_array("1", shape=(6, 32, 32), dtype=image.dtype)
    assert render(tmp_path / "image.ome.zarr", "-o", tmp_path / "a.zarr", *limits) == 0
    np.testing.assert_array_equal(read_image(tmp_path / "a.zarr"), expected)

    group = zarr.open_group(str(tmp_path / "two.zarr"), mode="w")
    group.create_array("raw", shape=image.shape, dtype=image.dtype)[...] = image
    group.create_array("mask", shape=image.shape, dtype=np.uint8)
    assert render(tmp_path / "two.zarr", "-o", tmp_path / "b.zarr", *limits) == 1
    (line,) = error_lines(capsys.readouterr().err)
    assert "2 arrays" in line and "two.zarr/mask" in line
    assert render(tmp_path / "two.zarr" / "raw", "-o", tmp_path / "b.zarr", *limits) == 0
    np.testing.assert_array_equal(read_image(tmp_path / "b.zarr"), expected)


# -- overwriting and failures ---------------------------------------------------------------------


def test_refuses_to_overwrite_a_store(tmp_path, capsys):
    image = textured()
    store(tmp_path / "in.zarr", image)
    old = store(tmp_path / "out.zarr", np.ones((2, 8, 8), np.uint8))
    argv = [tmp_path / "in.zarr", "-o", old, *OPTIONS]
    assert render(*argv) == 1
    err = capsys.readouterr().err
    assert "out.zarr" in err and "--overwrite" in err and "Traceback" not in err
    np.testing.assert_array_equal(read_image(old), np.ones((2, 8, 8), np.uint8))
    assert render(*argv, "--overwrite") == 0
    np.testing.assert_array_equal(read_image(old), labyrinth(image, **API_OPTIONS))
    assert sorted(os.listdir(tmp_path)) == ["in.zarr", "out.zarr"]  # nothing moved aside is left


def test_a_directory_that_is_not_a_store_is_never_replaced(tmp_path, capsys):
    store(tmp_path / "in.zarr", textured())
    mine = tmp_path / "notes.zarr"
    mine.mkdir()
    (mine / "thesis.txt").write_text("precious")
    argv = [tmp_path / "in.zarr", "-o", mine, "--overwrite", *OPTIONS]
    assert render(*argv) == 1
    (line,) = error_lines(capsys.readouterr().err)
    assert "not a zarr store" in line
    assert f"{mine}: exists and is not a zarr store" in line  # named: it is not the input
    assert os.listdir(mine) == ["thesis.txt"]
    assert leftovers(tmp_path) == []


def test_refuses_to_overwrite_the_input_store(tmp_path, capsys):
    image = textured()
    source = store(tmp_path / "in.zarr", image)
    assert render(source, "-o", source, *OPTIONS) == 1
    assert "input" in capsys.readouterr().err
    np.testing.assert_array_equal(read_image(source), image)
    # and the group holding an input array, even with --overwrite: it replaced the input
    # and every other member of the group
    group = zarr.open_group(str(tmp_path / "group.zarr"), mode="w")
    group.create_array("raw", shape=image.shape, dtype=image.dtype)[...] = image
    group.create_array("other", shape=(4, 4), dtype="u1")[...] = 7
    for overwrite in ([], ["--overwrite"]):
        argv = [tmp_path / "group.zarr" / "raw", "-o", tmp_path / "group.zarr", *overwrite]
        assert render(*argv, *OPTIONS) == 2
        assert "would replace the zarr store" in capsys.readouterr().err
        assert sorted(os.listdir(tmp_path / "group.zarr")) == ["other", "raw", "zarr.json"]
        np.testing.assert_array_equal(read_image(tmp_path / "group.zarr" / "raw"), image)
    # with --overwrite the input is read whole before its store is replaced
    assert render(source, "-o", source, "--overwrite", *OPTIONS) == 0
    np.testing.assert_array_equal(read_image(source), labyrinth(image, **API_OPTIONS))
    assert leftovers(tmp_path) == []
    assert sorted(os.listdir(tmp_path)) == ["group.zarr", "in.zarr"]


@pytest.mark.parametrize(
    "output",
    ["group.zarr/raw_labyrinth.zarr", "group.zarr/raw", "in.zarr/out.zarr", "in.zarr/sub/x.tif"],
)
def test_refuses_to_write_inside_the_store_of_an_input(tmp_path, capsys, output):
    # the store gained a member (the group no longer opened without an array's name) and
    # its checksum changed, so that ``reproduce`` refused the input
    image = textured()
    store(tmp_path / "in.zarr", image)
    group = zarr.open_group(str(tmp_path / "group.zarr"), mode="w")
    group.create_array("raw", shape=image.shape, dtype=image.dtype)[...] = image
    source = tmp_path / ("group.zarr/raw" if output.startswith("group") else "in.zarr")
    before = sorted(str(p.relative_to(tmp_path)) for p in tmp_path.rglob("*"))
    assert render(source, "-o", tmp_path / output, *OPTIONS) == 2
    assert "would be written inside the zarr store" in capsys.readouterr().err
    assert sorted(str(p.relative_to(tmp_path)) for p in tmp_path.rglob("*")) == before


def test_arrays_of_one_store_in_a_batch_are_named_after_their_array(tmp_path):
    # they were named raw__labyrinth.zarr and other_abyrinth.zarr
    image = textured()
    group = zarr.open_group(str(tmp_path / "group.zarr"), mode="w")
    for name in ("raw", "other"):
        group.create_array(name, shape=image.shape, dtype=image.dtype)[...] = image
    inputs = [tmp_path / "group.zarr" / name for name in ("raw", "other")]
    assert render(*inputs, "-o", tmp_path / "out", *OPTIONS) == 0
    names = sorted(os.listdir(tmp_path / "out"))
    assert names == ["group_other_labyrinth.zarr", "group_raw_labyrinth.zarr"]


def test_failure_while_writing_leaves_nothing_and_keeps_the_old_store(
    tmp_path, monkeypatch, capsys
):
    image = textured()
    store(tmp_path / "in.zarr", image)
    old = store(tmp_path / "out.zarr", np.ones((2, 8, 8), np.uint8))
    calls = []

    def broken(path, block, location):
        calls.append(location)
        if len(calls) == 3:
            raise OSError(28, "No space left on device")
        zarr_stores._cached_zarr_for_writing(path)[tuple(slice(*r) for r in location)] = block

    monkeypatch.setattr(zarr_stores, "_write_zarr_block", broken)
    argv = [tmp_path / "in.zarr", "-o", old, "--overwrite", *OPTIONS]
    assert render(*argv) == 1
    (line,) = error_lines(capsys.readouterr().err)
    assert "No space left on device" in line
    np.testing.assert_array_equal(read_image(old), np.ones((2, 8, 8), np.uint8))
    assert render(tmp_path / "in.zarr", "-o", tmp_path / "out.tif", *OPTIONS) == 0
    assert sorted(os.listdir(tmp_path)) == ["in.zarr", "out.tif", "out.zarr"]


@pytest.mark.skipif(not hasattr(signal, "pthread_kill"), reason="POSIX signals")
@pytest.mark.parametrize("lazy", [True, False], ids=["lazy", "in memory"])
def test_ctrl_c_while_zarr_writes_leaves_no_temporary(tmp_path, monkeypatch, lazy):
    # zarr does its I/O on an event loop of its own, which Ctrl-C in the waiting thread does
    # not stop: the store's metadata were written after the temporary had been removed
    original = zarr.storage.LocalStore.set

    async def slow_set(self, key, value):
        await asyncio.sleep(0.3)
        return await original(self, key, value)

    monkeypatch.setattr(zarr.storage.LocalStore, "set", slow_set)
    image = textured()
    array = da.from_array(image, chunks=(1, 64, 64)) if lazy else image
    main_thread = threading.main_thread().ident
    threading.Timer(0.1, signal.pthread_kill, (main_thread, signal.SIGINT)).start()
    with pytest.raises(KeyboardInterrupt):
        file_io.write_array(tmp_path / "out.zarr", array, plane_axes=(-2, -1))
        time.sleep(5)  # not reached unless the write outran the signal
    time.sleep(1.0)  # what zarr still had to write
    assert os.listdir(tmp_path) == []


class HeldChunkWrite:
    """The first chunk written to a zarr store held until released: a block write under way.

    ``entered`` is set once the write is held (the store's check for its metadata passed),
    ``finished`` once it has written its chunk, recreating the directories that hold it.
    ``metadata=True`` holds the first write of the store's metadata instead.
    """

    def __init__(self, monkeypatch, metadata=False):
        self.entered, self.released, self.finished = (threading.Event() for _ in range(3))
        self.released_at: float | None = None  # time.monotonic() at the release
        original = zarr.storage.LocalStore.set
        held = self

        def is_held(key):
            return key.endswith("zarr.json") if metadata else "/c/" in f"/{key}"

        async def set_held(store, key, value):
            if not is_held(key) or held.entered.is_set():
                return await original(store, key, value)
            held.entered.set()
            await asyncio.to_thread(held.released.wait, 60)
            try:
                return await original(store, key, value)
            finally:
                held.finished.set()

        monkeypatch.setattr(zarr.storage.LocalStore, "set", set_held)

    @contextlib.contextmanager
    def released_when_raised(self, ready: threading.Event, seconds: float = 1.0):
        """Release the write as soon as the block has raised, once ``ready`` is set; or
        ``seconds`` later if the block is still waiting for the write (as it must)."""
        raised = threading.Event()

        def release():
            ready.wait(60)
            raised.wait(seconds)
            self.released_at = time.monotonic()
            self.released.set()

        threading.Thread(target=release, daemon=True).start()
        try:
            yield
        finally:
            raised.set()
            assert self.finished.wait(60), "the held block write never ended"


def the_wait_for_the_block(monkeypatch) -> threading.Event:
    """An event set once an interrupted run begins to wait for the block writes under way.

    A second Ctrl-C sent after it comes during that wait, not as the first one unwinds.
    """
    begun = threading.Event()
    wait = lazy_blocks.wait_through_interrupts

    def waited(*args, **kwargs):
        begun.set()
        return wait(*args, **kwargs)

    monkeypatch.setattr(lazy_blocks, "wait_through_interrupts", waited)
    return begun


def _started_by(*module) -> bool:
    """Whether the main thread starts a thread from ``module`` (``"lazy", "blocks.py"``)."""
    if threading.current_thread() is not threading.main_thread():
        return False  # started by a block writer, or by zarr for its I/O
    frame = sys._getframe(1)
    while frame is not None:
        if Path(frame.f_code.co_filename).parts[-2:] == module:
            return True
        frame = frame.f_back
    return False


def test_ctrl_c_as_the_store_creating_thread_starts_leaves_no_temporary(tmp_path, monkeypatch):
    # the thread that creates the store (its metadata) was started with Thread.start, which
    # waits for it to run: Ctrl-C handled there left it running, unknown to the writer,
    # which removed the temporary, and the metadata written then made it again
    held = HeldChunkWrite(monkeypatch, metadata=True)
    real_start = threading.Thread.start
    interrupted = []

    def start(thread):
        real_start(thread)
        if not interrupted and _started_by("io", "zarr.py"):
            interrupted.append(thread)
            raise KeyboardInterrupt  # as the handler of SIGINT does, the thread running

    monkeypatch.setattr(threading.Thread, "start", start)
    with held.released_when_raised(held.entered), contextlib.suppress(KeyboardInterrupt):
        file_io.write_array(tmp_path / "out.zarr", textured((1, 64, 64)), plane_axes=(-2, -1))
    assert os.listdir(tmp_path) == (["out.zarr"] if not interrupted else [])


def test_ctrl_c_as_a_block_writer_thread_starts_leaves_no_temporary(tmp_path, monkeypatch):
    # Python runs Ctrl-C's handler where the main thread waits, here in Thread.start() as
    # the pool took on a thread for a block: the thread ran on, unknown to the pool shut
    # down after the interrupt, and wrote its block into the temporary once it was removed
    from dask.callbacks import Callback

    held = HeldChunkWrite(monkeypatch)
    real_start = threading.Thread.start
    interrupted = []

    def start(thread):
        real_start(thread)
        if not interrupted and _started_by("lazy", "blocks.py"):
            interrupted.append(thread)
            raise KeyboardInterrupt  # as the handler of SIGINT does, the thread running

    monkeypatch.setattr(threading.Thread, "start", start)
    array = da.from_array(textured((1, 64, 64)), chunks=(1, 64, 64))
    # dask's computation ends (interrupted) once the thread is writing its block
    the_block_is_written = Callback(finish=lambda *_: held.entered.wait(60))
    with (
        held.released_when_raised(held.entered),
        the_block_is_written,
        pytest.raises(KeyboardInterrupt),
    ):
        file_io.write_array(tmp_path / "out.zarr", array, plane_axes=(-2, -1))
    assert interrupted, "no thread was started to write the block"
    assert os.listdir(tmp_path) == []


@pytest.mark.skipif(not hasattr(signal, "pthread_kill"), reason="POSIX signals")
def test_a_second_ctrl_c_while_a_block_is_written_leaves_no_temporary(tmp_path, monkeypatch):
    # the first Ctrl-C had the run wait for the block being written; a second one ended
    # the wait (Thread.join), the temporary was removed, and the block's write made it again
    held = HeldChunkWrite(monkeypatch)
    handled, twice = [], threading.Event()
    waiting = the_wait_for_the_block(monkeypatch)

    def handler(signum, frame):
        handled.append(signum)
        raise KeyboardInterrupt

    def interrupt_twice(main_thread):
        held.entered.wait(60)
        for count, ready in ((1, held.entered), (2, waiting)):
            ready.wait(60)
            time.sleep(0.2)  # the main thread blocked in the wait
            signal.pthread_kill(main_thread, signal.SIGINT)
            while len(handled) < count:
                time.sleep(0.005)
        twice.set()

    previous = signal.signal(signal.SIGINT, handler)
    try:
        threading.Thread(
            target=interrupt_twice, args=(threading.main_thread().ident,), daemon=True
        ).start()
        array = da.from_array(textured((1, 64, 64)), chunks=(1, 64, 64))
        with held.released_when_raised(twice), pytest.raises(KeyboardInterrupt):
            file_io.write_array(tmp_path / "out.zarr", array, plane_axes=(-2, -1))
    finally:
        signal.signal(signal.SIGINT, previous)
    assert handled == [signal.SIGINT, signal.SIGINT]
    assert os.listdir(tmp_path) == []


@pytest.mark.skipif(not hasattr(signal, "pthread_kill"), reason="POSIX signals")
def test_ctrl_c_twice_while_the_cli_writes_a_block_exits_130_and_leaves_no_temporary(
    tmp_path, monkeypatch, capsys
):
    source = store(tmp_path / "in.zarr", textured((1, 64, 64)))
    held = HeldChunkWrite(monkeypatch)
    twice = threading.Event()
    waiting = the_wait_for_the_block(monkeypatch)

    def interrupt_twice(main_thread):
        for ready in (held.entered, waiting):
            if not ready.wait(60):
                return  # the test fails on what the command did meanwhile
            time.sleep(0.2)  # the main thread blocked in the wait
            signal.pthread_kill(main_thread, signal.SIGINT)
        twice.set()

    threading.Thread(
        target=interrupt_twice, args=(threading.main_thread().ident,), daemon=True
    ).start()
    with held.released_when_raised(twice):
        code = render(source, "-o", tmp_path / "out.zarr", *OPTIONS)
        returned = time.monotonic()
    assert twice.is_set(), "the command never waited for the block being written"
    assert code == 130
    assert error_lines(capsys.readouterr().err) == ["napari-labyrinth: error: interrupted"]
    assert sorted(os.listdir(tmp_path)) == ["in.zarr"]
    assert returned - held.released_at < 5.0  # once the block is written, not a bound later


def test_bad_stores_fail_one_line_each(tmp_path, capsys):
    store(tmp_path / "good.zarr", textured())
    (tmp_path / "empty.zarr").mkdir()
    store(tmp_path / "corrupt.zarr", textured())
    (tmp_path / "corrupt.zarr" / "c" / "4" / "0" / "0").write_bytes(b"not zstd" * 10)
    store(tmp_path / "labels.zarr", np.zeros((2, 8, 8), np.int64))
    argv = [
        tmp_path / "good.zarr",
        tmp_path / "empty.zarr",
        tmp_path / "missing.zarr",
        tmp_path / "corrupt.zarr",
        tmp_path / "labels.zarr",
        "-o",
        tmp_path / "out",
        *OPTIONS,
    ]
    assert render(*argv) == 1
    captured = capsys.readouterr()
    assert "Traceback" not in captured.err
    errors = error_lines(captured.err)
    assert len(errors) == 4
    for line, name in zip(errors, ["empty", "missing", "corrupt", "labels"], strict=True):
        assert f"{name}.zarr" in line
    assert "Zstd" in errors[2] and "int64" in errors[3]
    assert os.listdir(tmp_path / "out") == ["good_labyrinth.zarr"]
    assert leftovers(tmp_path) == []


def test_several_inputs_cannot_go_to_one_store(tmp_path, capsys):
    store(tmp_path / "a.zarr", textured())
    store(tmp_path / "b.zarr", textured())
    assert render(tmp_path / "a.zarr", tmp_path / "b.zarr", "-o", tmp_path / "o.zarr") == 2
    assert len(error_lines(capsys.readouterr().err)) == 1


@pytest.mark.parametrize("bad", [["--scheduler", "local:zero"], ["--scheduler", "local:0"]])
def test_bad_scheduler_is_a_usage_error(tmp_path, capsys, bad):
    store(tmp_path / "a.zarr", textured())
    assert render(tmp_path / "a.zarr", "-o", tmp_path / "o.zarr", *bad) == 2
    assert "Traceback" not in capsys.readouterr().err


@pytest.mark.parametrize("output", ["experiment.zarr/labyrinth", "experiment.zarr/raw/x.tif"])
def test_refuses_to_write_inside_a_zarr_store_that_holds_no_input(tmp_path, capsys, output):
    # -o experiment.zarr/labyrinth made experiment.zarr/labyrinth/cells_labyrinth.zarr, a
    # directory the group does not see as a member
    image = textured()
    source = store(tmp_path / "cells.zarr", image)
    group = zarr.open_group(str(tmp_path / "experiment.zarr"), mode="w")
    group.create_array("raw", shape=image.shape, dtype=image.dtype)[...] = image
    before = sorted(str(p.relative_to(tmp_path)) for p in tmp_path.rglob("*"))
    assert render(source, "-o", tmp_path / output, *OPTIONS) == 2
    assert "inside the zarr store" in capsys.readouterr().err
    assert sorted(str(p.relative_to(tmp_path)) for p in tmp_path.rglob("*")) == before


def test_an_output_that_cannot_take_a_lazy_rendering_is_refused_before_its_limits_pass(
    tmp_path, capsys
):
    # the pass over the data for the default tone limits ran first, then the PNG refused
    image = np.stack([textured()[0]] * 3, axis=-1)  # uint16 colour: PNG holds uint16 grey only
    source = tmp_path / "rgb.zarr"
    zarr.create_array(str(source), shape=image.shape, dtype=image.dtype)[...] = image
    argv = [source, "-o", tmp_path / "out.png", "--channel-axis", "-1", *OPTIONS]
    assert render(*argv) == 1
    err = capsys.readouterr().err
    assert "cannot store uint16 data of shape (64, 64, 3) as PNG" in err
    assert "finding the default tone limits" not in err


@pytest.mark.parametrize("output", ["out.zarr", "out.tif", "out.png"])
@pytest.mark.parametrize("lazy", [True, False], ids=["lazy", "in memory"])
def test_an_interruption_as_the_temporary_is_made_leaves_none(
    tmp_path, monkeypatch, output, lazy
):
    # Python runs a signal's handler as a call returns: SIGTERM handled as the temporary's
    # mkdir (or open) returned raised before the code that removes it was entered
    if output == "out.png" and lazy:
        pytest.skip("a PNG is written from memory")
    real_mkdir, real_open = os.mkdir, os.open
    signalled = []

    def interrupted(real):
        def call(path, *args, **kwargs):
            result = real(path, *args, **kwargs)
            if not signalled and os.path.basename(str(path)).startswith(f".{output}."):
                signalled.append(path)
                raise KeyboardInterrupt  # as the handler of the signal does
            return result

        return call

    monkeypatch.setattr(os, "mkdir", interrupted(real_mkdir))
    monkeypatch.setattr(os, "open", interrupted(real_open))
    image = textured()[:1, :16, :16].astype(np.uint8)[0]
    array = da.from_array(image) if lazy else image
    with pytest.raises(KeyboardInterrupt):
        file_io.write_array(tmp_path / output, array)
    assert signalled and os.listdir(tmp_path) == []
