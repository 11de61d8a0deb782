"""The kernels a platform wheel carries, compiled by numba for a portable CPU target.

A platform wheel holds numba's own cache files of every kernel, compiled for one
CPU model per machine kind (:data:`TARGETS`) under
``napari_labyrinth/_compiled/<numba version>/<platform>/`` beside a manifest
(``target.json``) naming the numba, Python, target triple, CPU and its features.
:mod:`._jit` looks there before numba's own cache, and loads a kernel from there
only when all of these hold:

- the user did not turn them off (:data:`SWITCH` set to ``0``);
- the folder of this numba version and this platform exists (the pure
  ``py3-none-any`` wheel, the sdist and a source checkout carry none);
- the manifest's Python and target triple are this process's;
- the user set neither ``NUMBA_CPU_NAME`` nor ``NUMBA_CPU_FEATURES`` (then the
  kernels are to be compiled for the CPU the user names);
- this CPU has every feature of the target (as numba reads them, so numba's
  ``NUMBA_ENABLE_AVX`` counts).

Elsewhere numba compiles the kernels and keeps them in its cache as it would
without this module, and the package says once, at the first compile, which of
these failed: a :class:`CompilingKernelsWarning` where the install carries
kernels, a line of the ``napari_labyrinth.kernels`` log where it carries none.

:class:`ShippedCache` is a numba cache of that layout: a kernel's shipped files are
current while the contents of its source file and of the files of the helpers it
calls are those it was compiled from (:func:`._kernel_sources.source_digest`, of
paths relative to the package): a wheel installed anywhere matches, and an edited
file compiles only the kernels that read it. The index key of each entry holds the
target's CPU and features where numba's own holds the host's; loading asks for
that key. :class:`ShippedFirst` puts it before numba's own cache of a kernel.

The build (``hatch_build.py``) runs ``python -m napari_labyrinth._warmup --all``
with :data:`COMPILE_INTO` naming an empty folder and numba told the target
(``NUMBA_CPU_NAME`` and an empty ``NUMBA_CPU_FEATURES``): every kernel numba
compiles then is saved there in the shipped layout (:func:`build_folder`).
"""

from __future__ import annotations

import functools
import json
import logging
import os
import platform
import sys
import warnings
from pathlib import Path
from typing import NamedTuple

import numba
from numba.core import config
from numba.core.caching import Cache, CompileResultCacheImpl, NullCache, _CacheLocator

from ._kernel_sources import source_digest

#: Set to ``0`` (or ``off``, ``no``, ``false``) to leave the shipped kernels unused: numba
#: compiles every kernel and keeps it in its own cache, as in an install that carries none.
SWITCH = "NAPARI_LABYRINTH_SHIPPED_KERNELS"

#: Set by the build to a folder: every kernel compiled in the process is saved there, in the
#: layout a wheel carries, instead of numba's own cache.
COMPILE_INTO = "NAPARI_LABYRINTH_COMPILE_INTO"

#: The folder of the package that holds the shipped kernels.
PACKAGE = Path(__file__).resolve().parents[1]
COMPILED = PACKAGE / "_compiled"

#: The file beside the kernels that says what they were compiled for.
MANIFEST = "target.json"

_log = logging.getLogger("napari_labyrinth.kernels")


class Target(NamedTuple):
    """A CPU model numba compiles the shipped kernels for, and what a host needs to run them.

    Attributes
    ----------
    cpu : str
        LLVM's name of the CPU model (``NUMBA_CPU_NAME`` at the build).
    features : tuple of str
        LLVM's names of the features that model has, every one of which a host must have.
    why : str
        Why this model.
    """

    cpu: str
    features: tuple[str, ...]
    why: str


#: The x86-64 micro-architecture levels of the psABI, in LLVM's feature names.
_X86_64_V2 = ("cmov", "cx8", "fxsr", "mmx", "sse", "sse2", "cx16", "sahf", "popcnt", "sse3",
              "sse4.1", "sse4.2", "ssse3")  # fmt: skip
_X86_64_V3 = (*_X86_64_V2, "avx", "avx2", "bmi", "bmi2", "f16c", "fma", "lzcnt", "movbe", "xsave")

#: The target of each machine kind (``platform.machine()``, lower case, x86 spellings as one).
TARGETS = {
    "x86_64": Target(
        "x86-64-v3",
        _X86_64_V3,
        "AVX2 and FMA (Intel since 2013, AMD since 2015), which the metrics' loops use: as fast "
        "as code compiled for the host (docs/performance.md), where x86-64-v2 is not",
    ),
    "arm64": Target(
        "apple-m1",
        (),
        "macOS on arm64 runs on Apple silicon only, every chip of which has the M1's features",
    ),
    "aarch64": Target(
        "generic",
        (),
        "every AArch64 CPU (Graviton, Ampere, Raspberry Pi 4 and 5): NEON, the 128-bit vectors "
        "the kernels use, is part of the base architecture",
    ),
}
_MACHINES = {"amd64": "x86_64", "x86-64": "x86_64"}


