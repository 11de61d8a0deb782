"""The platform wheel's build hook: numba's compiled kernels for a portable CPU, in the wheel.

Off by default: ``python -m build`` makes the pure ``py3-none-any`` wheel, whose
kernels numba compiles on the user's machine. With ``HATCH_BUILD_HOOK_ENABLE_CUSTOM=true``
(``make wheel``, the release workflow) the wheel also carries every kernel a user's
calls need, compiled for this machine kind's target CPU
(``napari_labyrinth.core._shipped.TARGETS``), under ``napari_labyrinth/_compiled/``:

1. ``python -m napari_labyrinth._warmup --all`` runs the source tree's package with
   ``NUMBA_CPU_NAME`` set to the target, an empty ``NUMBA_CPU_FEATURES``, numba's
   SVML off (its library is not on every user's machine) and
   ``NAPARI_LABYRINTH_COMPILE_INTO`` naming a folder of this build, where every kernel
   is saved;
2. that folder's index and data files and its manifest go into the wheel;
3. the wheel is tagged for this CPython and platform (see :func:`wheel_tag`).

The build needs the package's dependencies in the Python that builds it (build with
``--no-isolation`` from an environment that has them, or name one in
``NAPARI_LABYRINTH_BUILD_PYTHON``) and a CPU with every feature of the target: the
workload runs the kernels it compiles.
"""

from __future__ import annotations

import os
import platform
import shutil
import subprocess
import sys
import sysconfig
from pathlib import Path

from hatchling.builders.hooks.plugin.interface import BuildHookInterface

#: The files of numba's cache (index, data) and the manifest that go into the wheel.
SHIPPED_SUFFIXES = (".nbi", ".nbc", ".json")


def wheel_tag() -> str:
    """``cpXY-cpXY-<platform>``: the kernels are files of this CPython's minor version
    (numba names them so and keys them by its bytecode) and call its C API, so the
    interpreter and ABI tags are this one's. They are object code the process's numba
    links itself, no shared library of their own, so they ask of a Linux system only
    what numba's and llvmlite's wheels ask: the oldest manylinux tag those are built for
    (``manylinux_2_17``, manylinux2014). On macOS the machine's own architecture (the
    kernels are compiled for one; a python.org interpreter calls itself ``universal2``),
    from the first macOS of that architecture numba supports. Elsewhere the interpreter's
    platform tag."""
    python = f"cp{sys.version_info[0]}{sys.version_info[1]}"
    machine = platform.machine().lower()
    if sys.platform.startswith("linux"):
        plat = f"manylinux_2_17_{machine}.manylinux2014_{machine}"
    elif sys.platform == "darwin":  # the machine's own: an interpreter may say universal2
        plat = "macosx_11_0_arm64" if machine == "arm64" else f"macosx_10_15_{machine}"
    else:
        plat = sysconfig.get_platform().replace("-", "_").replace(".", "_")
    return f"{python}-{python}-{plat}"


class CompiledKernelsHook(BuildHookInterface):
    """Compile the kernels for the target CPU and put them into the wheel."""

    PLUGIN_NAME = "custom"

    def initialize(self, version: str, build_data: dict) -> None:
        if self.target_name != "wheel" or version == "editable":
            return
        python = os.environ.get("NAPARI_LABYRINTH_BUILD_PYTHON", sys.executable)
        root = Path(self.root)
        work = root / "build" / "kernels"
        shutil.rmtree(work, ignore_errors=True)
        work.mkdir(parents=True)
        compiled = work / "compiled"
        env = dict(os.environ)
        env["PYTHONPATH"] = os.pathsep.join(filter(None, [str(root / "src"), env.get("PYTHONPATH")]))
        target = self._target_cpu(python, env)
        env.update(
            NUMBA_CPU_NAME=target,
            NUMBA_CPU_FEATURES="",
            NUMBA_DISABLE_INTEL_SVML="1",
            NUMBA_CACHE_DIR=str(work / "numba-cache"),  # kernels outside the package
            NAPARI_LABYRINTH_COMPILE_INTO=str(compiled),
            NAPARI_LABYRINTH_NO_WARMUP="1",
        )
        env.pop("NAPARI_LABYRINTH_SHIPPED_KERNELS", None)
        self.app.display_info(f"compiling the kernels for {target} (a few minutes)")
        subprocess.run(
            [python, "-m", "napari_labyrinth._warmup", "--all"], env=env, cwd=work,
            check=True,
        )  # fmt: skip
        shipped = work / "_compiled"
        for path in compiled.rglob("*"):
            if path.is_file() and path.suffix in SHIPPED_SUFFIXES:
                destination = shipped / path.relative_to(compiled)
                destination.parent.mkdir(parents=True, exist_ok=True)
                shutil.copy2(path, destination)
        if not any(shipped.rglob("*.nbc")):
            raise RuntimeError(f"no kernel was compiled into {compiled}")
        build_data["force_include"][str(shipped)] = "napari_labyrinth/_compiled"
        build_data["pure_python"] = False
        build_data["tag"] = wheel_tag()

    def _target_cpu(self, python: str, env: dict) -> str:
        """The target CPU of this machine kind, as the source tree's package names it."""
        program = (
            "from napari_labyrinth.core._shipped import TARGETS, machine\n"
            "print(TARGETS[machine()].cpu)"
        )
        try:
            done = subprocess.run(
                [python, "-c", program], env=env, check=True, capture_output=True, text=True
            )
        except subprocess.CalledProcessError as error:
            raise RuntimeError(
                f"{python} cannot name the target CPU (are the package's dependencies "
                f"installed there? build with --no-isolation):\n{error.stderr}"
            ) from error
        return done.stdout.strip()
