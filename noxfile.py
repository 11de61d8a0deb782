"""The environments napari-labyrinth claims, each tested from the built wheel.

The sdist is built once per run and the wheel from it (as a package index builds it); every
session installs that wheel (not editable) with one napari, one Qt binding and the test extra
into a fresh environment, then runs the viewer tests (tests/_qt) and the command-line tests
(tests/cli) from the sdist's tests/, outside the source tree and without src/, so that they
import the installed package. Each session ends with one summary line: environment, versions,
passed / failed, duration; the lines are also kept in build/nox/summary/.

    make test-matrix               # every session, the Debian packages Qt needs, the install test
    .venv/bin/nox -l               # the sessions
    .venv/bin/nox -s napari-latest-pyside6

Environments live in build/nox/envs and are made again on every run (uv's cache makes that
quick). The interpreters are looked for on PATH, then among pyenv's versions.
"""

from __future__ import annotations

import fcntl
import importlib.util
import json
import os
import shutil
import subprocess
import sys
import tarfile
import time
import xml.etree.ElementTree as ET
from pathlib import Path

import nox
import nox.command
from packaging.requirements import Requirement

nox.needs_version = ">=2025.2.9"

ROOT = Path(__file__).resolve().parent
WORK = ROOT / "build" / "nox"
SUMMARY = WORK / "summary"

nox.options.envdir = str(WORK / "envs")
nox.options.default_venv_backend = "uv|virtualenv"
nox.options.error_on_missing_interpreters = True

#: name: (Python, napari, Qt binding (qtpy's QT_API), other pins).
#: "oldest" also resolves the package's dependencies and the test extra to the lowest versions
#: pyproject.toml allows.
MATRIX = {
    "napari-0.5-pyqt5": ("3.11", "napari==0.5.*", "pyqt5", []),
    "napari-0.6-pyqt6": ("3.12", "napari==0.6.*", "pyqt6", []),
    "napari-latest-pyqt6": ("3.13", "napari", "pyqt6", []),
    "napari-latest-pyside6": ("3.12", "napari", "pyside6", []),
    "oldest-numpy-1.26": ("3.11", "napari==0.5.0", "pyqt5", ["numpy==1.26.*"]),
}
LOWEST_DIRECT = {"oldest-numpy-1.26"}

#: The distribution of each binding. PyQt5 5.15 is the first with wheels for Python 3.10.
BINDINGS = {"pyqt5": "PyQt5>=5.15.9", "pyqt6": "PyQt6", "pyside6": "PySide6"}

TEST_DIRS = ["tests/_qt", "tests/cli"]

_VERSIONS = r"""
import json, sys, importlib.metadata as md
import numpy, numba, napari, qtpy
import napari_labyrinth
binding = {"pyqt5": "PyQt5", "pyqt6": "PyQt6", "pyside6": "PySide6"}[qtpy.API]
json.dump({
    "python": ".".join(map(str, sys.version_info[:3])),
    "napari": napari.__version__,
    "binding": binding + " " + md.version(binding),
    "qt": qtpy.QT_VERSION,
    "numpy": numpy.__version__,
    "numba": numba.__version__,
    "package": napari_labyrinth.__file__,
}, open(sys.argv[1], "w"))
"""

_dist: dict = {}


def _interpreter(version: str) -> str:
    """The path of a working python{version}: on PATH, else the newest of pyenv's."""
    candidates = [shutil.which(f"python{version}")]
    pyenv = Path(os.environ.get("PYENV_ROOT", Path.home() / ".pyenv")) / "versions"
    candidates += sorted(pyenv.glob(f"{version}.*/bin/python{version}"), reverse=True)
    for candidate in filter(None, candidates):
        try:
            found = subprocess.run(
                [str(candidate), "-c", "import sys; print('%d.%d' % sys.version_info[:2])"],
                capture_output=True,
                text=True,
                timeout=60,
            )
        except OSError:
            continue
        if found.returncode == 0 and found.stdout.strip() == version:
            return str(candidate)
    return version  # nox reports the interpreter missing


def _test_requirements() -> list[str]:
    """The test extra without napari: each session names its own napari and binding."""
    extra = nox.project.load_toml(ROOT / "pyproject.toml")["project"]["optional-dependencies"]
    return [r for r in extra["test"] if Requirement(r).name != "napari"]


def _source(session: nox.Session) -> Path:
    """The tree to build: the working tree, or the commit NAPARI_LABYRINTH_MATRIX_REF names
    (a tree others edit meanwhile may hold their unfinished changes)."""
    ref = os.environ.get("NAPARI_LABYRINTH_MATRIX_REF")
    if not ref:
        return ROOT
    tree = WORK / "source"
    shutil.rmtree(tree, ignore_errors=True)
    tree.mkdir(parents=True)
    archive = subprocess.run(
        ["git", "-C", str(ROOT), "archive", ref], capture_output=True, check=True
    ).stdout
    subprocess.run(["tar", "-x", "-C", str(tree)], input=archive, check=True)
    commit = subprocess.run(
        ["git", "-C", str(ROOT), "rev-parse", "--short", ref], capture_output=True, text=True
    ).stdout.strip()
    session.log(f"building {ref} ({commit})")
    return tree


