"""The shipped kernels: loaded where they may be, numba's JIT everywhere else, bit for bit.

A copy of the package is given shipped kernels the way the platform wheel's build makes
them (``NAPARI_LABYRINTH_COMPILE_INTO``, numba told the target CPU), for two kernels of two
files: ``core._kernel.stream_key`` and ``metrics._kernels.reductions.edge_sums``. Each
test runs that copy in new processes with an empty numba cache and notes what numba
compiles there (``NAPARI_LABYRINTH_COMPILE_LOG``, a file of the test's own: these tests
compile on purpose, and the suite's count of compiled kernels leaves them out).
"""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

import numba
import pytest

import napari_labyrinth
from napari_labyrinth.core import _shipped

pytestmark = [
    pytest.mark.subprocess,
    pytest.mark.skipif(_shipped.machine() not in _shipped.TARGETS, reason="no target CPU here"),
]

PACKAGE = Path(napari_labyrinth.__file__).resolve().parent

#: The calls of a child process: the two kernels, with results that show any difference.
CALLS = """
import hashlib, json, sys
import numpy as np
from napari_labyrinth.core import _shipped
from napari_labyrinth.core._kernel import stream_key
from napari_labyrinth.metrics._kernels.reductions import edge_sums

rng = np.random.default_rng(5)
after, before, edges = (rng.random((40, 33)) * 255 for _ in range(3))
sums = np.zeros((40, 5))
edge_sums(after, before, edges, 1.25, 0.75, sums, 0, 40)
print("RESULT " + json.dumps({
    "key": int(stream_key(7, 2, 3)),
    "sums": hashlib.sha256(sums.tobytes()).hexdigest(),
    "refused": _shipped.shipped().refused,
}))
"""


def _fresh(prefix: str) -> Path:
    """A new directory others may read (``nobody`` runs some children)."""
    path = Path(tempfile.mkdtemp(prefix=prefix))
    path.chmod(0o755)
    return path


def _copy_package(site: Path) -> Path:
    target = site / "napari_labyrinth"
    shutil.copytree(
        PACKAGE, target, ignore=shutil.ignore_patterns("__pycache__", "_compiled", "*.nbi", "*.nbc")
    )
    return target


def _env(site: Path, log: Path, cache: Path | None, **extra: str) -> dict[str, str]:
    env = {
        key: value
        for key, value in os.environ.items()
        if not key.startswith(("NUMBA_", "NAPARI_LABYRINTH_", "PYTEST_"))
    }
    env.update(PYTHONPATH=str(site), NAPARI_LABYRINTH_COMPILE_LOG=str(log))
    if cache is not None:
        env["NUMBA_CACHE_DIR"] = str(cache)
    env.update(extra)
    return env


class Child:
    """What a child process printed, compiled and warned."""

    def __init__(self, done: subprocess.CompletedProcess, log: Path):
        assert done.returncode == 0, done.stderr
        (line,) = [line for line in done.stdout.splitlines() if line.startswith("RESULT ")]
        self.result = json.loads(line[len("RESULT ") :])
        self.values = (self.result["key"], self.result["sums"])
        self.compiled = [line.split("\t")[0] for line in log.read_text().splitlines()] if (
            log.exists()) else []  # fmt: skip
        self.stderr = done.stderr


def _run(site: Path, *, before: str = "", cache: bool = True, prefix=(), **extra) -> Child:
    scratch = _fresh("shipped-child-")
    log = scratch / "compiled.tsv"
    try:
        done = subprocess.run(
            [*prefix, sys.executable, "-c", before + CALLS],
            env=_env(site, log, scratch / "numba" if cache else None, **extra),
            capture_output=True, text=True, timeout=300, cwd=scratch, check=False,
        )  # fmt: skip
        return Child(done, log)
    finally:
        shutil.rmtree(scratch, ignore_errors=True)


