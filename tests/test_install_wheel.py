"""An install as users make it: the built wheel in a fresh environment they cannot write to.

The sdist and the wheel built from it pass ``twine check``; the wheel goes into a new venv
(no system site-packages, no source tree) whose files are read-only to the user who runs it:
``nobody`` when the tests run as root, else the same user with the venv made read-only. The
command line renders a PNG and npe2 validates the plugin there. numba then keeps its kernels
in the user's cache directory (~/.cache/numba, numba's user-wide locator), and a second run
reuses them: faster, and no cache file added or rewritten. With no writable cache anywhere
(home, $XDG_CACHE_HOME and the install all read-only) the package still renders, and says so
in one warning.

One to two minutes (three cold processes compile the kernels), so it runs only where asked:
``make test-install`` or ``NAPARI_LABYRINTH_INSTALL_TESTS=1``.
"""

from __future__ import annotations

import importlib.util
import os
import pwd
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import imageio.v3 as iio
import numpy as np
import pytest
from skimage import data

ROOT = Path(__file__).resolve().parents[1]
TIMEOUT = 600

pytestmark = [
    pytest.mark.subprocess,
    pytest.mark.slow,
    pytest.mark.skipif(
        os.environ.get("NAPARI_LABYRINTH_INSTALL_TESTS") != "1",
        reason="builds and installs the wheel (1-2 min): make test-install",
    ),
    pytest.mark.skipif(not (ROOT / "pyproject.toml").exists(), reason="needs the source tree"),
]


def _uv() -> str | None:
    if importlib.util.find_spec("uv") is not None:
        from uv import find_uv_bin

        return find_uv_bin()
    return shutil.which("uv")


class Install:
    """The fresh environment, its user, and that user's home and working directory."""

    def __init__(self, base: Path):
        self.base = base
        self.dist = base / "dist"
        self.venv = base / "venv"
        self.home = base / "home"
        self.work = base / "work"
        self.no_home = base / "no-home"
        self.as_root = os.geteuid() == 0
        self.user = pwd.getpwnam("nobody") if self.as_root else pwd.getpwuid(os.getuid())

    @property
    def prefix(self) -> list[str]:
        if not self.as_root:
            return []
        return [
            "setpriv",
            f"--reuid={self.user.pw_uid}",
            f"--regid={self.user.pw_gid}",
            "--clear-groups",
            "--",
        ]

    def env(self, home: Path, **extra: str) -> dict[str, str]:
        """A user's environment: none of the test run's caches, paths or numba settings."""
        env = {
            "PATH": f"{self.venv / 'bin'}:/usr/local/bin:/usr/bin:/bin",
            "HOME": str(home),
            "USER": self.user.pw_name,
            "LANG": "C.UTF-8",
            "TMPDIR": str(self.work),
        }
        env.update({k: v for k, v in os.environ.items() if k.startswith("OPENBLAS_")})
        env.update(extra)
        return env

    def run(self, *args: str, home: Path | None = None, **extra: str):
        """Run a command of the venv as its user, in the working directory; timed."""
        start = time.perf_counter()
        result = subprocess.run(
            [*self.prefix, *args],
            cwd=self.work,
            env=self.env(home or self.home, **extra),
            capture_output=True,
            text=True,
            timeout=TIMEOUT,
        )
        result.seconds = time.perf_counter() - start
        assert result.returncode == 0, f"{args}: {result.stdout}\n{result.stderr}"
        return result

    def runnable_by_user(self, python: str) -> bool:
        """Whether the user reaches the interpreter's file (a Python started from a path it
        cannot reach may still run, on another prefix's standard library)."""
        for probe in (["test", "-x", python], [python, "-c", "import venv"]):
            try:
                found = subprocess.run(
                    [*self.prefix, *probe], capture_output=True, cwd="/", timeout=60
                )
            except OSError:
                return False
            if found.returncode != 0:
                return False
        return True

    def interpreter(self) -> str | None:
        """This Python, or another of the same version that the user can run (the venv
        links to it: pyenv's under /root is not)."""
        version = "python{}.{}".format(*sys.version_info[:2])
        candidates = [getattr(sys, "_base_executable", None), os.path.realpath(sys.executable)]
        candidates += [f"/usr/bin/{version}", f"/usr/local/bin/{version}", shutil.which(version)]
        for candidate in filter(None, candidates):
            if os.path.exists(candidate) and self.runnable_by_user(candidate):
                return candidate
        return None

    def files(self, where: Path) -> dict[str, tuple[int, int]]:
        return {
            str(p.relative_to(where)): (p.stat().st_mtime_ns, p.stat().st_size)
            for p in where.rglob("*")
            if p.is_file()
        }

    def site_packages(self) -> Path:
        (site,) = self.venv.glob("lib/python3*/site-packages")
        return site


