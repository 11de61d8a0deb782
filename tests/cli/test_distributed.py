"""Rendering on a dask.distributed cluster (loopback only) equals rendering locally, bit for bit.

One ``LocalCluster`` of two single-threaded worker processes serves the
module; it must shut down without leaving a process behind. Warnings raised
by this module's tests fail them.
"""

from __future__ import annotations

import contextlib
import gc
import os
import warnings
from pathlib import Path

import numpy as np
import pytest

distributed = pytest.importorskip("distributed")
zarr = pytest.importorskip("zarr")
psutil = pytest.importorskip("psutil")
da = pytest.importorskip("dask.array")

from napari_labyrinth import labyrinth, labyrinth_stack
from napari_labyrinth.cli import main
from napari_labyrinth.cli import render as render_module
from napari_labyrinth.io import read_image, write_image

from .test_cli_chunked import API_OPTIONS, OPTIONS, error_lines, store, textured

#: A local cluster of worker processes, started and stopped by the tests.
pytestmark = pytest.mark.subprocess

#: Processes multiprocessing keeps for the life of this process (not a cluster's).
HELPERS = ("multiprocessing.resource_tracker", "multiprocessing.forkserver")


def children() -> set[int]:
    """Child processes of the test process, multiprocessing's own helpers excepted."""
    pids = set()
    for process in psutil.Process().children(recursive=True):
        try:
            command = " ".join(process.cmdline())
        except psutil.Error:  # gone meanwhile
            continue
        if not any(helper in command for helper in HELPERS):
            pids.add(process.pid)
    return pids


def wait_for_exit(pids: set[int]) -> None:
    processes = []
    for pid in pids:
        with contextlib.suppress(psutil.NoSuchProcess):
            processes.append(psutil.Process(pid))
    psutil.wait_procs(processes, timeout=10)


@contextlib.contextmanager
def no_warnings():
    """Fail on any warning but the pydantic deprecations napari's pytest plugin brings."""
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        yield
    ours = [w for w in caught if "Pydantic" not in type(w.message).__name__]
    assert ours == [], [f"{w.category.__name__}: {w.message}" for w in ours]


@pytest.fixture(scope="module")
def cluster():
    before = children()
    with no_warnings():
        cluster = distributed.LocalCluster(
            n_workers=2,
            threads_per_worker=1,
            processes=True,
            host="127.0.0.1",
            dashboard_address=None,
            # the scheduler's HTTP endpoints on a free port, not 8787 (may be taken)
            scheduler_kwargs={"dashboard": False, "dashboard_address": "127.0.0.1:0"},
        )
    assert cluster.scheduler_address.startswith("tcp://127.0.0.1:")
    yield cluster
    with no_warnings():
        cluster.close()
    wait_for_exit(children() - before)
    assert children() - before == set(), "worker processes left behind"


@pytest.fixture
def client(cluster):
    with no_warnings(), distributed.Client(cluster) as client:
        yield client
    assert distributed.client._get_global_client() is None


def render(*argv) -> int:
    with no_warnings():
        return main(["render", *map(str, argv)])


def test_api_under_a_client_equals_local(client):
    image = textured((6, 64, 64))
    lazy = da.from_array(image, chunks=(2, 32, 64))  # the API rechunks to whole planes
    rendered = labyrinth(lazy, tone_limits=(0, 65535), **API_OPTIONS)
    on_cluster = rendered.compute()
    local = labyrinth(image, tone_limits=(0, 65535), **API_OPTIONS)
    np.testing.assert_array_equal(on_cluster, local)
    np.testing.assert_array_equal(rendered.compute(scheduler="threads"), local)
    ran_on = client.run(lambda: "napari_labyrinth.core._kernel" in __import__("sys").modules)
    assert len(ran_on) == 2 and any(ran_on.values())  # the workers really rendered


def test_cli_with_a_scheduler_address(cluster, tmp_path, capsys):
    address = cluster.scheduler_address
    image = textured((6, 64, 64))
    store(tmp_path / "in.zarr", image, chunks=(1, 32, 32))
    expected = labyrinth(image, **API_OPTIONS)  # default tone limits: streamed on the cluster
    assert (
        render(tmp_path / "in.zarr", "-o", tmp_path / "out.zarr", "--scheduler", address, *OPTIONS)
        == 0
    )
    np.testing.assert_array_equal(read_image(tmp_path / "out.zarr"), expected)
    # TIFF output: the blocks come back here and are written plane by plane
    assert (
        render(tmp_path / "in.zarr", "-o", tmp_path / "out.tif", "--scheduler", address, *OPTIONS)
        == 0
    )
    np.testing.assert_array_equal(read_image(tmp_path / "out.tif"), expected)
    # TIFF input: the workers open the file themselves
    write_image(tmp_path / "in.tif", image)
    argv = [tmp_path / "in.tif", "-o", tmp_path / "stack.zarr", "--stack", "--passes", "2"]
    assert render(*argv, "--scheduler", address) == 0
    np.testing.assert_array_equal(
        read_image(tmp_path / "stack.zarr"), labyrinth_stack(image, passes=2)
    )
    captured = capsys.readouterr()
    assert error_lines(captured.err) == [] and "Traceback" not in captured.err
    assert distributed.client._get_global_client() is None  # the command closed its client
    assert [p.name for p in Path(tmp_path).rglob("*.tmp")] == []


