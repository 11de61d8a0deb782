"""The provenance record: how a rendering was made, enough to make it again.

One schema for every front end, built by one function,
:func:`rendering_record`, from the keyword arguments a front end gives the
API. The napari widget puts the record in the result layer's ``metadata``
(:mod:`napari_labyrinth.widget.plan`); the command line
(:mod:`napari_labyrinth.cli.render`) writes it into the output file
(:mod:`napari_labyrinth.io`: a TIFF's description, an OME-TIFF's annotation,
a PNG text chunk, zarr attributes) and ``napari-labyrinth reproduce`` renders
again from it.

A record is a JSON-ready dict:

``schema``
    :data:`SCHEMA`, the name and version of this layout.
``version``
    The package version that rendered.
``mode``, ``function``, ``arguments``
    The API call that gives the result: ``function(image, **arguments)``
    with ``function`` one of :func:`~napari_labyrinth.labyrinth`,
    :func:`~napari_labyrinth.labyrinth_stack` and
    :func:`~napari_labyrinth.labyrinth_sweep` for ``mode`` ``"single"``,
    ``"stack"`` and ``"sweep"``. The arguments name every parameter (not
    only those that differ from the preset), the seed, the tone limits that
    were used and the channel axis, so the call does not depend on the
    defaults of a later version.
``preset``, ``overrides``, ``parameters``, ``seed``, ``tone_limits``, ``sweep``
    The same facts for reading: the preset, what was changed from it, every
    resolved parameter (Eqs. 1-4 of the paper), the seed, the values mapped
    to tones 0 and 255, and the swept parameter and its values (or None).
``noise_sigma``
    Only where the noise gate (``noise_gate``, not in the paper) measured it:
    the noise of each plane in tones (None for an alpha plane). For reading:
    a rendering again measures it on the same values, and gets the same
    numbers.
``input``
    What was rendered: ``name`` (a file name, or a layer name), ``sha256``
    of the file's bytes (None for a layer), ``shape`` and ``dtype``.

Front ends may add their own keys (the widget adds the layer's description,
diagnostics and metrics); :func:`reproduce_call` reads only the ones above.
"""

from __future__ import annotations

import hashlib
import json
import os
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from . import __version__
from .core.colour import resolve_colour
from .core.parameters import PARAMETERS
from .core.presets import DEFAULT_PRESET, resolve_parameters

__all__ = [
    "FUNCTIONS",
    "KEY",
    "SCHEMA",
    "ProvenanceError",
    "call_arguments",
    "check",
    "file_checksum",
    "from_json",
    "input_record",
    "make_record",
    "rendering_record",
    "reproduce_call",
    "sweep_arguments",
    "to_json",
]

#: Name and version of the record's layout.
SCHEMA = "napari-labyrinth/provenance/1"

#: Key under which a record is stored: layer metadata, zarr attributes, PNG
#: text chunk, TIFF description, and the OME annotation's namespace suffix.
KEY = "napari_labyrinth"

#: API function each mode calls.
FUNCTIONS = {"single": "labyrinth", "stack": "labyrinth_stack", "sweep": "labyrinth_sweep"}

#: Bytes read at a time when a file's checksum is computed.
_CHUNK = 1 << 20


class ProvenanceError(ValueError):
    """A record that is missing, of another schema, or incomplete."""


def rendering_record(
    mode: str,
    arguments: Mapping[str, Any],
    *,
    source: Mapping[str, Any],
    tone_limits: Sequence[float] | None = None,
    overrides: Mapping[str, Any] | None = None,
    seed: int | None = None,
    noise_sigma: Sequence[float] | None = None,
) -> dict[str, Any]:
    """The record of ``labyrinth_steps(image, mode, **arguments)`` on ``source``: what the
    command line writes into a file and the widget into a layer's metadata.

    The record's arguments name what ``arguments`` leave to defaults: every
    parameter (resolved from the preset and the overrides), the seed, the
    tone limits used and the colour mode the default chose.

    Parameters
    ----------
    mode : {"single", "stack", "sweep"}
    arguments : mapping
        The keyword arguments of the rendering (those given, or every one):
        ``preset``, parameters, ``seed``, ``tone_limits``, ``channel_axis``,
        ``colour``, ``alpha``, ``plane_offset``, and for a sweep
        ``parameter`` and ``values``.
    source : mapping
        The ``input`` entry (see :func:`input_record`).
    tone_limits : pair of float, optional
        The values the rendering mapped to tones 0 and 255
        (``Result.tone_limits``); by default those of ``arguments``.
    overrides : mapping, optional
        The parameters set over the preset; by default the parameters that
        ``arguments`` name (pass them when ``arguments`` name every parameter).
    seed : int, optional
        The seed to record; by default that of ``arguments`` (0 if none; a
        sweep of the seed takes it out of ``arguments``).
    noise_sigma : sequence of float, optional
        Each rendered plane's noise in tones (``Result.noise_sigma``).

    Returns
    -------
    dict
        The record (see the module's docstring), JSON-ready.
    """
    preset = arguments.get("preset", DEFAULT_PRESET)
    if overrides is None:
        overrides = {name: value for name, value in arguments.items() if name in PARAMETERS}
    parameters = resolve_parameters(preset, **overrides).as_dict()
    if seed is None:
        seed = arguments.get("seed", 0)
    sweep = (arguments["parameter"], arguments["values"]) if mode == "sweep" else None
    if tone_limits is None:
        tone_limits = arguments.get("tone_limits")
    channel_axis, colour = arguments.get("channel_axis"), arguments.get("colour")
    if channel_axis is not None:  # the colour mode the default chose, written down
        colour = resolve_colour(colour, source["shape"], channel_axis)
    call = call_arguments(
        preset=preset,
        parameters=parameters,
        seed=seed,
        tone_limits=tone_limits,
        channel_axis=channel_axis,
        colour=colour,
        alpha=arguments.get("alpha"),
        sweep=sweep,
        plane_offset=arguments.get("plane_offset"),
    )
    return make_record(
        mode=mode,
        preset=preset,
        overrides=overrides,
        parameters=parameters,
        seed=seed,
        tone_limits=tone_limits,
        arguments=call,
        sweep=sweep,
        source=source,
        noise_sigma=noise_sigma,
    )


