"""The decorator of every numba kernel: ``njit`` with numba's disk cache where one can be kept.

numba keeps compiled kernels beside their source (``__pycache__``) or, where
the install is read-only, in the user's cache directory (``$NUMBA_CACHE_DIR``,
else ``$XDG_CACHE_HOME/numba`` or ``~/.cache/numba``). Where none of them can
be written, ``njit(cache=True)`` refuses the function as it is defined, so
the package would not import. ``cached_njit`` compiles such kernels in memory
instead (every new process compiles again) and says so once.

numba takes a cached kernel as current while its own source file keeps its
modification time and size; the code of the helpers it calls from other files
is compiled into it, and a change there would go unseen. Nor does numba's
cache index know a NamedTuple argument by its fields' names: one moved or
renamed would be read at its old place. ``cached_njit`` stamps a kernel's
cache with the contents of its file and of every file its helpers and the
NamedTuple classes in their modules come from, so that a change to any of
them compiles it again. numba reads the index before its stamp: an index that
names a NamedTuple class no longer there (moved since it was written) reads
as stale, instead of raising.

numba names a kernel's compiled code by its qualified name, its argument types
and a number counted up in each process, not by the values a kernel made by a
factory closes over. Two variants of a factory compiled in two processes can
get the same name; a process that then holds one compiled by itself and
another loaded from the cache links whichever of the two bodies it sees first
into every caller of either (numba issue #10486). ``cached_njit`` names such a
kernel by those values (``labyrinth_pass[variance_decides_first=True,...]``),
so that two variants never share a name.

numba's dispatcher types every argument of every call, a NamedTuple on its
Python route; :func:`compiled_for` gives a caller that
calls a kernel many times with arguments of the same types its compiled code
to call without that.

A platform wheel carries every kernel compiled for a portable CPU model
(:mod:`._shipped`): ``cached_njit`` loads a kernel from there before it looks in
numba's cache, where this process may (:func:`._shipped.shipped`), and saves
every kernel there when the build compiles them (``_shipped.COMPILE_INTO``).
With :data:`COMPILE_LOG` naming a file, every kernel numba compiles in a process
(and in the processes it starts) is noted there, a line each.
"""

from __future__ import annotations

import os
import pickle
import threading
import warnings

try:
    import fcntl
except ImportError:  # pragma: no cover - Windows
    fcntl = None

from numba import njit
from numba.core import event

from . import _shipped
from ._kernel_sources import source_digest

#: Set to a file's path to note there every kernel of the package numba compiles, a line
#: each (name, signature, the test running then): what a shipped wheel leaves to compile.
COMPILE_LOG = "NAPARI_LABYRINTH_COMPILE_LOG"

#: The start of the message numba raises when no cache directory can be written.
_NO_LOCATOR = "cannot cache function"

_warned = False


class UncachedKernelWarning(RuntimeWarning):
    """numba found no directory to keep its compiled kernels in: they compile in memory."""


def cached_njit(**options):
    """``numba.njit(**options)``, cached on disk where numba finds a writable directory.

    Parameters
    ----------
    **options
        Options of ``numba.njit`` other than ``cache`` (``nogil``, ``inline``, ...).

    Returns
    -------
    callable
        A decorator making a numba dispatcher of a function.
    """

    def decorate(function):
        _name_by_closure(function)
        dispatcher = njit(**options)(function)
        shipped = _shipped.shipped_cache(function)
        if shipped is not None and os.environ.get(_shipped.COMPILE_INTO):
            dispatcher._cache = shipped  # the build: every kernel saved in the shipped layout
            _lock_between_processes(dispatcher)
            return dispatcher
        try:
            dispatcher.enable_caching()
        except RuntimeError as error:
            if not str(error).startswith(_NO_LOCATOR):
                raise
            if shipped is None:  # nothing shipped to load either: every kernel compiles
                _warn_once()
        else:
            _stamp_with_sources(dispatcher)
            _read_unreadable_index_as_stale(dispatcher)
            _lock_between_processes(dispatcher)
        if shipped is not None or _shipped.of_the_package(function):
            dispatcher._cache = _shipped.ShippedFirst(function, shipped, dispatcher._cache)
        return dispatcher

    return decorate