def _built_wheel(session: nox.Session) -> Path:
    """The sdist, and the wheel built from it, once per run (build/nox/dist); the sdist
    unpacked for its tests."""
    if "wheel" not in _dist:
        out = WORK / "dist"
        shutil.rmtree(out, ignore_errors=True)
        source = _source(session)
        if importlib.util.find_spec("build") is not None:
            session.run(
                sys.executable,
                "-m",
                "build",
                "--outdir",
                str(out),
                str(source),
                external=True,
                silent=True,
            )
        else:
            session.install("build")
            session.run("python", "-m", "build", "--outdir", str(out), str(source), silent=True)
        (_dist["wheel"],) = out.glob("napari_labyrinth-*.whl")
        (_dist["sdist"],) = out.glob("napari_labyrinth-*.tar.gz")
        # The tests of the same moment as the wheel: the sdist's (the tree may change meanwhile).
        with tarfile.open(_dist["sdist"]) as sdist:
            sdist.extractall(out / "sdist", filter="data")
        (_dist["tree"],) = (out / "sdist").iterdir()
        session.log(f"built {_dist['sdist'].name} and, from it, {_dist['wheel'].name}")
    return _dist["wheel"]


def _junit_outcomes(path: Path) -> tuple[dict[str, int], list[str]]:
    """passed / failed / skipped per test id (a test failing and erroring in teardown once)."""
    outcomes: dict[str, str] = {}
    for case in ET.parse(path).getroot().iter("testcase"):
        test = f"{case.get('classname')}::{case.get('name')}"
        if case.find("failure") is not None or case.find("error") is not None:
            outcomes[test] = "failed"
        elif case.find("skipped") is not None:
            outcomes.setdefault(test, "skipped")
        else:
            outcomes.setdefault(test, "passed")
    counts = {k: list(outcomes.values()).count(k) for k in ("passed", "failed", "skipped")}
    return counts, [t for t, outcome in outcomes.items() if outcome == "failed"]


def _lock() -> None:
    """One run at a time: sessions share build/nox (the wheel, the summaries)."""
    if "lock" in _dist:
        return
    WORK.mkdir(parents=True, exist_ok=True)
    handle = open(WORK / ".lock", "w")  # noqa: SIM115 - held for the whole run
    try:
        fcntl.flock(handle, fcntl.LOCK_EX | fcntl.LOCK_NB)
    except BlockingIOError:
        raise SystemExit(f"another nox run is using {WORK}") from None
    _dist["lock"] = handle


def _matrix_session(session: nox.Session, name: str) -> None:
    _lock()
    start = time.monotonic()
    _python, napari, api, pins = MATRIX[name]
    wheel = _built_wheel(session)
    resolution = []
    if name in LOWEST_DIRECT and session.venv_backend == "uv":
        # The package's own dependencies named too: lowest-direct lowers only those named.
        project = nox.project.load_toml(ROOT / "pyproject.toml")["project"]
        resolution = ["--resolution", "lowest-direct", *project["dependencies"]]
    session.install(*resolution, str(wheel), napari, BINDINGS[api], *pins, *_test_requirements())

    # The sdist's tests, without its src/: nothing can import anything but the wheel.
    run_dir = Path(session.create_tmp()) / "run"
    shutil.rmtree(run_dir, ignore_errors=True)
    tree = _dist["tree"]
    shutil.copytree(
        tree / "tests", run_dir / "tests", ignore=shutil.ignore_patterns("__pycache__", "*.pyc")
    )
    shutil.copy2(tree / "pyproject.toml", run_dir / "pyproject.toml")
    session.chdir(run_dir)
    env = {"QT_API": api, "PYTEST_QT_API": api}

    versions_file = run_dir / "versions.json"
    session.run("python", "-c", _VERSIONS, str(versions_file), env=env, silent=True)
    versions = json.loads(versions_file.read_text())
    if not Path(versions["package"]).is_relative_to(session.virtualenv.location):
        session.error(f"napari_labyrinth imported from {versions['package']}, not the wheel")

    junit = run_dir / "junit.xml"
    # session.run returns True, not the exit code: a code other than 0 raises, and says it.
    try:
        session.run(
            "python",
            "-m",
            "pytest",
            *TEST_DIRS,
            "-p",
            "no:cacheprovider",
            "-q",
            "--rootdir",
            str(run_dir),
            f"--junitxml={junit}",
            "-o",
            "junit_family=xunit2",
            *session.posargs,
            env=env,
        )
        code = 0
    except nox.command.CommandFailed as failure:  # the summary line says what happened
        code = failure.return_code
    if junit.exists():
        counts, failed = _junit_outcomes(junit)
        result = f"{counts['passed']} passed, {counts['failed']} failed, "
        result += f"{counts['skipped']} skipped"
    else:
        failed, result = [], f"pytest exited {code} without a report"
    line = (
        f"{name}: Python {versions['python']}, napari {versions['napari']}, "
        f"{versions['binding']} (Qt {versions['qt']}), numpy {versions['numpy']}, "
        f"numba {versions['numba']}: {result} ({time.monotonic() - start:.0f} s)"
    )
    SUMMARY.mkdir(parents=True, exist_ok=True)
    (SUMMARY / f"{name}.txt").write_text(line + "\n")
    (SUMMARY / f"{name}.failed.txt").write_text("".join(f"{t}\n" for t in failed))
    for test in failed:
        print(f"FAILED {test}", flush=True)
    print(line, flush=True)
    if code != 0 or failed:
        session.error(f"pytest exited {code}: {len(failed)} failed")


def _define(name: str, python: str):
    @nox.session(name=name, python=_interpreter(python))
    def matrix(session: nox.Session) -> None:
        _matrix_session(session, name)

    matrix.__doc__ = f"{name}: the built wheel's viewer and CLI tests"
    return matrix


for _name, (_python, *_rest) in MATRIX.items():
    globals()[_name.replace("-", "_").replace(".", "_")] = _define(_name, _python)