def make_record(
    *,
    mode: str,
    preset: str,
    overrides: Mapping[str, Any],
    parameters: Mapping[str, Any],
    seed: int,
    tone_limits: Sequence[float] | None,
    arguments: Mapping[str, Any],
    sweep: tuple[str, Sequence[Any]] | None,
    source: Mapping[str, Any],
    noise_sigma: Sequence[float] | None = None,
) -> dict[str, Any]:
    """A provenance record (see the module's docstring), JSON-ready.

    Parameters
    ----------
    mode : {"single", "stack", "sweep"}
    preset : str
    overrides : mapping
        The parameters set explicitly, over the preset.
    parameters : mapping
        Every resolved parameter (``LabyrinthParameters.as_dict()``).
    seed : int
    tone_limits : pair of float or None
        The values mapped to tones 0 and 255 by the rendering.
    arguments : mapping
        The keyword arguments of ``FUNCTIONS[mode]`` that give the result.
    sweep : (str, sequence) or None
        The swept parameter and its values.
    source : mapping
        The ``input`` entry (see :func:`input_record`).
    noise_sigma : sequence of float, optional
        Each rendered plane's noise in tones (``Result.noise_sigma``).
    """
    record = _plain(
        {
            "schema": SCHEMA,
            "version": __version__,
            "mode": mode,
            "function": FUNCTIONS[mode],
            "arguments": dict(arguments),
            "preset": preset,
            "overrides": dict(overrides),
            "parameters": dict(parameters),
            "seed": int(seed),
            "tone_limits": None if tone_limits is None else [float(v) for v in tone_limits],
            "sweep": {"parameter": sweep[0], "values": list(sweep[1])} if sweep else None,
            "input": dict(source),
        }
    )
    if noise_sigma is not None:  # measured by the noise gate: for reading (None: an alpha plane)
        record["noise_sigma"] = [None if v is None else float(v) for v in noise_sigma]
    return record


def call_arguments(
    *,
    preset: str,
    parameters: Mapping[str, Any],
    seed: int,
    tone_limits: Sequence[float] | None,
    channel_axis: int | None,
    colour: str | None = None,
    alpha: bool | None = None,
    sweep: tuple[str, Sequence[Any]] | None = None,
    plane_offset: int | None = None,
) -> dict[str, Any]:
    """The ``arguments`` of a record: every parameter, the seed, tone limits, channel axis
    (and ``colour``, ``alpha``, ``plane_offset`` when given).

    For a sweep the swept parameter (and ``tones`` when ``tone_ranges`` is
    swept: they are reset to T = L) gives way to ``parameter`` and ``values``.
    """
    arguments: dict[str, Any] = {"preset": preset, "seed": int(seed), **parameters}
    arguments["tone_limits"] = None if tone_limits is None else tuple(tone_limits)
    arguments["channel_axis"] = channel_axis
    if colour is not None:
        arguments["colour"] = colour
    if alpha is not None:
        arguments["alpha"] = bool(alpha)
    if sweep:
        sweep_arguments(arguments, *sweep)
    if plane_offset is not None:
        arguments["plane_offset"] = plane_offset
    return arguments


def sweep_arguments(arguments: dict[str, Any], parameter: str, values: Sequence[Any]) -> None:
    """Turn the arguments of one rendering into those of ``labyrinth_sweep``, in place."""
    arguments.pop(parameter, None)
    if parameter == "tone_ranges":
        arguments.pop("tones", None)
    arguments["parameter"] = parameter
    arguments["values"] = list(values)