def _chmod_tree(path: Path, writable: bool) -> None:
    mode = "u+w" if writable else "a-w"
    subprocess.run(["chmod", "-R", mode, str(path)], check=True)


@pytest.fixture(scope="module")
def install():
    if os.geteuid() == 0 and shutil.which("setpriv") is None:
        pytest.skip("running as root needs setpriv (util-linux) to run as nobody")
    base = Path(tempfile.mkdtemp(prefix="napari-labyrinth-install-"))
    base.chmod(0o755)
    env = Install(base)
    for directory in (env.home, env.work, env.no_home):
        directory.mkdir()
    if env.as_root:
        for directory in (env.home, env.work):
            os.chown(directory, env.user.pw_uid, env.user.pw_gid)
    env.no_home.chmod(0o555)
    try:
        yield env
    finally:
        if env.venv.exists():
            _chmod_tree(env.venv, writable=True)
        env.no_home.chmod(0o755)
        shutil.rmtree(base, ignore_errors=True)


@pytest.fixture(scope="module")
def dists(install):
    """The sdist, and the wheel built from it, in an isolated build as an index builds them."""
    uv = _uv()
    installer = ["--installer", "uv"] if uv else []
    build = subprocess.run(
        [sys.executable, "-m", "build", *installer, "--outdir", str(install.dist), str(ROOT)],
        capture_output=True,
        text=True,
        timeout=TIMEOUT,
        env=dict(os.environ, PATH=f"{Path(uv).parent}:{os.environ['PATH']}") if uv else None,
    )
    assert build.returncode == 0, build.stdout + build.stderr
    (sdist,) = install.dist.glob("napari_labyrinth-*.tar.gz")
    (wheel,) = install.dist.glob("napari_labyrinth-*.whl")
    return sdist, wheel


def test_sdist_and_wheel_pass_twine_check(dists):
    check = subprocess.run(
        [sys.executable, "-m", "twine", "check", "--strict", *map(str, dists)],
        capture_output=True,
        text=True,
        timeout=TIMEOUT,
    )
    assert check.returncode == 0, check.stdout + check.stderr
    assert check.stdout.count("PASSED") == 2, check.stdout


@pytest.fixture(scope="module")
def installed(install, dists):
    python = install.interpreter()
    if python is None:
        pytest.skip(f"no Python {sys.version_info[:2]} that {install.user.pw_name} can run")
    uv = _uv()
    if uv:
        subprocess.run([uv, "venv", "-q", "--python", python, str(install.venv)], check=True)
        command = [uv, "pip", "install", "-q", "--python", str(install.venv / "bin" / "python")]
    else:
        subprocess.run([python, "-m", "venv", str(install.venv)], check=True)
        command = [str(install.venv / "bin" / "python"), "-m", "pip", "install", "-q"]
    # npe2 is not a dependency: napari brings it; here it validates the manifest.
    result = subprocess.run(
        [*command, str(dists[1]), "npe2"], capture_output=True, text=True, timeout=TIMEOUT
    )
    assert result.returncode == 0, result.stdout + result.stderr
    _chmod_tree(install.venv, writable=False)
    # A small photograph: the kernels compile whatever the size.
    iio.imwrite(install.work / "input.png", data.camera()[::4, ::4])
    return install


