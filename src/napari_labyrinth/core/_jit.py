"""The decorator of every numba kernel: ``njit`` with numba's disk cache where one can be kept.

numba keeps compiled kernels beside their source (``__pycache__``) or, where
the install is read-only, in the user's cache directory (``$NUMBA_CACHE_DIR``,
else ``$XDG_CACHE_HOME/numba`` or ``~/.cache/numba``). Where none of them can
be written, ``njit(cache=True)`` refuses the function as it is defined, so
the package would not import. ``cached_njit`` compiles such kernels in memory
instead (every new process compiles again) and says so once.
"""

from __future__ import annotations

import warnings

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
        dispatcher = njit(**options)(function)
        try:
            dispatcher.enable_caching()
        except RuntimeError as error:
            if not str(error).startswith(_NO_LOCATOR):
                raise
            _warn_once()
        return dispatcher

    return decorate


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