def input_record(
    name: str,
    shape: Sequence[int],
    dtype: Any,
    sha256: str | None = None,
    *,
    scene: str | None = None,
) -> dict[str, Any]:
    """The ``input`` entry of a record: name, checksum of the file (or None), shape, dtype,
    and the scene read from a file of several (bioio's name for it), if any."""
    record = {
        "name": str(name),
        "sha256": sha256,
        "shape": [int(n) for n in shape],
        "dtype": str(np.dtype(dtype)),
    }
    if scene is not None:
        record["scene"] = scene
    return record


def file_checksum(path: str | os.PathLike) -> str:
    """SHA-256 of a file's bytes, or of a directory's files (a zarr store).

    A directory's checksum covers every file under it, in sorted order of
    their relative paths, each path followed by its bytes; hidden files
    (``.``-prefixed names, beside zarr v2 metadata) are skipped except
    ``.zarray``, ``.zgroup`` and ``.zattrs``.
    """
    path = Path(path)
    digest = hashlib.sha256()
    if path.is_dir():
        for file in sorted(_store_files(path)):
            digest.update(file.relative_to(path).as_posix().encode() + b"\0")
            _update(digest, file)
    else:
        _update(digest, path)
    return digest.hexdigest()


def _store_files(root: Path):
    for directory, names, files in os.walk(root):
        names[:] = [name for name in names if not name.startswith(".")]
        for name in files:
            if not name.startswith(".") or name in (".zarray", ".zgroup", ".zattrs"):
                yield Path(directory) / name


def _update(digest, file: Path) -> None:
    with open(file, "rb") as handle:
        while block := handle.read(_CHUNK):
            digest.update(block)


def to_json(record: Mapping[str, Any]) -> str:
    """The record as one line of JSON (exact floats: they read back to the same values)."""
    return json.dumps(_plain(record), separators=(",", ":"), allow_nan=False)


def from_json(text: str | bytes) -> dict[str, Any]:
    """A record read back from :func:`to_json`'s text.

    Raises
    ------
    ProvenanceError
        If the text is not JSON of a record of this schema.
    """
    try:
        record = json.loads(text)
    except (ValueError, TypeError) as exc:
        raise ProvenanceError(f"the provenance record is not JSON: {exc}") from None
    check(record)
    return record


def check(record: Any) -> None:
    """Raise :class:`ProvenanceError` unless ``record`` is a complete record of :data:`SCHEMA`."""
    if not isinstance(record, Mapping):
        raise ProvenanceError(f"a provenance record is a mapping, got {type(record).__name__}")
    schema = record.get("schema")
    if schema != SCHEMA:
        raise ProvenanceError(f"provenance schema {schema!r} is not {SCHEMA!r}")
    missing = [
        key
        for key in ("version", "mode", "function", "preset", "seed", "arguments", "input")
        if key not in record
    ]
    if missing:
        raise ProvenanceError(f"the provenance record lacks {', '.join(missing)}")
    source = record["input"]
    if not isinstance(record["arguments"], Mapping) or not isinstance(source, Mapping):
        raise ProvenanceError("the provenance record's arguments and input must be mappings")
    if not isinstance(source.get("name"), str) or not source["name"]:
        raise ProvenanceError(
            f"the provenance record's input name must be a file name, got {source.get('name')!r}"
        )
    if not isinstance(source.get("sha256"), (str, type(None))):
        raise ProvenanceError(
            f"the provenance record's input sha256 must be a hex digest or null, got "
            f"{source['sha256']!r}"
        )
    if record["mode"] not in FUNCTIONS or FUNCTIONS[record["mode"]] != record["function"]:
        raise ProvenanceError(
            f"the provenance record's mode {record['mode']!r} and function "
            f"{record['function']!r} do not match"
        )


def reproduce_call(record: Mapping[str, Any]) -> tuple[str, dict[str, Any]]:
    """``(mode, arguments)`` for :func:`~napari_labyrinth.labyrinth_steps` from a record.

    ``labyrinth_steps(image, mode, **arguments)`` yields the result the
    record describes (for a sweep, ``arguments`` hold ``parameter`` and
    ``values``).
    """
    check(record)
    arguments = dict(record["arguments"])
    if "noise_gate" not in arguments and "mean_threshold" in arguments:
        arguments["noise_gate"] = 0.0  # a record from before the gate: rendered without it
    if arguments.get("tone_limits") is not None:
        arguments["tone_limits"] = tuple(arguments["tone_limits"])
    return record["mode"], arguments


def _plain(value: Any) -> Any:
    """``value`` with tuples as lists and numpy scalars as Python numbers (JSON-ready)."""
    if isinstance(value, Mapping):
        return {str(k): _plain(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [_plain(v) for v in value]
    if hasattr(value, "item") and not isinstance(value, (str, bytes)):  # numpy scalar
        return value.item()
    return value
