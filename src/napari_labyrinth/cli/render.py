"""``napari-labyrinth render``: the outputs of the inputs, overwrite checks, the run.

zarr stores and large TIFF stacks are rendered lazily, block by block, locally
or on a ``dask.distributed`` cluster (``--scheduler``); other inputs in
memory. In a batch a bad file is reported in one line and the others still
render.

Outputs are lossless unless ``--lossy`` says otherwise: a directory batch
writes JPEG (and BMP, which holds no metadata) inputs as PNG, and an explicit
``.jpg`` output is refused without ``--lossy``. The colour axis, axes and
pixel sizes come from the input's own metadata (``io.read_metadata``) and are
written back with the provenance record of the rendering
(:mod:`napari_labyrinth.provenance`).
"""

from __future__ import annotations

import argparse
import asyncio
import contextlib
import dataclasses
import functools
import logging
import os
import sys
from pathlib import Path
from typing import Any

from .. import api
from ..core.parameters import is_auto, without_auto
from ..core.planes import plane_axes
from ..core.presets import DEFAULT_PRESET, resolve_parameters
from ..io import (
    FORMATS,
    FORMATS_WITHOUT_METADATA,
    LOSSY_FORMATS,
    ImageFileError,
    check_output,
    enclosing_zarr_store,
    image_format,
    input_format,
    ome_lost,
    open_image,
    read_metadata,
    release_files,
    write_array,
    zarr_root,
)
from ..lazy import ComputeError, is_lazy, rendering_tone_limits
from ..provenance import file_checksum, input_record, rendering_record
from ..streaming import streams
from ..window import window_for
from ._common import (
    EXIT_FAILED,
    EXIT_OK,
    PROG,
    Failed,
    Refused,
    UsageError,
    cannot_write,
    describe,
    make_directory,
    path_key,
    print_output,
    raise_if_interrupted,
)
from .options import SCHEDULER_TIMEOUT, render_options
from .stream_plane import render_streamed

#: Suffix a directory batch gives the rendering of an input in a lossy format, or in
#: one that holds no provenance record.
LOSSLESS_SUFFIX = ".png"

#: Suffix a directory batch gives the rendering of an input read through bioio (CZI, ND2...):
#: its axes, pixel sizes and channel names are OME's.
BIOIO_SUFFIX = ".ome.tif"

#: What the second progress bar counts: passes over a plane (in memory), planes
#: written (a lazy rendering, computed as it is written), or rows written (a plane
#: larger than memory, rendered band by band).
PROGRESS_LABELS = {"pass": "passes", "plane": "planes written", "row": "rows written"}


@dataclasses.dataclass
class _Job:
    """One input file and where its result goes."""

    input: Path
    output: Path | None
    error: str | None = None  # known before reading, e.g. an unknown suffix


class _FileError(Exception):
    """A per-file problem found before reading the file."""


def render_command(args: argparse.Namespace) -> int:
    """Run ``napari-labyrinth render``; the exit code."""
    options = render_options(args)
    jobs, directory = _plan(args)
    _check_overwrites(jobs, overwrite=args.overwrite)
    if directory is not None:
        make_directory(directory)
    timeout = getattr(args, "scheduler_timeout", None) or SCHEDULER_TIMEOUT
    with _scheduler(args.scheduler, timeout):
        return _render_jobs(jobs, args, options)


@contextlib.contextmanager
def _scheduler(address: str | int | None, timeout: float = SCHEDULER_TIMEOUT):
    """Make a ``dask.distributed`` client the scheduler of dask for the run (None: local)."""
    if address is None:
        yield None
        return
    try:
        from distributed import Client, LocalCluster
    except ImportError:
        raise UsageError(
            "--scheduler needs dask.distributed: pip install 'napari-labyrinth[dask]'"
        ) from None
    cluster = None
    try:
        if isinstance(address, int):
            cluster = LocalCluster(
                n_workers=address,
                threads_per_worker=1,
                processes=True,
                host="127.0.0.1",
                dashboard_address=None,
                silence_logs=logging.CRITICAL,  # a failed block is reported in one line
                # no dashboard; the scheduler's HTTP endpoints on any free loopback port
                scheduler_kwargs={"dashboard": False, "dashboard_address": "127.0.0.1:0"},
            )
            client = Client(cluster)
        else:
            client = Client(_answering_scheduler(address, timeout), timeout=timeout)
    except Failed:
        raise
    except Exception as exc:  # OSError, TimeoutError, ValueError for a bad address, ...
        if cluster is not None:
            cluster.close()
        where = f"{address} local workers" if isinstance(address, int) else address
        raise Failed(f"--scheduler: cannot connect to {where}: {describe(exc, '')}") from exc
    try:
        yield client
    finally:
        client.close()
        if cluster is not None:
            cluster.close()


