"""Large results in plain memory pages: a render's first touches must not stall the GUI.

numpy asks Linux to back every new array of 4 MB or more with 2 MB huge pages
(``madvise(MADV_HUGEPAGE)``). An array larger than malloc ever recycles
(32 MB, glibc's largest ``mmap`` threshold), such as the result of a stack of
planes, is new memory on every call, and the render threads make its first
touches as they write its planes. On a virtual machine that hands free memory
back to its host (the virtio balloon's free page reporting), a first touch of a
huge page is sometimes very slow, and while the render threads were taking
such pages napari's event loop stalled. Plain 4 kB pages cost a steady, small
price in page faults, spread over the render threads; huge pages cost less when
they come fast and more when they come slowly. The stalls and the trade, as
measured, are in docs/performance.md ("Memory pages of large results").

Smaller arrays keep numpy's advice: malloc gives their memory back to the next
array of their size, already touched, and the speed of a single plane's render
is measured on such memory.
"""

from __future__ import annotations

import ctypes
import mmap
import sys

import numpy as np

#: Arrays of at least this many bytes are new memory on every call (glibc's largest
#: ``mmap`` threshold on 64-bit machines: nothing this large is recycled by malloc).
FRESH_BYTES = 32 << 20

_PAGE = mmap.PAGESIZE
_MADV_NOHUGEPAGE = getattr(mmap, "MADV_NOHUGEPAGE", None)  # Linux only
_libc = None


def empty_in_plain_pages(shape, dtype) -> np.ndarray:
    """``np.empty(shape, dtype)``, in plain pages if it is at least ``FRESH_BYTES`` (Linux).

    Where the advice cannot be given (another system, a refusal), the array is
    numpy's as it is: the advice changes no value, only how its memory comes.
    """
    array = np.empty(shape, dtype)
    if array.nbytes >= FRESH_BYTES:
        advise_plain_pages(array)
    return array


def advise_plain_pages(array: np.ndarray) -> bool:
    """Ask Linux to back the whole pages of ``array``'s memory with plain pages
    (``madvise(MADV_NOHUGEPAGE)``; pages already touched stay as they are).

    Returns whether the advice was taken.
    """
    global _libc
    if _MADV_NOHUGEPAGE is None or not sys.platform.startswith("linux"):
        return False
    address = array.__array_interface__["data"][0]
    start = -(-address // _PAGE) * _PAGE
    stop = (address + array.nbytes) // _PAGE * _PAGE
    if stop <= start:
        return False
    if _libc is None:
        _libc = ctypes.CDLL(None, use_errno=True)
        _libc.madvise.argtypes = (ctypes.c_void_p, ctypes.c_size_t, ctypes.c_int)
        _libc.madvise.restype = ctypes.c_int
    return _libc.madvise(start, stop - start, _MADV_NOHUGEPAGE) == 0