def _name_by_closure(function) -> None:
    """Append the values ``function`` closes over to its qualified name, which numba's
    compiled code and cache files are named by (see the module's docstring).

    Raises
    ------
    TypeError
        A closed-over value that is not a bool, an int or a string: its repr would
        not name it the same way in every process.
    """
    if not function.__closure__:
        return
    values = []
    for name, cell in zip(function.__code__.co_freevars, function.__closure__, strict=True):
        value = cell.cell_contents
        if not isinstance(value, (bool, int, str)):
            raise TypeError(
                f"{function.__qualname__} closes over {name}={value!r}: a kernel made by a "
                "factory may close over bools, ints and strings only, which name its variant"
            )
        values.append(f"{name}={value!r}")
    function.__qualname__ += "[" + ",".join(values) + "]"


def _stamp_with_sources(dispatcher) -> None:
    """Make the cache of ``dispatcher`` current only for the present contents of its
    file and of the files of the jitted helpers it reaches (numba's own stamp is its
    file's modification time and size)."""
    cache_file = getattr(getattr(dispatcher, "_cache", None), "_cache_file", None)
    if cache_file is None or not hasattr(cache_file, "_source_stamp"):
        return  # a numba whose cache differs: its own stamp stands
    cache_file._source_stamp = (cache_file._source_stamp, source_digest(dispatcher.py_func))


def _read_unreadable_index_as_stale(dispatcher) -> None:
    """Make an index of ``dispatcher``'s cache that does not unpickle read as stale.

    numba unpickles a kernel's cache index (its signatures) before it compares the
    stamp: a signature that names a class no longer there, a NamedTuple argument
    moved or renamed since the index was written, would raise at the kernel's first
    call. Read as empty, the kernel compiles again and its index is written anew.
    """
    cache_file = getattr(getattr(dispatcher, "_cache", None), "_cache_file", None)
    load_index = getattr(cache_file, "_load_index", None)
    if load_index is None:
        return  # a numba whose cache differs: as it is

    def load_index_or_nothing():
        try:
            return load_index()
        except (ImportError, AttributeError, EOFError, pickle.UnpicklingError):
            return {}

    cache_file._load_index = load_index_or_nothing


def _lock_between_processes(dispatcher) -> None:
    """Save and load ``dispatcher``'s cache holding a lock on its index file.

    numba saves a new overload by writing its index (naming the first free data
    file) and then the data: two processes compiling overloads of one kernel
    (the variants of a factory share an index) may name the same data file, and
    a load between the two writes reads the data file of an older index. Either
    way a kernel would run another overload's code. The lock (``flock``, Linux
    and macOS) makes each save and load whole.
    """
    cache_file = getattr(getattr(dispatcher, "_cache", None), "_cache_file", None)
    index_path = getattr(cache_file, "_index_path", None)
    if index_path is None or fcntl is None:
        return  # a numba whose cache differs, or no flock: as it is
    save, load = cache_file.save, cache_file.load

    def locked(operation, mode):
        def run(*arguments):
            try:
                lock = open(index_path + ".lock", "a")  # noqa: SIM115 - closed below
            except OSError:  # no cache directory yet, or one this user cannot write
                return operation(*arguments)
            with lock:
                fcntl.flock(lock, mode)  # released when the file closes
                return operation(*arguments)

        return run

    cache_file.save = locked(save, fcntl.LOCK_EX)
    cache_file.load = locked(load, fcntl.LOCK_SH)


def compiled_for(dispatcher, *arguments):
    """The compiled code of ``dispatcher`` for the types of ``arguments``, compiled or
    loaded from numba's disk cache first if need be, to call without typing them again.

    Parameters
    ----------
    dispatcher : numba dispatcher
        A kernel.
    *arguments
        Arguments of the types of every later call.

    Returns
    -------
    callable
        Takes arguments of exactly those types (any other is undefined behaviour)
        and runs the kernel, holding no GIL if the kernel is ``nogil``. Where
        numba's internals differ, ``dispatcher`` itself.
    """
    try:
        signature = tuple(dispatcher.typeof_pyval(argument) for argument in arguments)
        if signature not in dispatcher.overloads:
            dispatcher.compile(signature)
        return dispatcher.overloads[signature].entry_point
    except (AttributeError, TypeError, KeyError):  # a numba whose dispatchers differ
        return dispatcher