def test_site_packages_is_read_only_to_the_user(installed):
    probe = installed.run(
        "python",
        "-c",
        "import os, sys, napari_labyrinth as p;"
        "d = os.path.dirname(p.__file__);"
        "print(d); print(os.access(d, os.W_OK)); print(os.getuid())",
    )
    where, writable, uid = probe.stdout.split()
    assert Path(where).is_relative_to(installed.site_packages())
    assert writable == "False"
    assert int(uid) == installed.user.pw_uid


def test_cli_renders_and_numba_caches_in_the_users_cache(installed):
    before = installed.files(installed.site_packages())
    cache = installed.home / ".cache" / "numba"

    cold = installed.run("napari-labyrinth", "render", "input.png", "-o", "cold/")
    installed.cold_stderr = cold.stderr
    assert (installed.work / "cold" / "input_labyrinth.png").is_file(), cold.stdout
    assert "cache" not in cold.stderr.lower(), cold.stderr
    cached = installed.files(cache) if cache.exists() else {}
    assert any(name.endswith(".nbc") for name in cached), (
        f"no kernel cached in {cache}: {sorted(installed.files(installed.home))}"
    )
    assert installed.files(installed.site_packages()) == before

    warm = installed.run("napari-labyrinth", "render", "input.png", "-o", "warm/")
    assert installed.files(cache) == cached, "the second run compiled again"
    assert warm.seconds < cold.seconds, (warm.seconds, cold.seconds)
    np.testing.assert_array_equal(
        iio.imread(installed.work / "warm" / "input_labyrinth.png"),
        iio.imread(installed.work / "cold" / "input_labyrinth.png"),
    )
    print(f"cold {cold.seconds:.1f} s, warm {warm.seconds:.1f} s, {len(cached)} cache files")


def test_cli_shows_its_user_no_warning(installed):
    """The first run after an install compiles the kernels: numba's own warnings stay out of
    the user's terminal."""
    stderr = getattr(installed, "cold_stderr", None)
    if stderr is None:
        pytest.skip("the first run did not complete")
    assert "Warning:" not in stderr, stderr


def test_npe2_validates_the_installed_plugin(installed):
    result = installed.run("npe2", "validate", "napari-labyrinth")
    assert "valid" in result.stdout, result.stdout + result.stderr


def test_no_writable_cache_anywhere_still_renders_with_one_warning(installed):
    result = installed.run(
        "napari-labyrinth",
        "render",
        "input.png",
        "-o",
        "uncached/",
        home=installed.no_home,
        XDG_CACHE_HOME=str(installed.no_home / "cache"),
    )
    assert (installed.work / "uncached" / "input_labyrinth.png").is_file(), result.stdout
    warnings = [line for line in result.stderr.splitlines() if "Warning:" in line]
    assert len([w for w in warnings if "cache" in w.lower()]) == 1, result.stderr
    assert not any(installed.no_home.iterdir())


# -- the platform wheel: the kernels compiled for this machine kind's CPU, inside ------------


@pytest.fixture(scope="module")
def platform_wheel(install):
    """This machine's platform wheel, built as ``make wheel`` builds it (the build hook on,
    from this environment, which holds the package's dependencies)."""
    out = install.base / "platform-dist"
    build = subprocess.run(
        [sys.executable, "-m", "build", "--wheel", "--no-isolation", "--outdir", str(out),
         str(ROOT)],
        capture_output=True, text=True, timeout=TIMEOUT,
        env=dict(os.environ, HATCH_BUILD_HOOK_ENABLE_CUSTOM="true"),
    )  # fmt: skip
    assert build.returncode == 0, build.stdout[-3000:] + build.stderr[-3000:]
    (wheel,) = out.glob("napari_labyrinth-*.whl")
    return wheel


def _names(wheel: Path) -> list[str]:
    import zipfile

    with zipfile.ZipFile(wheel) as archive:
        return archive.namelist()


def test_the_pure_wheel_and_the_sdist_carry_no_compiled_kernels(dists):
    import tarfile

    sdist, wheel = dists
    assert wheel.name.endswith("-py3-none-any.whl")
    assert not [name for name in _names(wheel) if "_compiled" in name or name.endswith(".nbc")]
    with tarfile.open(sdist) as archive:
        assert not [n for n in archive.getnames() if "_compiled" in n or n.endswith(".nbc")]