@pytest.fixture(scope="module")
def site():
    """A copy of the package carrying shipped kernels of the two calls, as a build makes them."""
    base = _fresh("shipped-site-")
    try:
        site = base / "site"
        site.mkdir()
        package = _copy_package(site)
        build = base / "build"
        target = _shipped.TARGETS[_shipped.machine()].cpu
        built = _run(
            site, NUMBA_CPU_NAME=target, NUMBA_CPU_FEATURES="", NUMBA_DISABLE_INTEL_SVML="1",
            NAPARI_LABYRINTH_COMPILE_INTO=str(build),
        )  # fmt: skip
        assert sorted(built.compiled) == ["edge_sums", "stream_key"]
        shutil.copytree(build, package / "_compiled")
        yield site
    finally:
        shutil.rmtree(base, ignore_errors=True)


@pytest.fixture(scope="module")
def jit(site):
    """The two calls compiled by numba for this machine (the shipped kernels off)."""
    return _run(site, NAPARI_LABYRINTH_SHIPPED_KERNELS="0")


def _variant(site: Path, change) -> Path:
    """Another copy of ``site`` with ``change(package)`` made to it."""
    other = _fresh("shipped-variant-") / "site"
    shutil.copytree(site, other)
    change(other / "napari_labyrinth")
    return other


def _warnings(child: Child, category: str) -> list[str]:
    return [line for line in child.stderr.splitlines() if category in line]


def test_the_build_lays_out_the_kernels_by_numba_version_platform_and_module(site):
    folder = site / "napari_labyrinth" / "_compiled" / numba.__version__ / _shipped.platform_key()
    manifest = json.loads((folder / "target.json").read_text())
    assert manifest["cpu"] == _shipped.TARGETS[_shipped.machine()].cpu
    assert manifest["numba"] == numba.__version__
    assert {p.parent.relative_to(folder).as_posix() for p in folder.rglob("*.nbc")} == {
        "core",
        "metrics/_kernels",
    }


def test_shipped_kernels_load_compile_nothing_and_match_the_jit(site, jit):
    shipped = _run(site)
    assert shipped.result["refused"] is None
    assert shipped.compiled == []
    assert shipped.values == jit.values
    assert sorted(jit.compiled) == ["edge_sums", "stream_key"]
    assert "Warning" not in shipped.stderr


def test_the_switch_turns_them_off_and_the_first_compile_says_so_once(jit):
    (warning,) = _warnings(jit, "CompilingKernelsWarning")
    assert "NAPARI_LABYRINTH_SHIPPED_KERNELS=0 turns them off" in warning


def test_a_cpu_lacking_features_of_the_target_compiles_and_says_which(site, jit):
    if not _shipped.TARGETS[_shipped.machine()].features:
        pytest.skip("this machine kind's target has no features to lack")
    lacking = (
        "from napari_labyrinth.core import _shipped as s\n"
        "s._host_features = lambda: {'sse', 'sse2', 'avx'}\n"
    )
    child = _run(site, before=lacking)
    assert sorted(child.compiled) == ["edge_sums", "stream_key"]
    assert child.values == jit.values
    (warning,) = _warnings(child, "CompilingKernelsWarning")
    assert "this CPU lacks" in warning and "avx2" in warning and "fma" in warning


def test_a_cpu_named_by_the_user_gets_kernels_compiled_for_it(site, jit):
    child = _run(site, NUMBA_CPU_NAME="generic")
    assert sorted(child.compiled) == ["edge_sums", "stream_key"]
    assert child.values == jit.values
    (warning,) = _warnings(child, "CompilingKernelsWarning")
    assert "NUMBA_CPU_NAME is set ('generic')" in warning


def test_kernels_of_another_numba_version_are_not_loaded(site, jit):
    def renamed(package):
        (package / "_compiled" / numba.__version__).rename(package / "_compiled" / "0.0.1")

    child = _run(_variant(site, renamed))
    assert sorted(child.compiled) == ["edge_sums", "stream_key"]
    assert child.values == jit.values
    (warning,) = _warnings(child, "CompilingKernelsWarning")
    assert f"compiled for numba 0.0.1; this is numba {numba.__version__}" in warning