def _answering_scheduler(address: str, timeout: float) -> str:
    """The address of a dask scheduler that answers within ``timeout`` seconds.

    ``address`` is an address or a scheduler file. A socket that accepts and
    never answers, an HTTP server or a closed port fail after ``timeout``
    seconds, where ``distributed.Client`` alone can wait forever.

    Raises
    ------
    Failed
        One line: what was tried and why it failed.
    """
    if os.path.isfile(address):
        address = _scheduler_file_address(address)
    _note(f"connecting to the dask scheduler at {address} (timeout {timeout:g} s)")
    try:
        reply = asyncio.run(asyncio.wait_for(_identity(address, timeout), timeout))
    except (TimeoutError, asyncio.TimeoutError):
        raise Failed(
            f"--scheduler: no dask scheduler answered at {address} within {timeout:g} s "
            "(--scheduler-timeout sets the wait)"
        ) from None
    except Exception as exc:  # OSError, ValueError for a bad address, a garbled reply
        raise Failed(f"--scheduler: cannot connect to {address}: {describe(exc, '')}") from None
    if not isinstance(reply, dict) or reply.get("type") != "Scheduler":
        raise Failed(f"--scheduler: {address} answered, but not as a dask scheduler")
    return address


async def _identity(address: str, timeout: float):
    """The scheduler's answer to an ``identity`` request."""
    from distributed.comm import connect

    comm = await connect(address, timeout=timeout)
    try:
        await comm.write({"op": "identity", "reply": True})
        return await comm.read()
    finally:
        comm.abort()


def _scheduler_file_address(path: str) -> str:
    """The address a dask scheduler file holds (JSON with an ``"address"``)."""
    import json

    try:
        with open(path, encoding="utf-8") as file:
            content = json.load(file)
    except (OSError, ValueError) as exc:
        raise Failed(
            f'--scheduler: {path} is not a dask scheduler file (JSON with an "address"): '
            f"{describe(exc, path)}"
        ) from None
    address = content.get("address") if isinstance(content, dict) else None
    if not isinstance(address, str) or not address:
        raise Failed(f'--scheduler: {path} is not a dask scheduler file: it has no "address"')
    return address


def _render_jobs(jobs: list[_Job], args: argparse.Namespace, options: dict[str, Any]) -> int:
    from tqdm import tqdm

    show = _isatty(sys.stderr)
    rendered: list[Path] = []
    failed: list[Path] = []
    files_bar = tqdm(
        total=len(jobs), desc="files", unit="file", file=sys.stderr, disable=not show, position=0
    )
    planes_bar = tqdm(
        total=1,
        desc=PROGRESS_LABELS["pass"],
        unit="pass",
        file=sys.stderr,
        disable=not show,
        position=1,
        leave=False,
    )

    def progress(done: int, total: int, unit: str = "pass") -> None:
        raise_if_interrupted()  # after each pass or block: an interrupt lost meanwhile stops here
        if not show:
            return
        planes_bar.set_description_str(PROGRESS_LABELS[unit], refresh=False)
        planes_bar.unit = unit
        planes_bar.total = total
        planes_bar.n = done
        planes_bar.refresh()

    try:
        for job in jobs:
            files_bar.set_postfix_str(job.input.name, refresh=False)
            planes_bar.reset(total=1)
            try:
                if job.error is not None:
                    raise _FileError(job.error)
                _render_one(job, args, options, progress)
            except Exception as exc:  # noqa: BLE001 - one file's failure never stops a batch
                failed.append(job.input)
                tqdm.write(f"{PROG}: error: {_failure(exc, job)}", file=sys.stderr)
            else:
                rendered.append(job.output)
                with tqdm.external_write_mode(file=sys.stdout):  # the bars cleared first
                    print_output(str(job.output))
            files_bar.update()
    finally:
        planes_bar.close()
        files_bar.close()
    _summary(len(rendered), len(jobs), failed)
    return EXIT_FAILED if failed else EXIT_OK


