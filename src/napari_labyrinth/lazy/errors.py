"""Errors of a computation over dask blocks, each said in one line.

``computing`` turns what dask or a ``dask.distributed`` cluster raises while
blocks are computed (a corrupt chunk, a lost worker, ...) into a
:class:`ComputeError`; errors that already name what went wrong about a file
pass through as they are.
"""

from __future__ import annotations

import contextlib


class ComputeError(RuntimeError):
    """A block could not be computed: a corrupt chunk, a lost worker, ... (one line)."""


#: Errors that already say what went wrong about a file, passed on as they are.
_PLAIN_ERRORS = (OSError, ValueError, TypeError, MemoryError)


@contextlib.contextmanager
def computing():
    """Turn any other exception raised while computing into a one-line ComputeError."""
    try:
        yield
    except _PLAIN_ERRORS:
        raise
    except Exception as exc:
        where = "the dask cluster" if type(exc).__module__.startswith("distributed") else ""
        text = " ".join(str(exc).split()) or "no details"
        prefix = f"{where} failed: " if where else ""
        raise ComputeError(f"{prefix}{type(exc).__name__}: {text}") from exc