def test_a_grey_alpha_tiff_on_a_scheduler_equals_its_render_in_memory(cluster, tmp_path):
    # its alpha was counted in the streamed tone limits (0 and 65535 here): 8173 of the
    # 16384 values differed from the rendering in memory
    tifffile = pytest.importorskip("tifffile")
    gc.collect()  # what earlier tests left for the collector warns here, not in render()
    grey = np.random.default_rng(5).integers(1000, 3000, (2, 64, 64), dtype=np.uint16)
    alpha = np.full(grey.shape, 65535, np.uint16)
    alpha[:, :8] = 0
    source = tmp_path / "ga.tif"
    tifffile.imwrite(source, np.stack([grey, alpha], -1), extrasamples=["unassalpha"])
    assert render(source, "-o", tmp_path / "memory.tif", "--passes", "1") == 0
    address = cluster.scheduler_address
    argv = [source, "-o", tmp_path / "cluster.tif", "--passes", "1", "--scheduler", address]
    assert render(*argv) == 0
    in_memory = read_image(tmp_path / "memory.tif")
    np.testing.assert_array_equal(read_image(tmp_path / "cluster.tif"), in_memory)
    np.testing.assert_array_equal(in_memory[..., 1], alpha)


def test_cli_starts_and_stops_its_own_local_cluster(tmp_path):
    before = children()
    image = textured((4, 48, 48), np.uint8)
    store(tmp_path / "in.zarr", image)
    assert (
        render(
            tmp_path / "in.zarr", "-o", tmp_path / "out.zarr", "--scheduler", "local:2", *OPTIONS
        )
        == 0
    )
    np.testing.assert_array_equal(
        read_image(tmp_path / "out.zarr"), labyrinth(image, **API_OPTIONS)
    )
    wait_for_exit(children() - before)
    assert children() - before == set()


def test_unreachable_scheduler_is_one_line(tmp_path, capsys, monkeypatch):
    monkeypatch.setattr(render_module, "SCHEDULER_TIMEOUT", 1)
    store(tmp_path / "in.zarr", textured((2, 16, 16), np.uint8))
    argv = [tmp_path / "in.zarr", "-o", tmp_path / "out.zarr", "--scheduler", "tcp://127.0.0.1:9"]
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # distributed may warn while it retries
        code = main(["render", *map(str, argv)])
    assert code == 1
    err = capsys.readouterr().err
    (line,) = error_lines(err)
    assert "--scheduler" in line and "127.0.0.1:9" in line and "Traceback" not in err
    assert os.listdir(tmp_path) == ["in.zarr"]


def test_a_failing_block_on_the_cluster_fails_only_its_file(cluster, tmp_path, capsys):
    good = textured((3, 32, 32))
    store(tmp_path / "good.zarr", good)
    store(tmp_path / "bad.zarr", good)
    (tmp_path / "bad.zarr" / "c" / "1" / "0" / "0").write_bytes(b"not zstd" * 10)
    argv = [tmp_path / "bad.zarr", tmp_path / "good.zarr", "-o", tmp_path / "out"]
    address = cluster.scheduler_address
    for limits in ([], ["--tone-limits", "0", "65535"]):  # fails in the scan, in the rendering
        assert render(*argv, "--scheduler", address, "--overwrite", *limits, *OPTIONS) == 1
        err = capsys.readouterr().err
        (line,) = error_lines(err)
        assert "bad.zarr" in line and "Zstd" in line and "Traceback" not in err
        assert [p.name for p in tmp_path.rglob("*.tmp")] == []
    assert os.listdir(tmp_path / "out") == ["good_labyrinth.zarr"]
    np.testing.assert_array_equal(
        read_image(tmp_path / "out" / "good_labyrinth.zarr"),
        labyrinth(good, tone_limits=(0, 65535), **API_OPTIONS),
    )