def _failure(exc: Exception, job: _Job) -> str:
    """One line for a file that failed: the output's path and why it cannot be written, or
    the input's path and what went wrong; errors nobody foresaw also name their type."""
    if job.output is not None and (line := cannot_write(exc, job.output)) is not None:
        return line
    text = describe(exc, job.input)
    foreseen = (_FileError, OSError, ValueError, TypeError, MemoryError, ComputeError)
    if not isinstance(exc, foreseen):
        text = f"{type(exc).__name__}: {text}"
    return f"{job.input}: {text}"


def _plan(args: argparse.Namespace) -> tuple[list[_Job], Path | None]:
    """The jobs, and the output directory to create (None when writing one file)."""

    inputs = [Path(p) for p in args.inputs]
    if not args.output.strip():  # Path("") is the current directory
        raise UsageError("-o/--output is empty: name an output file or directory")
    if args.output == "-":
        raise UsageError("-o - (standard output) is not supported: name an output file")
    output = Path(args.output)
    variant = "stack" if args.stack else "sweep" if args.sweep is not None else None
    to_zarr = output.suffix.lower() == ".zarr"
    named_directory = output.is_dir() or args.output.endswith(("/", os.sep))
    if len(inputs) > 1:
        _check_names_a_directory(output, to_zarr, named_directory)
    as_directory = not to_zarr and (len(inputs) > 1 or named_directory or output.suffix == "")
    if not as_directory:
        try:
            kind = image_format(output)
        except ValueError as exc:
            raise UsageError(f"output {describe(exc, output)}") from None
        if variant is not None and kind not in ("TIFF", "ZARR"):
            raise UsageError(
                f"--{variant} writes a {variant} of images (more than 2-D); "
                f"give a .tif or .zarr output, not {output.name}"
            )
        _check_lossless(output, kind, args.lossy)
        return [_Job(inputs[0], output)], None

    if output.exists() and not output.is_dir():
        raise UsageError(f"{output} is not a directory (several inputs need a directory)")
    jobs = []
    for path in inputs:
        stem, suffix = _stem_and_suffix(path)
        kind = input_format(path)
        if kind == "ZARR":  # store.zarr or store.zarr/array: named after the store
            stem, suffix = _stem_and_suffix(zarr_root(path)[0])
        elif kind == "BIOIO":  # read through bioio, with OME metadata: written as OME-TIFF
            suffix = BIOIO_SUFFIX
        elif variant is not None and kind != "TIFF":
            suffix = ".tif"  # a stack or sweep does not fit in a PNG or JPEG
        elif kind in LOSSY_FORMATS + FORMATS_WITHOUT_METADATA and not (
            args.lossy and kind in LOSSY_FORMATS
        ):
            suffix = LOSSLESS_SUFFIX
        tail = f"_{variant}" if variant else ""
        jobs.append(_Job(path, output / f"{stem}_labyrinth{tail}{suffix}"))
    _keep_apart(jobs)
    return jobs, output


def _check_names_a_directory(output: Path, to_zarr: bool, named_directory: bool) -> None:
    """Refuse an output of several inputs that names a file the package writes: a typo, not
    a directory to create (``-o two.png`` made a directory ``two.png``). A directory that
    exists, or a name ending with ``/``, is one."""
    kind = FORMATS.get(output.suffix.lower())
    if kind is None or (named_directory and not to_zarr):
        return
    what = "a zarr store" if to_zarr else f"an image file ({kind})"
    stem, _ = _stem_and_suffix(output)
    raise UsageError(
        f"-o {output}: several inputs need an output directory, not {what}; "
        f"name a directory, e.g. -o {output.with_name(stem)}{os.sep}"
    )