class CompilingKernelsWarning(RuntimeWarning):
    """numba compiles the kernels on this machine: the shipped ones are not used (says why)."""


def machine() -> str:
    """This machine's kind as :data:`TARGETS` names it (arm64 is Apple silicon on macOS
    only; elsewhere it is the AArch64 of every vendor)."""
    name = platform.machine().lower()
    if name == "arm64" and sys.platform != "darwin":
        return "aarch64"
    return _MACHINES.get(name, name)


def platform_key() -> str:
    """The folder name of this platform's kernels: ``<sys.platform>-<machine>``."""
    return f"{sys.platform}-{machine()}"


def build_folder(root: str | os.PathLike) -> Path:
    """The folder under ``root`` (the package's ``_compiled``) of this numba and platform."""
    return Path(root) / numba.__version__ / platform_key()


@functools.lru_cache(maxsize=1)
def build_root() -> Path:
    """The folder the build saves this process's kernels in (under :data:`COMPILE_INTO`),
    its manifest written."""
    folder = build_folder(os.environ[COMPILE_INTO])
    write_manifest(folder)
    return folder


def _python() -> str:
    return f"{sys.version_info[0]}.{sys.version_info[1]}"


def _triple() -> str:
    import llvmlite.binding as ll

    return ll.get_process_triple()


def write_manifest(folder: Path) -> dict:
    """Write ``folder``'s manifest: what its kernels were compiled for (the build's numba,
    Python, triple, and the CPU model numba was told, with its features from
    :data:`TARGETS`)."""
    cpu = config.CPU_NAME or ""
    target = next((t for t in TARGETS.values() if t.cpu == cpu), None)
    if target is None or config.CPU_FEATURES != "":
        raise RuntimeError(
            f"the shipped kernels are compiled for a CPU model of TARGETS with NUMBA_CPU_NAME "
            f"and an empty NUMBA_CPU_FEATURES (here {cpu!r}, {config.CPU_FEATURES!r})"
        )
    manifest = {
        "numba": numba.__version__,
        "python": _python(),
        "platform": platform_key(),
        "triple": _triple(),
        "cpu": target.cpu,
        "features": list(target.features),
    }
    folder.mkdir(parents=True, exist_ok=True)
    (folder / MANIFEST).write_text(json.dumps(manifest, indent=1) + "\n")
    return manifest


def _switched_off() -> bool:
    return os.environ.get(SWITCH, "").strip().lower() in ("0", "off", "no", "false")


def _host_features() -> set[str]:
    """The features of this CPU numba compiles for (``+name`` in its feature string)."""
    from numba.core.codegen import get_host_cpu_features

    flat = get_host_cpu_features()
    return {item[1:] for item in flat.split(",") if item.startswith("+")}


class Shipped(NamedTuple):
    """The shipped kernels of this process: their folder and manifest, or why not."""

    folder: Path | None
    manifest: dict | None
    refused: str | None


@functools.lru_cache(maxsize=1)
def shipped() -> Shipped:
    """This install's shipped kernels, if this process may load them (read once)."""
    folder, manifest, reason = None, None, _refusal()
    if reason is None:
        folder = build_folder(COMPILED)
        manifest = json.loads((folder / MANIFEST).read_text())
    return Shipped(folder, manifest, reason)


def _refusal() -> str | None:
    """Why this process does not load the shipped kernels, or None if it does."""
    if os.environ.get(COMPILE_INTO):
        return "the kernels are being compiled for a wheel"
    if _switched_off():
        return f"{SWITCH}={os.environ[SWITCH]} turns them off"
    if config.CACHE_LOCATOR_CLASSES:
        return "NUMBA_CACHE_LOCATOR_CLASSES is set: numba's caches are the ones it names"
    if not COMPILED.is_dir():
        return "this install carries none (a source install, an sdist or the py3-none-any wheel)"
    versions = sorted(p.name for p in COMPILED.iterdir() if p.is_dir())
    if numba.__version__ not in versions:
        return (
            f"they were compiled for numba {', '.join(versions) or '(none)'}; this is numba "
            f"{numba.__version__} (install napari-labyrinth again, or the numba it was built for)"
        )
    folder = build_folder(COMPILED)
    if not (folder / MANIFEST).is_file():
        kinds = sorted(p.name for p in folder.parent.iterdir() if p.is_dir())
        return f"they were compiled for {', '.join(kinds) or '(none)'}; this is {platform_key()}"
    manifest = json.loads((folder / MANIFEST).read_text())
    if manifest["python"] != _python():
        return f"they were compiled for Python {manifest['python']}; this is Python {_python()}"
    for variable in ("NUMBA_CPU_NAME", "NUMBA_CPU_FEATURES"):
        if variable in os.environ:
            return f"{variable} is set ({os.environ[variable]!r}): numba compiles for the CPU it names"
    if manifest["triple"] != _triple():
        return f"they were compiled for {manifest['triple']}; this process is {_triple()}"
    missing = sorted(set(manifest["features"]) - _host_features())
    if missing:
        return f"this CPU lacks {', '.join(missing)} of their target, {manifest['cpu']}"
    return None