def _warn_once() -> None:
    global _warned
    if _warned:
        return
    _warned = True
    warnings.warn(
        "napari-labyrinth: no writable directory for numba's cache (the package's own "
        "__pycache__, $NUMBA_CACHE_DIR, $XDG_CACHE_HOME or ~/.cache): the kernels are "
        "compiled in memory, again in every new process. Set NUMBA_CACHE_DIR to a "
        "writable directory to keep them.",
        UncachedKernelWarning,
        stacklevel=4,
    )


def is_compiled(dispatcher, *arguments) -> bool:
    """Whether ``dispatcher(*arguments)`` runs at once, without compiling: its code for
    these argument types is compiled in this process or in numba's disk cache (then
    loaded, as the call would).

    A call that can take another route to the same result (one that compiles
    nothing) takes it while this is False: only the kernels a call needs compile.
    """
    from numba.core.compiler_lock import global_compiler_lock

    try:
        signature = tuple(dispatcher.typeof_pyval(argument) for argument in arguments)
        if signature in dispatcher.overloads:
            return True
        with global_compiler_lock:  # numba's Dispatcher.compile, up to its cache's answer
            result = dispatcher._cache.load_overload(signature, dispatcher.targetctx)
            if result is None:
                return False
            dispatcher.targetctx.insert_user_function(
                result.entry_point, result.fndesc, [result.library]
            )
            dispatcher.add_overload(result)
    except (AttributeError, TypeError):  # a numba whose dispatchers differ: say not compiled
        return False
    return True


_compiling: list[str] = []
_compiling_lock = threading.Lock()
_listener = None


def watch_compiles() -> None:
    """Start noting the kernels numba compiles in this process (for :func:`compiling`)."""
    global _listener
    if _listener is not None:
        return

    class _Watcher(event.Listener):
        def on_start(self, ev):
            with _compiling_lock:
                _compiling.append(ev.data["dispatcher"].py_func.__name__)

        def on_end(self, ev):
            with _compiling_lock:
                _compiling.pop()

    _listener = _Watcher()
    event.register("numba:compile", _listener)


def compiling() -> str | None:
    """The kernel numba is compiling in this process now (the outermost), or None.

    Only once :func:`watch_compiles` was called: a run's first call of a
    kernel after an install waits seconds on its compile, which a front end
    can say.
    """
    with _compiling_lock:
        return _compiling[0] if _compiling else None


def _note_compiles_in(path: str) -> None:
    """Append a line to ``path`` for every kernel of the package numba compiles in this
    process, called from Python (the helpers a kernel's compile types on the way are part
    of it): its qualified name, signature, the test running then (pytest's
    ``PYTEST_CURRENT_TEST``, which the processes a test starts inherit) and the process."""
    depth = threading.local()

    class _Noter(event.Listener):
        def on_start(self, ev):
            depth.value = getattr(depth, "value", 0) + 1
            function = ev.data["dispatcher"].py_func
            if depth.value > 1 or not _is_the_packages(function):
                return
            test = os.environ.get("PYTEST_CURRENT_TEST", "").rsplit(" (", 1)[0]
            line = f"{function.__qualname__}\t{ev.data['args']}\t{test}\t{os.getpid()}\n"
            with open(path, "a", encoding="utf-8") as log:
                log.write(line)

        def on_end(self, ev):
            depth.value -= 1

    event.register("numba:compile", _Noter())


def _is_the_packages(function) -> bool:
    """Whether ``function`` is defined by a module of this package (by its module's name)."""
    return (function.__module__ or "").startswith("napari_labyrinth")


def _say_why_at_the_first_compile() -> None:
    """Have :func:`._shipped.say_why_compiling` say once why the package's first kernel to
    compile in this process compiles (a load from a cache is no compile)."""

    class _FirstCompile(event.Listener):
        def on_start(self, ev):
            function = ev.data["dispatcher"].py_func
            if _is_the_packages(function):
                _shipped.say_why_compiling(function.__qualname__)

        def on_end(self, ev):
            pass

    event.register("numba:compile", _FirstCompile())


_noting: str | None = None


def note_compiles() -> None:
    """Note the kernels numba compiles in this process in the file :data:`COMPILE_LOG`
    names, if it names one (once a process; this module does so as it is imported)."""
    global _noting
    path = os.environ.get(COMPILE_LOG)
    if path and _noting is None:
        _noting = path
        _note_compiles_in(path)


note_compiles()
_say_why_at_the_first_compile()