def _stem_and_suffix(path: Path) -> tuple[str, str]:
    """A file's name without its suffix, and the suffix: ``.ome.tif`` and ``.ome.zarr`` whole,
    so that a result is named ``cells_labyrinth.ome.tif`` as OME readers expect (it was
    ``cells.ome_labyrinth.tif``)."""
    stem, suffix = path.stem, path.suffix
    if stem.lower().endswith(".ome") and suffix.lower() in (".tif", ".tiff", ".zarr"):
        return stem[: -len(".ome")], stem[-len(".ome") :] + suffix
    return stem, suffix


def _keep_apart(jobs: list[_Job]) -> None:
    """Name a result after its input's suffix too where two results would share a name.

    ``cells.jpg`` and ``cells.png`` both become PNG files: ``cells_jpg_labyrinth.png``
    and ``cells_labyrinth.png``; the arrays ``group.zarr/raw`` and ``group.zarr/other``
    (results named after their store) become ``group_raw_labyrinth.zarr`` and
    ``group_other_labyrinth.zarr``.
    """

    names: dict[str, int] = {}
    for job in jobs:
        if job.output is not None:
            key = path_key(job.output)
            names[key] = names.get(key, 0) + 1
    for job in jobs:
        if job.output is None or names[path_key(job.output)] < 2:
            continue
        root = zarr_root(job.input)
        if root is not None and root[1]:  # an array of a store: its name in the store
            stem, label = _stem_and_suffix(root[0])[0], root[1].replace("/", "_")
        elif job.input.suffix.lower() != job.output.suffix.lower():
            stem, suffix = _stem_and_suffix(job.input)
            label = suffix.lstrip(".").replace(".", "_").lower()
        else:
            continue
        rest = job.output.name[len(stem) :]
        job.output = job.output.with_name(f"{stem}_{label}{rest}")


def _check_lossless(output: Path, kind: str, lossy: bool) -> None:
    """Refuse a lossy output format without --lossy; note a format without metadata."""

    if kind in LOSSY_FORMATS and not lossy:
        raise UsageError(
            f"{output}: {kind} is lossy: its compression blurs the pixel-scale texture; "
            "write a .png or .tif file, or give --lossy"
        )
    if kind in FORMATS_WITHOUT_METADATA:
        _note(f"{output}: {kind} holds no provenance record; 'reproduce' cannot check it")


def _check_overwrites(jobs: list[_Job], *, overwrite: bool) -> None:
    """Refuse colliding outputs always, and existing files without --overwrite."""

    inputs = {}
    stores = {}  # the zarr stores that hold inputs: nothing is written inside one
    for job in jobs:
        inputs[path_key(job.input)] = job.input
        store = zarr_root(job.input)
        if store is not None:  # replacing the store would replace the input
            inputs.setdefault(path_key(store[0]), job.input)
            stores.setdefault(path_key(store[0]), (store[0], job.input))
    seen: dict[str, Path] = {}
    refused = []
    for job in jobs:
        if job.output is None:
            continue
        key = path_key(job.output)
        for store_key, (store, holder) in stores.items():
            if key != store_key and key.startswith(store_key + os.sep):
                raise UsageError(
                    f"the result of {job.input} would be written inside the zarr store {store}, "
                    f"which holds the input {holder} (it would change the input, and its "
                    "record's checksum): name an output outside it"
                )
            if key == store_key and path_key(holder) != store_key:
                # the input is one array of a group: the group's other members would go too
                raise UsageError(
                    f"the result of {job.input} would replace the zarr store {store}, which "
                    f"holds the input {holder} and whatever else is in it: name an output "
                    "outside it"
                )
        blocking = next((p for p in job.output.parents if os.path.lexists(p)), None)
        if blocking is not None and not blocking.is_dir():  # it said "File exists: /dev/null"
            raise UsageError(
                f"the result of {job.input} would be written to {job.output}, but {blocking} "
                "is not a directory"
            )
        store = enclosing_zarr_store(job.output)
        if store is not None:  # zarr sees no member there: a stray file in someone's store
            raise UsageError(
                f"the result of {job.input} would be written to {job.output}, inside the zarr "
                f"store {store}: name an output outside it"
            )
        if key in seen:
            raise UsageError(f"{seen[key]} and {job.input} would both be rendered to {job.output}")
        seen[key] = job.input
        own_input = inputs.get(key) == job.input
        if key in inputs and not own_input:
            raise UsageError(f"the result of {job.input} would overwrite the input {inputs[key]}")
        if not overwrite and os.path.lexists(job.output):
            if own_input:
                what = "the input file"
            elif job.output.is_dir():
                what = "an existing directory"
            else:
                what = "an existing file"
            refused.append(
                f"{job.output}: refusing to overwrite {what} (use --overwrite to replace it)"
            )
    if refused:
        raise Refused(*refused)


