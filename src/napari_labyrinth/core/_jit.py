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
"""

from __future__ import annotations

import contextlib
import functools
import hashlib
import inspect
import pickle
import threading
import warnings

try:
    import fcntl
except ImportError:  # pragma: no cover - Windows
    fcntl = None

from numba import njit

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
        try:
            dispatcher.enable_caching()
        except RuntimeError as error:
            if not str(error).startswith(_NO_LOCATOR):
                raise
            _warn_once()
        else:
            _stamp_with_sources(dispatcher)
            _read_unreadable_index_as_stale(dispatcher)
            _lock_between_processes(dispatcher)
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
    digest = hashlib.sha256()
    for path in sorted(_source_files(dispatcher.py_func)):
        digest.update(path.encode() + b"\0" + _file_digest(path))
    cache_file._source_stamp = (cache_file._source_stamp, digest.hexdigest())


@functools.lru_cache(maxsize=None)
def _file_digest(path: str) -> bytes:
    """The digest of ``path``'s contents, read once a process: the kernels of a module
    and their helpers share their files."""
    with open(path, "rb") as source:
        return hashlib.sha256(source.read()).digest()


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


def _source_files(function, seen: set[str] | None = None) -> set[str]:
    """The file of ``function`` and those of the jitted functions it reaches through its
    globals (helpers, tuples of kernels), as the decorator sees them: helpers come from
    imports at the top of a module or are defined above their caller. The files of the
    NamedTuple classes in those globals too: the kernels' arguments, imported at the top
    of their modules."""
    seen = set() if seen is None else seen
    try:
        path = inspect.getsourcefile(function)
    except TypeError:
        return seen
    if path is None or path in seen:
        return seen
    seen.add(path)
    values = list(getattr(function, "__globals__", {}).values())
    while values:
        value = values.pop()
        if isinstance(value, tuple):
            values.extend(value)
        elif hasattr(value, "py_func") and hasattr(value, "overloads"):  # a dispatcher
            _source_files(value.py_func, seen)
        elif isinstance(value, type) and issubclass(value, tuple) and hasattr(value, "_fields"):
            with contextlib.suppress(TypeError, OSError):  # a NamedTuple of no file
                seen.add(inspect.getsourcefile(value) or "")
    seen.discard("")
    return seen


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
    from numba.core import event

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