def magic_tuple(manifest: dict) -> tuple[str, str, str]:
    """The codegen part of the index key of a shipped entry (numba's ``magic_tuple()``
    where numba was told the target: its CPU name and no features)."""
    return (manifest["triple"], manifest["cpu"], "")


_said = False


def say_why_compiling(kernel: str) -> None:
    """Say once in this process why numba compiles ``kernel`` (the first one) here."""
    global _said
    if _said:
        return
    _said = True
    reason = shipped().refused
    if reason is None:  # loaded where they exist: this signature is not among them
        _log.info("compiling %s: not among the shipped kernels", kernel)
        return
    if os.environ.get(COMPILE_INTO):
        return
    if not COMPILED.is_dir():  # by design: an install without them compiles
        _log.info("numba compiles the kernels on this machine: %s", reason)
        return
    warnings.warn(
        f"napari-labyrinth: numba compiles the kernels on this machine, seconds for each "
        f"first call (then kept in numba's cache); the compiled kernels are not used: "
        f"{reason}.",
        CompilingKernelsWarning,
        stacklevel=_callers_level(),
    )


def _callers_level() -> int:
    """The ``stacklevel`` of the first frame outside this package, numba and the standard
    library's context managers: the user's call that compiles (2 if there is none)."""
    frame, level = sys._getframe(2), 2
    while frame is not None:
        name = frame.f_globals.get("__name__", "")
        if not name.startswith(("napari_labyrinth", "numba", "contextlib")):
            return level
        frame, level = frame.f_back, level + 1
    return 2


def _root() -> Path | None:
    """The folder of this process's shipped kernels: the build's, while it compiles them,
    else the install's where this process loads them; None otherwise."""
    if os.environ.get(COMPILE_INTO):
        return build_root()
    return shipped().folder


class _ShippedLocator(_CacheLocator):
    """numba's locator of a kernel's files in the shipped layout: the folder of its module
    relative to the package, under :func:`_root`; stamped by its sources' contents."""

    def __init__(self, py_func, folder: Path):
        self._py_func = py_func
        self._folder = folder
        self._lineno = py_func.__code__.co_firstlineno

    def ensure_cache_path(self):
        self._folder.mkdir(parents=True, exist_ok=True)  # the build's; the install's exists

    def get_cache_path(self):
        return str(self._folder)

    def get_source_stamp(self):
        return ("napari-labyrinth", source_digest(self._py_func))

    def get_disambiguator(self):
        return str(self._lineno)

    @classmethod
    def from_function(cls, py_func, py_file):
        root = _root()
        if root is None:
            return None
        try:
            module = Path(py_file).resolve().parent.relative_to(PACKAGE)
        except ValueError:  # a kernel outside the package: never shipped
            return None
        return cls(py_func, root / module)


class _ShippedImpl(CompileResultCacheImpl):
    _locator_classes = [_ShippedLocator]


class ShippedCache(Cache):
    """numba's cache of one kernel in the shipped layout; its entries' keys name the
    target CPU (:func:`magic_tuple`). Saves only while the build compiles."""

    _impl_class = _ShippedImpl

    def __init__(self, py_func):
        super().__init__(py_func)
        manifest = shipped().manifest
        self._magic = magic_tuple(manifest) if manifest is not None else None

    def _index_key(self, sig, codegen):
        key = super()._index_key(sig, codegen)
        return key if self._magic is None else (key[0], self._magic, key[2])

    def save_overload(self, sig, data):
        if os.environ.get(COMPILE_INTO):
            super().save_overload(sig, data)


def of_the_package(py_func) -> bool:
    """Whether the kernel ``py_func`` is defined in a module of this package."""
    try:
        Path(py_func.__code__.co_filename).resolve().relative_to(PACKAGE)
    except (ValueError, OSError):
        return False
    return True


def shipped_cache(py_func) -> ShippedCache | None:
    """The shipped cache of the kernel ``py_func``, or None: a kernel outside the package,
    or a process that neither loads shipped kernels nor compiles them for a wheel."""
    if _root() is None or config.CACHE_LOCATOR_CLASSES:
        return None
    try:
        return ShippedCache(py_func)
    except RuntimeError:  # no locator: see _ShippedLocator.from_function
        return None


class ShippedFirst(NullCache):
    """A kernel's cache: its shipped entries first, then numba's own cache (``users``,
    where whatever compiles here is saved)."""

    def __init__(self, py_func, shipped_entries: ShippedCache | None, users):
        self._name = py_func.__qualname__
        self.shipped = shipped_entries
        self.users = users

    @property
    def cache_path(self):
        return self.users.cache_path

    def load_overload(self, sig, target_context):
        if self.shipped is not None:
            result = self.shipped.load_overload(sig, target_context)
            if result is not None:
                return result
        return self.users.load_overload(sig, target_context)

    def save_overload(self, sig, data):
        self.users.save_overload(sig, data)

    def enable(self):
        self.users.enable()

    def disable(self):
        self.users.disable()

    def flush(self):
        self.users.flush()