def _render_one(job: _Job, args: argparse.Namespace, options: dict[str, Any], progress) -> None:
    """Read, render and write one input, with its metadata and provenance record.

    zarr stores, TIFF stacks over ``LAZY_TIFF_BYTES`` and, with --scheduler,
    every TIFF are opened lazily: the rendering is a dask array written block
    by block (progress counts planes written); the default tone limits of a
    lazy input are found by ``lazy.rendering_tone_limits`` (exact, in bounded
    memory) and reported. One plane too large to render in memory is
    rendered band by band from file to file (``stream_plane``; progress counts
    rows written). Other inputs are rendered in memory (progress counts
    plane-passes).
    """

    scene = getattr(args, "scene", None)
    metadata = read_metadata(job.input, scene=scene)
    channel_axis = input_channel_axis(metadata, args.channel_axis)
    mode = "stack" if args.stack else "sweep" if "parameter" in options else "single"
    plane = None
    if mode == "single" and channel_axis is None and args.scheduler is None:
        plane = streams(job.input)  # one plane too large for memory: rendered band by band
    if plane is not None:
        _check_colour(job.input, options.get("colour"), plane.shape, channel_axis, {})
        rendered = metadata.with_channel_axis(channel_axis)
        render_streamed(job.input, job.output, plane, rendered, options,
                        overwrite=args.overwrite, progress=progress, note=_note)  # fmt: skip
        return
    lazy = True if args.scheduler is not None else None
    image = open_image(job.input, lazy=lazy, channel_axis=channel_axis, scene=scene)
    if image.dtype.kind == "b":  # a 1-bit PNG or TIFF: the API would name only its dtype
        raise ImageFileError(
            job.input,
            "is a 1-bit (black and white) image: the labyrinth draws in grey levels; "
            "save it as 8-bit grey",
        )
    if metadata.ambiguous and args.channel_axis is None:
        *planes, rows, columns = image.shape
        _note(
            f"{job.input}: shape {tuple(image.shape)} has no colour metadata: read as "
            f"{'x'.join(map(str, planes))} planes of {rows}x{columns} pixels; "
            "--channel-axis -1 reads the last axis as RGB(A)"
        )
    kwargs = dict(options, channel_axis=channel_axis)
    if channel_axis == metadata.channel_axis:
        refusal = metadata.unrenderable_samples()
        if refusal is not None:
            raise ImageFileError(job.input, refusal)
        if metadata.grey_alpha:
            kwargs["alpha"] = True  # the file says grey + alpha: alpha is kept, never rendered
        elif metadata.kept_unspecified_sample():
            _note(
                f"{job.input}: its fourth sample is an unspecified extra sample (not alpha): "
                "kept as it is, not rendered, as alpha would be"
            )
    _check_colour(job.input, options.get("colour"), image.shape, channel_axis, kwargs)
    extra = 0 if mode == "single" else 1
    rendered = metadata.with_channel_axis(channel_axis)  # as --channel-axis read it
    chunked = is_lazy(image)
    try:
        shape, written = _result_shape(image.shape, mode, kwargs), rendered.for_output(
            "Q" if extra else None, None
        )
        # before the rendering, and a lazy input's pass for its limits: refused now
        check_output(job.output, shape, image.dtype, overwrite=args.overwrite, metadata=written)
        lost = ome_lost(job.output, shape, written)
        if lost is not None:
            _note(f"{job.output}: {lost}")
        if chunked and "tone_limits" not in options and image.dtype.name != "uint8":
            # a lazy rendering is only a graph: building one checks the input (dtype,
            # shape, channel axis) before a scan of the whole data; V=auto is chosen
            # once, below, on the tone limits found
            api.labyrinth_steps(image, mode, **dict(without_auto(kwargs), tone_limits=(0.0, 1.0)))
            _note(
                f"{job.input}: finding the default tone limits (0.5th and 99.5th "
                "percentiles) in a pass over the data; --tone-limits skips it"
            )
            low, high = rendering_tone_limits(  # as the API finds them (alpha left out)
                image, channel_axis=channel_axis, alpha=kwargs.get("alpha"),
                colour=options.get("colour"),
            )  # fmt: skip
            kwargs["tone_limits"] = (low, high)
            _note(f"{job.input}: tone limits {low!r} {high!r}")
        _choose_auto_threshold(job, image, kwargs)
        steps = api.labyrinth_steps(image, mode, **kwargs)  # checks every argument first
        for event in steps:
            if isinstance(event, api.Result):
                result, limits, sigma = event.image, event.tone_limits, event.noise_sigma
            else:
                progress(event.done, event.total)
        source = input_record(
            job.input, image.shape, image.dtype, file_checksum(job.input), scene=metadata.scene
        )
        record = rendering_record(
            mode, kwargs, source=source, tone_limits=limits, noise_sigma=sigma
        )
        job.output.parent.mkdir(parents=True, exist_ok=True)
        write_array(
            job.output,
            result,
            overwrite=args.overwrite,
            plane_axes=plane_axes(image.ndim, channel_axis, extra),
            progress=functools.partial(progress, unit="plane") if chunked else None,
            metadata=rendered.for_output("Q" if extra else None, record),
        )
    finally:
        if chunked:
            release_files()