def test_the_platform_wheel_carries_the_kernels_tagged_for_this_python_and_platform(
    platform_wheel,
):
    import numba

    from napari_labyrinth.core._shipped import platform_key

    python = "cp{}{}".format(*sys.version_info[:2])
    assert f"-{python}-{python}-" in platform_wheel.name
    names = _names(platform_wheel)
    folder = f"napari_labyrinth/_compiled/{numba.__version__}/{platform_key()}/"
    assert folder + "target.json" in names
    assert sum(name.startswith(folder) and name.endswith(".nbc") for name in names) > 20
    assert not [name for name in names if name.endswith(".lock")]
    check = subprocess.run(
        [sys.executable, "-m", "twine", "check", "--strict", str(platform_wheel)],
        capture_output=True, text=True, timeout=TIMEOUT,
    )  # fmt: skip
    assert check.returncode == 0, check.stdout + check.stderr


@pytest.fixture(scope="module")
def platform_installed(install, platform_wheel):
    """The platform wheel in a second venv, read-only to its user, beside the pure one."""
    python = install.interpreter()
    if python is None:
        pytest.skip(f"no Python {sys.version_info[:2]} that {install.user.pw_name} can run")
    venv = install.base / "platform-venv"
    uv = _uv()
    if uv:
        subprocess.run([uv, "venv", "-q", "--python", python, str(venv)], check=True)
        command = [uv, "pip", "install", "-q", "--python", str(venv / "bin" / "python")]
    else:
        subprocess.run([python, "-m", "venv", str(venv)], check=True)
        command = [str(venv / "bin" / "python"), "-m", "pip", "install", "-q"]
    result = subprocess.run(
        [*command, str(platform_wheel)], capture_output=True, text=True, timeout=TIMEOUT
    )
    assert result.returncode == 0, result.stdout + result.stderr
    _chmod_tree(venv, writable=False)
    if not (install.work / "input.png").exists():
        iio.imwrite(install.work / "input.png", data.camera()[::4, ::4])
    try:
        yield venv
    finally:
        _chmod_tree(venv, writable=True)


def test_from_the_platform_wheel_the_cli_compiles_nothing_and_writes_no_cache(
    install, platform_installed
):
    home = install.base / "platform-home"
    home.mkdir()
    if install.as_root:
        os.chown(home, install.user.pw_uid, install.user.pw_gid)
    log = install.work / "platform-compiled.tsv"
    bin_path = f"{platform_installed / 'bin'}:/usr/local/bin:/usr/bin:/bin"
    result = install.run(
        "napari-labyrinth", "render", "input.png", "-o", "platform/", home=home,
        PATH=bin_path, NAPARI_LABYRINTH_COMPILE_LOG=str(log),
    )  # fmt: skip
    assert (install.work / "platform" / "input_labyrinth.png").is_file(), result.stdout
    assert not log.exists() or log.read_text() == "", log.read_text()
    assert "Warning" not in result.stderr, result.stderr
    # numba makes its cache folder as it enables caching (a probe), but nothing is written in it
    assert not [path for path in home.rglob("*") if path.is_file()], sorted(home.rglob("*"))
    needed = install.run(
        "python", "-c", "from napari_labyrinth import _warmup; print(_warmup.needed())",
        home=home, PATH=bin_path,
    )  # fmt: skip
    assert needed.stdout.strip() == "False"  # the widget starts no warm-up process
    jit = install.run(
        "napari-labyrinth", "render", "input.png", "-o", "platform-jit/", home=home,
        PATH=bin_path, NAPARI_LABYRINTH_SHIPPED_KERNELS="0",
    )  # fmt: skip
    assert "NAPARI_LABYRINTH_SHIPPED_KERNELS=0 turns them off" in jit.stderr, jit.stderr
    np.testing.assert_array_equal(
        iio.imread(install.work / "platform" / "input_labyrinth.png"),
        iio.imread(install.work / "platform-jit" / "input_labyrinth.png"),
    )
