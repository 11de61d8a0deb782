"""``napari-labyrinth reproduce``: render an output again from its record, compare bit for bit."""

from __future__ import annotations

import argparse
import os
from pathlib import Path
from typing import Any

import numpy as np

from .. import __version__, api
from ..io import LOSSY_FORMATS, image_format, open_image, read_image, read_provenance
from ..lazy import computing, is_lazy
from ..provenance import file_checksum, reproduce_call
from ._common import EXIT_FAILED, EXIT_OK, PROG, Failed, describe, print_output


def reproduce_command(args: argparse.Namespace) -> int:
    """Run ``napari-labyrinth reproduce``; the exit code (0: identical, 1: not)."""

    output = Path(args.output)
    try:
        record = read_provenance(output)
    except (OSError, ValueError) as exc:
        raise Failed(f"{output}: {describe(exc, output)}") from None
    source = record["input"]
    path = find_input(output, source, args.input)
    checksum = file_checksum(path)
    if source.get("sha256") not in (None, checksum):
        raise Failed(
            f"{path}: not the file that was rendered (SHA-256 {checksum[:12]}..., "
            f"recorded {source['sha256'][:12]}...)"
        )
    mode, arguments = reproduce_call(record)
    try:
        image = open_image(
            path, lazy=None, channel_axis=arguments.get("channel_axis"), scene=source.get("scene")
        )
        for event in api.labyrinth_steps(image, mode, **arguments):
            if isinstance(event, api.Result):
                again = event.image
        if is_lazy(again):
            with computing():
                again = again.compute()
        written = read_image(output)
    except (OSError, ValueError, TypeError) as exc:
        raise Failed(f"{output}: {describe(exc, output)}") from None
    again = np.asarray(again)
    versions = f"recorded by {record['version']}, rendered by {__version__}"
    sweep = record.get("sweep") or {}
    swept = sweep.get("parameter")
    seed = f"seed {record['seed']}"
    if swept == "seed":  # the seed recorded is the default the sweep replaced
        seed = "seeds " + ", ".join(map(str, sweep.get("values", ())))
    elif swept is not None:
        seed += f", {swept} " + ", ".join(map(str, sweep.get("values", ())))
    what = f"{mode} of {path} ({record['function']}, preset {record['preset']}, {seed}; "
    what += f"{versions})"
    if identical(written, again):
        print_output(
            f"{output}: identical bit for bit to a new rendering: {what}; "
            f"shape {tuple(written.shape)}, {written.dtype}, {written.size} values"
        )
        return EXIT_OK
    lossy = ""
    if image_format(output) in LOSSY_FORMATS:
        lossy = f" ({image_format(output)} is lossy: its values are never a rendering's own)"
    print_output(
        f"{PROG}: {output}: DIFFERS from a new rendering: {what}; "
        f"{difference(written, again)}{lossy}"
    )
    return EXIT_FAILED


def find_input(output: Path, source: dict[str, Any], given: str | None) -> Path:
    """The input to render: ``--input``, else the recorded name: as given, beside the output,
    or below a directory that holds the output.

    The name was recorded relative to where ``render`` ran, often a directory above the
    output's (``render raw/cells.png -o results/``, then ``reproduce`` in ``results``);
    the input's checksum, checked next, tells a file of the same name from it.
    """
    if given is not None:
        path = Path(given)
        if not path.exists():
            raise Failed(f"--input {given}: no such file")
        return path
    name = Path(source["name"])
    candidates = [name, output.parent / name, output.parent / name.name]
    if not name.is_absolute():
        candidates += [folder / name for folder in Path(os.path.abspath(output)).parents[1:]]
    for path in candidates:
        try:
            if path.exists():
                return path
        except OSError:  # a name the file system cannot hold (too long): not there
            continue
    tried = ", ".join(dict.fromkeys(str(path) for path in candidates[:3]))
    above = " nor below a directory above the output's;" if len(candidates) > 3 else ";"
    raise Failed(f"{output}: the recorded input {name} is not at {tried},{above} give --input")


def identical(a, b) -> bool:
    """Same shape, dtype and bytes (NaNs included)."""
    a, b = np.ascontiguousarray(a), np.ascontiguousarray(b)
    return a.shape == b.shape and a.dtype == b.dtype and a.tobytes() == b.tobytes()


def difference(written, again) -> str:
    """How two arrays differ, in words."""
    if written.shape != again.shape or written.dtype != again.dtype:
        return (
            f"the output is {written.dtype} {tuple(written.shape)}, the new rendering "
            f"{again.dtype} {tuple(again.shape)}"
        )
    differ = np.count_nonzero(~((written == again) | ((written != written) & (again != again))))
    return f"{differ} of {written.size} values differ"