def test_an_edited_source_file_compiles_only_the_kernels_that_read_it(site, jit):
    def edited(package):
        with open(package / "metrics" / "_kernels" / "reductions.py", "a") as source:
            source.write("\n# an edit\n")

    child = _run(_variant(site, edited))
    assert child.compiled == ["edge_sums"]  # stream_key's files are unchanged: shipped
    assert child.values == jit.values
    assert "Warning" not in child.stderr


def test_an_install_elsewhere_loads_them(site, jit):
    """The stamps name files relative to the package: another folder matches."""
    child = _run(_variant(site, lambda package: None))
    assert child.compiled == []
    assert child.values == jit.values


def test_two_processes_load_the_shipped_kernels_at_once(site, jit):
    scratch = [_fresh("shipped-pair-") for _ in range(2)]
    logs = [folder / "compiled.tsv" for folder in scratch]
    try:
        processes = [
            subprocess.Popen(
                [sys.executable, "-c", CALLS], env=_env(site, log, folder / "numba"),
                stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, cwd=folder,
            )  # fmt: skip
            for folder, log in zip(scratch, logs, strict=True)
        ]
        children = []
        for process, log in zip(processes, logs, strict=True):
            out, err = process.communicate(timeout=300)
            done = subprocess.CompletedProcess(process.args, process.returncode, out, err)
            children.append(Child(done, log))
    finally:
        for folder in scratch:
            shutil.rmtree(folder, ignore_errors=True)
    assert [child.compiled for child in children] == [[], []]
    assert [child.values for child in children] == [jit.values, jit.values]


#: Runs a command with two folders ("$0", "$1") mounted read-only for it, root included.
_READ_ONLY_MOUNTS = (
    'for d in "$0" "$1"; do mount --bind "$d" "$d" && mount -o remount,bind,ro "$d" || exit 97;'
    ' done; shift; exec "$@"'
)


def _read_only(site: Path) -> tuple[list[str], dict[str, str]]:
    """A command prefix and variables under which ``site`` and the user's home (so every
    cache folder numba looks for) are read-only: made so for another user, or, for root,
    who writes anyway, mounted read-only in a mount namespace of the child's own."""
    home = _fresh("shipped-no-home-")
    variables = {"HOME": str(home), "XDG_CACHE_HOME": str(home / "cache")}
    if os.geteuid() != 0:
        subprocess.run(["chmod", "-R", "a-w", str(site), str(home)], check=True)
        return [], variables
    prefix = ["unshare", "--mount", "--", "sh", "-c", _READ_ONLY_MOUNTS, str(site), str(home)]
    probe = subprocess.run([*prefix, "touch", str(home / "probe")], capture_output=True)
    if probe.returncode != 1 or (home / "probe").exists():
        pytest.skip("root here cannot mount folders read-only (unshare --mount)")
    return prefix, variables


def _files(where: Path) -> dict[str, tuple[int, int]]:
    return {
        str(p.relative_to(where)): (p.stat().st_mtime_ns, p.stat().st_size)
        for p in where.rglob("*")
        if p.is_file()
    }


def test_a_read_only_install_with_no_writable_cache_loads_them_and_writes_nothing(site, jit):
    other = _variant(site, lambda package: None)
    before = _files(other)
    prefix, variables = _read_only(other)
    try:
        child = _run(other, cache=False, prefix=prefix, **variables)
        fallback = _run(other, cache=False, prefix=prefix, NAPARI_LABYRINTH_SHIPPED_KERNELS="0",
                        **variables)  # fmt: skip
    finally:
        subprocess.run(["chmod", "-R", "u+w", str(other)], check=True)
    assert child.compiled == []
    assert child.values == jit.values
    assert "Warning" not in child.stderr
    assert sorted(fallback.compiled) == ["edge_sums", "stream_key"]
    assert fallback.values == jit.values
    assert len(_warnings(fallback, "UncachedKernelWarning")) == 1  # compiled in memory, once
    assert len(_warnings(fallback, "CompilingKernelsWarning")) == 1
    assert _files(other) == before
