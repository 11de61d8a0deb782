"""The C reference of the kernel (``c_reference.c``), built and loaded with ctypes.

``load()`` compiles the C file with the system compiler (``gcc -O3 -march=native
-ffp-contract=off``: float64 in the kernel's order, no fused multiply-add) into
``benchmarks/build/`` (ignored by git) and returns a :class:`CReference`, or
None with the reason printed when no compiler is found or the build fails.
"""

from __future__ import annotations

import ctypes
import pathlib
import shutil
import subprocess

import numpy as np

SOURCE = pathlib.Path(__file__).with_suffix(".c")
BUILD = pathlib.Path(__file__).parent / "build"
FLAGS = ("-O3", "-march=native", "-ffp-contract=off", "-shared", "-fPIC")


class CReference:
    """``run_pass`` with the signature of ``napari_labyrinth._engine.run_pass`` (one thread)."""

    def __init__(self, library: ctypes.CDLL, command: str):
        self.command = command
        self._pass = library.labyrinth_pass
        pointer, i64, u64 = ctypes.c_void_p, ctypes.c_int64, ctypes.c_uint64
        self._pass.argtypes = [pointer, i64, i64, ctypes.c_double, ctypes.c_double, pointer,
                               pointer, pointer, i64, i64, u64, u64, u64] + [ctypes.c_int] * 8 + [
                               pointer]  # fmt: skip
        self._pass.restype = None

    def run_pass(self, tones, parameters, *, seed=0, plane_index=0, pass_index=0, counts=None,
                 has_nonfinite=None):  # fmt: skip
        from napari_labyrinth._engine.passes import pass_parameters
        from napari_labyrinth.core.codes import DIAGNOSTIC_FIELDS

        assert tones.dtype == np.float32 and tones.flags.c_contiguous and tones.ndim == 2
        if counts is None:  # the C pass counts the first six (it has no noise gate)
            counts = np.zeros(len(DIAGNOSTIC_FIELDS), np.int64)
        if has_nonfinite is None:
            has_nonfinite = not np.isfinite(tones).all()
        kernel = pass_parameters(parameters)
        bounds = kernel.range_bounds
        bounds = np.ascontiguousarray(bounds if bounds.size else np.zeros(1))
        low, high = kernel.tone_low, kernel.tone_high
        options = (
            kernel.border, kernel.variance_ratio, kernel.variance_action, kernel.condition_order,
            kernel.on_exhausted, kernel.scan, int(kernel.include_centre), int(has_nonfinite),
        )  # fmt: skip
        self._pass(
            tones.ctypes.data, tones.shape[0], tones.shape[1], kernel.mean_threshold,
            kernel.variance_threshold, bounds.ctypes.data, low.ctypes.data, high.ctypes.data,
            low.size, kernel.max_tries, seed, plane_index, pass_index, *options,
            counts.ctypes.data,
        )  # fmt: skip
        return counts


def load(verbose: bool = True) -> CReference | None:
    """Build (if the source is newer) and load the C reference; None if there is no compiler."""
    compiler = shutil.which("gcc") or shutil.which("cc")
    if compiler is None:
        if verbose:
            print("C reference skipped: no gcc or cc on PATH")
        return None
    BUILD.mkdir(exist_ok=True)
    library = BUILD / "labyrinth_pass.so"
    command = [compiler, *FLAGS, str(SOURCE), "-o", str(library), "-lm"]
    if not library.exists() or library.stat().st_mtime < SOURCE.stat().st_mtime:
        result = subprocess.run(command, capture_output=True, text=True)
        if result.returncode != 0:
            if verbose:
                print(f"C reference skipped: the build failed\n{result.stderr}")
            return None
    return CReference(ctypes.CDLL(str(library)), " ".join(command))