def _check_colour(path: Path, colour, shape, channel_axis, kwargs: dict[str, Any]) -> None:
    """Refuse ``--colour`` for an image it cannot apply to, in the command line's words
    (the API's message names its own keywords, which the user never gave)."""

    if colour is None:
        return
    if channel_axis is None:
        raise ImageFileError(
            path,
            f"--colour {colour} applies to colour images, and this one has no colour axis "
            "(the file declares none; --channel-axis names one)",
        )
    alpha = bool(kwargs.get("alpha")) or shape[channel_axis] == 4  # a 4th channel: alpha
    colours = shape[channel_axis] - alpha
    if colour == "luminance" and colours != 3:
        what = f"{colours} colour channel(s) and alpha" if alpha else f"{colours} channel(s)"
        raise ImageFileError(
            path,
            f"--colour luminance needs red, green and blue, and this image has {what}; "
            "--colour channels renders each channel on its own",
        )


def _result_shape(shape: tuple[int, ...], mode: str, kwargs: dict[str, Any]) -> tuple[int, ...]:
    """The shape of a rendering of an image of ``shape``: a leading axis of the input and
    every pass (stack), or of the values (sweep)."""
    if mode == "stack":
        passes = kwargs.get("passes")
        if passes is None:  # the preset's
            passes = resolve_parameters(kwargs.get("preset", DEFAULT_PRESET)).passes
        return (passes + 1, *shape)
    if mode == "sweep":
        return (len(kwargs["values"]), *shape)
    return tuple(shape)


def _choose_auto_threshold(job: _Job, image, kwargs: dict[str, Any]) -> None:
    """``variance_threshold=auto``: choose V on this image (find_window) and report it."""
    if not is_auto(kwargs.get("variance_threshold")):
        return
    options = {k: v for k, v in kwargs.items() if k not in ("parameter", "values")}
    window = window_for(image, **options)
    kwargs["variance_threshold"] = window.best
    _note(f"{job.input}: variance threshold auto: {window.summary()}")


def input_channel_axis(metadata, given: int | str | None) -> int | None:
    """The channel axis of an input: ``--channel-axis`` if given, else what the file says."""
    if given == "none":
        return None
    return metadata.channel_axis if given is None else given


def _note(message: str) -> None:
    """An informational line on stderr (kept apart from progress bars)."""
    from tqdm import tqdm

    tqdm.write(f"{PROG}: {message}", file=sys.stderr)


def _summary(done: int, total: int, failed: list[Path]) -> None:
    noun = "file" if total == 1 else "files"
    if failed:
        names = ", ".join(str(path) for path in failed)
        print(f"{PROG}: rendered {done} of {total} {noun}; failed: {names}", file=sys.stderr)
    else:
        print(f"{PROG}: rendered {done} {noun}", file=sys.stderr)


def _isatty(stream) -> bool:
    try:
        return stream.isatty()
    except (AttributeError, ValueError):
        return False
