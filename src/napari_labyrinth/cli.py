"""The ``napari-labyrinth`` command: render image files, or write a demo.

::

    napari-labyrinth render INPUT... -o OUTPUT [options]
    napari-labyrinth demo [-o DIR] [--overwrite]
    napari-labyrinth --version

Heavy modules (numba, tifffile, imageio, tqdm, scikit-image, dask) are
imported only when a command needs them, so ``--help`` answers at once.
Nothing here imports napari or Qt: the command runs without a display.

zarr stores and large TIFF stacks are rendered lazily, block by block (see
``io.open_image`` and ``io.write_array``), locally or on a
``dask.distributed`` cluster (``--scheduler``).
"""

from __future__ import annotations

import argparse
import contextlib
import dataclasses
import functools
import logging
import math
import os
import sys
from collections.abc import Sequence
from pathlib import Path
from typing import Any

PROG = "napari-labyrinth"

#: Exit codes.
EXIT_OK, EXIT_FAILED, EXIT_USAGE, EXIT_INTERRUPTED = 0, 1, 2, 130

#: Samples the demo renders, in order.
DEMO_SAMPLES = ("nematic_schlieren", "camera")

#: Passes of the stack the demo writes.
DEMO_STACK_PASSES = 4

#: Width in pixels of the white band between the panels of the demo's comparison.
SEPARATOR_WIDTH = 4

#: Formats read with imageio whose 3-D images are colour: channel_axis=-1 by default.
_COLOUR_FORMATS = ("PNG", "JPEG", "BMP")

#: Seconds to wait for a dask scheduler given by --scheduler.
SCHEDULER_TIMEOUT = 10


class _UsageError(Exception):
    """A bad combination of arguments: one line on stderr, exit code 2."""


class _Refused(Exception):
    """Files that would be overwritten without --overwrite: exit code 1."""


class _Failed(Exception):
    """Nothing could be rendered (e.g. no dask scheduler): one line, exit code 1."""


def main(argv: Sequence[str] | None = None) -> int:
    """Run the ``napari-labyrinth`` command.

    Parameters
    ----------
    argv : sequence of str, optional
        The arguments after the program name; ``sys.argv[1:]`` by default.

    Returns
    -------
    int
        Exit code: 0 on success, 1 if a file failed or an existing file was
        not overwritten, 2 for a usage or parameter error, 130 on Ctrl-C.
    """
    parser = _build_parser()
    try:
        args = parser.parse_args(argv)
    except SystemExit as exc:  # --help, --version and usage errors
        return exc.code if isinstance(exc.code, int) else (0 if exc.code is None else 1)
    if args.command is None:
        parser.print_help(sys.stderr)
        return EXIT_USAGE
    try:
        return args.run(args)
    except _UsageError as exc:
        _error(str(exc))
        return EXIT_USAGE
    except _Refused as exc:
        for line in exc.args:
            _error(line)
        return EXIT_FAILED
    except _Failed as exc:
        _error(str(exc))
        return EXIT_FAILED
    except KeyboardInterrupt:
        _error("interrupted")
        return EXIT_INTERRUPTED


# -- arguments ------------------------------------------------------------------------------------


def _build_parser() -> argparse.ArgumentParser:
    from . import __version__
    from .presets import DEFAULT_PRESET, PRESETS

    parser = argparse.ArgumentParser(
        prog=PROG,
        description=("Render images with the labyrinthine tiling of Sparavigna & Montrucchio."),
    )
    parser.add_argument("--version", action="version", version=f"{PROG} {__version__}")
    parser.set_defaults(command=None)
    commands = parser.add_subparsers(title="commands", metavar="COMMAND")

    render = commands.add_parser(
        "render",
        help="render image files",
        description=(
            "Render image files (TIFF, PNG, JPEG, BMP) and zarr stores. Parameters not "
            f"given come from the preset (default {DEFAULT_PRESET!r}). The result keeps "
            "the input's shape and dtype; stacks and sweeps are written as TIFF or zarr. "
            "zarr stores and TIFF stacks over 1 GiB are rendered block by block, in "
            "bounded memory."
        ),
    )
    render.set_defaults(command="render", run=_render_command)
    render.add_argument(
        "inputs",
        nargs="+",
        metavar="INPUT",
        help="image file(s) or .zarr store(s) (store.zarr/NAME: an array of a group)",
    )
    render.add_argument(
        "-o",
        "--output",
        required=True,
        metavar="OUTPUT",
        help=(
            "output file or .zarr store (one input; format from its suffix) or directory "
            "(created if missing), where each result is named <stem>_labyrinth<suffix>"
        ),
    )
    render.add_argument(
        "--preset", choices=sorted(PRESETS), help=f"parameter set (default {DEFAULT_PRESET})"
    )
    render.add_argument(
        "--passes", type=int, metavar="N", help="passes over the image (--stack: default 4)"
    )
    render.add_argument("--seed", type=_seed, metavar="S", help="random seed (default 0)")
    render.add_argument(
        "--mean-threshold", type=float, metavar="T", help="t of Eq. 2 (paper: 0.12)"
    )
    render.add_argument(
        "--variance-threshold", type=float, metavar="V", help="V of Eq. 4 (paper: 0.50)"
    )
    render.add_argument(
        "--max-tries", type=int, metavar="K", help="draws of Eq. 3 per pixel (paper preset: 10)"
    )
    render.add_argument(
        "--tone-limits",
        nargs=2,
        type=float,
        metavar=("LOW", "HIGH"),
        help=(
            "values mapped to tones 0 and 255 (default: 0 255 for uint8, else the 0.5th "
            "and 99.5th percentiles, which takes extra reads of a lazily rendered input)"
        ),
    )
    render.add_argument(
        "--channel-axis",
        type=int,
        metavar="A",
        help=(
            "axis of colour channels (default: -1 for RGB(A) PNG/JPEG/BMP files, none for TIFF)"
        ),
    )
    render.add_argument(
        "--set",
        action="append",
        type=_assignment,
        dest="assignments",
        metavar="PARAM=VALUE",
        help=(
            "any other parameter of the algorithm, e.g. --set border=mirror "
            "--set scan=serpentine (repeatable)"
        ),
    )
    variants = render.add_mutually_exclusive_group()
    variants.add_argument(
        "--stack",
        action="store_true",
        help="write the input and the image after every pass: shape (N+1, ...), as TIFF",
    )
    variants.add_argument(
        "--sweep",
        type=_sweep,
        metavar="PARAM=V1,V2,...",
        help=(
            "render once per value of one parameter (e.g. variance_threshold=0.47,0.5,0.53 "
            "or seed=1,2,3): shape (len(values), ...), as TIFF"
        ),
    )
    render.add_argument(
        "--scheduler",
        type=_scheduler_address,
        metavar="ADDRESS",
        help=(
            "render on a dask.distributed cluster: the scheduler's address "
            "(tcp://host:8786), its scheduler file, or local:N to start N worker "
            "processes on this machine; workers need napari-labyrinth and must see the "
            "input and .zarr output paths"
        ),
    )
    render.add_argument(
        "--overwrite", action="store_true", help="replace existing files, inputs included"
    )

    demo = commands.add_parser(
        "demo",
        help="render the built-in samples into a directory",
        description=(
            "Render the synthetic nematic Schlieren texture and the camera photograph "
            "with the default preset; write each input, its rendering, a "
            f"{DEMO_STACK_PASSES}-pass stack (TIFF) and a side-by-side comparison, and "
            "print the path of every file written."
        ),
    )
    demo.set_defaults(command="demo", run=_demo_command)
    demo.add_argument(
        "-o",
        "--output",
        default="labyrinth-demo",
        metavar="DIR",
        help="output directory (default: labyrinth-demo)",
    )
    demo.add_argument("--overwrite", action="store_true", help="replace existing files")
    return parser


def _seed(text: str) -> int:
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"not an integer: {text!r}") from None
    if not 0 <= value < 2**64:
        raise argparse.ArgumentTypeError(f"must be between 0 and 2**64 - 1, got {value}")
    return value


def _scheduler_address(text: str) -> str | int:
    """A scheduler address, or the number of local workers of ``local[:N]``."""
    text = text.strip()
    name, sep, count = text.partition(":")
    if name != "local":
        if not text:
            raise argparse.ArgumentTypeError("empty address")
        return text
    if not sep:
        return os.cpu_count() or 1
    try:
        workers = int(count)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected local:N, got {text!r}") from None
    if not 1 <= workers <= 1024:
        raise argparse.ArgumentTypeError(f"local:N needs 1 <= N <= 1024, got {workers}")
    return workers


def _sweep(text: str) -> tuple[str, list[Any]]:
    name, sep, values = text.partition("=")
    name = name.strip().replace("-", "_")
    if not sep or not name or not values.strip():
        raise argparse.ArgumentTypeError(f"expected PARAM=V1,V2,..., got {text!r}")
    return name, [_parse_value(v.strip()) for v in values.split(",")]


def _assignment(text: str) -> tuple[str, Any]:
    name, sep, value = text.partition("=")
    name = name.strip().replace("-", "_")
    if not sep or not name or not value.strip():
        raise argparse.ArgumentTypeError(f"expected PARAM=VALUE, got {text!r}")
    return name, _parse_value(value.strip())


def _parse_value(text: str) -> Any:
    """A sweep value: int, float, bool or (for choices such as border) the text."""
    for convert in (int, float):
        try:
            return convert(text)
        except ValueError:
            pass
    if text.lower() in ("true", "false"):
        return text.lower() == "true"
    return text


# -- render ---------------------------------------------------------------------------------------


@dataclasses.dataclass
class _Job:
    """One input file and where its result goes."""

    input: Path
    output: Path | None
    error: str | None = None  # known before reading, e.g. an unknown suffix


def _render_command(args: argparse.Namespace) -> int:
    options = _render_options(args)
    jobs, directory = _plan(args)
    _check_overwrites(jobs, overwrite=args.overwrite)
    if directory is not None:
        _make_directory(directory)
    with _scheduler(args.scheduler):
        return _render_jobs(jobs, args, options)


@contextlib.contextmanager
def _scheduler(address: str | int | None):
    """Make a ``dask.distributed`` client the scheduler of dask for the run (None: local)."""
    if address is None:
        yield None
        return
    try:
        from distributed import Client, LocalCluster
    except ImportError:
        raise _UsageError(
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
        elif os.path.isfile(address):
            client = Client(scheduler_file=address, timeout=SCHEDULER_TIMEOUT)
        else:
            client = Client(address, timeout=SCHEDULER_TIMEOUT)
    except Exception as exc:  # OSError, TimeoutError, ValueError for a bad address, ...
        if cluster is not None:
            cluster.close()
        where = f"{address} local workers" if isinstance(address, int) else address
        raise _Failed(f"--scheduler: cannot connect to {where}: {_describe(exc, '')}") from exc
    try:
        yield client
    finally:
        client.close()
        if cluster is not None:
            cluster.close()


def _render_jobs(jobs: list[_Job], args: argparse.Namespace, options: dict[str, Any]) -> int:
    from tqdm import tqdm

    from ._chunked import ComputeError

    show = _isatty(sys.stderr)
    rendered: list[Path] = []
    failed: list[Path] = []
    files_bar = tqdm(
        total=len(jobs), desc="files", unit="file", file=sys.stderr, disable=not show, position=0
    )
    planes_bar = tqdm(
        total=1,
        desc="planes",
        unit="pass",
        file=sys.stderr,
        disable=not show,
        position=1,
        leave=False,
    )

    def progress(done: int, total: int, unit: str = "pass") -> None:
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
                _render_one(job, args, options, progress if show else None)
            except (
                _FileError,
                OSError,
                ValueError,
                TypeError,
                MemoryError,
                ComputeError,
            ) as exc:
                failed.append(job.input)
                tqdm.write(
                    f"{PROG}: error: {job.input}: {_describe(exc, job.input)}", file=sys.stderr
                )
            else:
                rendered.append(job.output)
                tqdm.write(str(job.output), file=sys.stdout)
            files_bar.update()
    finally:
        planes_bar.close()
        files_bar.close()
    _summary(len(rendered), len(jobs), failed)
    return EXIT_FAILED if failed else EXIT_OK


class _FileError(Exception):
    """A per-file problem found before reading the file."""


def _render_options(args: argparse.Namespace) -> dict[str, Any]:
    """Keyword arguments for the API from the command line, validated up front."""
    from .api import resolve_parameters
    from .parameters import PARAMETER_NAMES
    from .presets import DEFAULT_PRESET

    parameters = {
        "passes": args.passes,
        "mean_threshold": args.mean_threshold,
        "variance_threshold": args.variance_threshold,
        "max_tries": args.max_tries,
    }
    parameters = {name: value for name, value in parameters.items() if value is not None}
    for name, value in args.assignments or ():
        if name not in PARAMETER_NAMES:
            raise _UsageError(
                f"--set: unknown parameter {name!r}; use one of {', '.join(PARAMETER_NAMES)}"
            )
        if name in parameters:
            raise _UsageError(f"{name} is given twice")
        parameters[name] = value
    options: dict[str, Any] = dict(parameters)
    if args.preset is not None:
        options["preset"] = args.preset
    if args.seed is not None:
        options["seed"] = args.seed
    if args.tone_limits is not None:
        low, high = args.tone_limits
        if not (math.isfinite(low) and math.isfinite(high) and low < high):
            raise _UsageError(f"--tone-limits must be finite with LOW < HIGH, got {low} {high}")
        options["tone_limits"] = (low, high)

    preset = args.preset or DEFAULT_PRESET
    try:
        resolve_parameters(preset, **parameters)
        if args.sweep is not None:
            _check_sweep(args.sweep, preset, parameters, options)
    except (ValueError, TypeError) as exc:
        raise _UsageError(_one_line(str(exc))) from None
    return options


def _check_sweep(
    sweep: tuple[str, list[Any]],
    preset: str,
    parameters: dict[str, Any],
    options: dict[str, Any],
) -> None:
    from .api import resolve_parameters
    from .parameters import PARAMETER_NAMES

    name, values = sweep
    if name not in PARAMETER_NAMES + ("seed",):
        raise ValueError(
            f"--sweep: unknown parameter {name!r}; use one of "
            f"{', '.join(PARAMETER_NAMES + ('seed',))}"
        )
    if name in options:
        raise ValueError(f"--sweep varies {name}; do not also give it a value")
    for value in values:
        if name == "seed":
            if isinstance(value, bool) or not isinstance(value, int) or not 0 <= value < 2**64:
                raise ValueError(f"--sweep: seed values must be integers >= 0, got {value!r}")
        else:
            resolve_parameters(preset, **parameters, **{name: value})


def _plan(args: argparse.Namespace) -> tuple[list[_Job], Path | None]:
    """The jobs, and the output directory to create (None when writing one file)."""
    from .io import image_format, zarr_root

    inputs = [Path(p) for p in args.inputs]
    output = Path(args.output)
    variant = "stack" if args.stack else "sweep" if args.sweep is not None else None
    to_zarr = output.suffix.lower() == ".zarr"
    if to_zarr and len(inputs) > 1:
        raise _UsageError(f"{output}: several inputs need an output directory, not a zarr store")
    as_directory = not to_zarr and (
        len(inputs) > 1
        or output.is_dir()
        or args.output.endswith(("/", os.sep))
        or output.suffix == ""
    )
    if not as_directory:
        try:
            kind = image_format(output)
        except ValueError as exc:
            raise _UsageError(f"output {_describe(exc, output)}") from None
        if variant is not None and kind not in ("TIFF", "ZARR"):
            raise _UsageError(
                f"--{variant} writes a {variant} of images (more than 2-D); "
                f"give a .tif or .zarr output, not {output.name}"
            )
        return [_Job(inputs[0], output)], None

    if output.exists() and not output.is_dir():
        raise _UsageError(f"{output} is not a directory (several inputs need a directory)")
    jobs = []
    for path in inputs:
        stem, suffix = path.stem, path.suffix
        try:
            kind = image_format(path)
        except ValueError as exc:
            jobs.append(_Job(path, None, error=_describe(exc, path)))
            continue
        if kind == "ZARR":  # store.zarr or store.zarr/array: named after the store
            store = zarr_root(path)[0]
            stem, suffix = store.stem, store.suffix
        elif variant is not None and kind != "TIFF":
            suffix = ".tif"  # a stack or sweep does not fit in a PNG or JPEG
        tail = f"_{variant}" if variant else ""
        jobs.append(_Job(path, output / f"{stem}_labyrinth{tail}{suffix}"))
    return jobs, output


def _check_overwrites(jobs: list[_Job], *, overwrite: bool) -> None:
    """Refuse colliding outputs always, and existing files without --overwrite."""
    from .io import zarr_root

    inputs = {}
    for job in jobs:
        inputs[_key(job.input)] = job.input
        store = zarr_root(job.input)
        if store is not None:  # replacing the store would replace the input
            inputs.setdefault(_key(store[0]), job.input)
    seen: dict[str, Path] = {}
    refused = []
    for job in jobs:
        if job.output is None:
            continue
        key = _key(job.output)
        if key in seen:
            raise _UsageError(
                f"{seen[key]} and {job.input} would both be rendered to {job.output}"
            )
        seen[key] = job.input
        own_input = inputs.get(key) == job.input
        if key in inputs and not own_input:
            raise _UsageError(f"the result of {job.input} would overwrite the input {inputs[key]}")
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
        raise _Refused(*refused)


def _render_one(job: _Job, args: argparse.Namespace, options: dict[str, Any], progress) -> None:
    """Read, render and write one input.

    zarr stores, TIFF stacks over ``LAZY_TIFF_BYTES`` and, with --scheduler,
    every TIFF are opened lazily: the rendering is a dask array written block
    by block (progress counts planes written); the default tone limits of a
    lazy input are found by ``default_tone_limits`` (exact, in bounded
    memory) and reported. Other inputs are rendered in memory (progress
    counts plane-passes).
    """
    from . import api
    from ._chunked import default_tone_limits, is_lazy
    from .io import image_format, open_image, release_files, write_array

    lazy = True if args.scheduler is not None else None
    image = open_image(job.input, lazy=lazy, channel_axis=args.channel_axis)
    channel_axis = args.channel_axis
    if (
        channel_axis is None
        and image_format(job.input) in _COLOUR_FORMATS
        and image.ndim == 3
        and image.shape[-1] in (2, 3, 4)
    ):
        channel_axis = -1
    kwargs = dict(options, channel_axis=channel_axis)
    chunked = is_lazy(image)
    try:
        if not chunked:
            kwargs["progress"] = progress
        elif "tone_limits" not in options and image.dtype.name != "uint8":
            # a lazy rendering is only a graph: building one checks the input (dtype,
            # shape, channel axis) before a scan of the whole data
            api.labyrinth(image, **dict(kwargs, tone_limits=(0.0, 1.0)))
            _note(
                f"{job.input}: finding the default tone limits (0.5th and 99.5th "
                "percentiles) in a pass over the data; --tone-limits skips it"
            )
            low, high = default_tone_limits(image, channel_axis)
            kwargs["tone_limits"] = (low, high)
            _note(f"{job.input}: tone limits {low!r} {high!r}")
        if args.stack:
            result = api.labyrinth_stack(image, **kwargs)
        elif args.sweep is not None:
            name, values = args.sweep
            result = api.labyrinth_sweep(image, name, values, **kwargs)
        else:
            result = api.labyrinth(image, **kwargs)
        extra = 1 if args.stack or args.sweep is not None else 0
        plane_axes = _plane_axes(image.ndim, channel_axis, extra)
        job.output.parent.mkdir(parents=True, exist_ok=True)
        write_array(
            job.output,
            result,
            overwrite=args.overwrite,
            plane_axes=plane_axes,
            progress=functools.partial(progress, unit="plane") if chunked and progress else None,
        )
    finally:
        if chunked:
            release_files()


def _plane_axes(ndim: int, channel_axis: int | None, extra: int) -> tuple[int, ...]:
    """Axes of one plane of a result with ``extra`` axes before those of the image."""
    if channel_axis is None:
        return (extra + ndim - 2, extra + ndim - 1)
    channel = channel_axis % ndim
    spatial = [axis for axis in range(ndim) if axis != channel][-2:]
    return tuple(sorted(extra + axis for axis in (*spatial, channel)))


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


# -- demo -----------------------------------------------------------------------------------------


def _demo_command(args: argparse.Namespace) -> int:
    from .io import write_image
    from .api import labyrinth, labyrinth_stack
    from .samples import SAMPLES

    directory = Path(args.output)
    if directory.exists() and not directory.is_dir():
        raise _UsageError(f"{directory} is not a directory")
    names = {
        sample: (
            directory / f"{sample}.png",
            directory / f"{sample}_labyrinth.png",
            directory / f"{sample}_labyrinth_stack.tif",
            directory / f"{sample}_comparison.png",
        )
        for sample in DEMO_SAMPLES
    }
    if not args.overwrite:
        existing = [p for paths in names.values() for p in paths if os.path.lexists(p)]
        if existing:
            raise _Refused(
                *(
                    f"{p}: refusing to overwrite an existing file (use --overwrite)"
                    for p in existing
                )
            )
    _make_directory(directory)
    for sample, (input_path, rendered_path, stack_path, comparison_path) in names.items():
        image = _to_uint8(SAMPLES[sample]())
        # The uint8 image is what is written and rendered, so that rendering
        # the written PNG with `napari-labyrinth render` gives the same result.
        rendered = labyrinth(image)
        stack = labyrinth_stack(image, passes=DEMO_STACK_PASSES)
        comparison = _side_by_side([image, stack[1], stack[DEMO_STACK_PASSES]])
        for path, data in (
            (input_path, image),
            (rendered_path, rendered),
            (stack_path, stack),
            (comparison_path, comparison),
        ):
            try:
                write_image(path, data, overwrite=args.overwrite)
            except (OSError, ValueError) as exc:
                _error(f"{path}: {_describe(exc, path)}")
                return EXIT_FAILED
            print(path.resolve(), flush=True)
    return EXIT_OK


def _to_uint8(image):
    """uint8 copy of a sample: floats in [0, 1] scaled by 255, other types min-max scaled."""
    import numpy as np

    image = np.asarray(image)
    if image.dtype == np.uint8:
        return image
    if image.dtype.kind == "f":
        return np.rint(np.clip(image, 0.0, 1.0) * 255.0).astype(np.uint8)
    low, high = float(image.min()), float(image.max())
    scaled = (image.astype(np.float64) - low) / ((high - low) or 1.0)
    return np.rint(scaled * 255.0).astype(np.uint8)


def _side_by_side(panels):
    """uint8 panels of equal height in a row, separated by thin white bands."""
    import numpy as np

    height = panels[0].shape[0]
    band = np.full((height, SEPARATOR_WIDTH), 255, dtype=np.uint8)
    row = []
    for index, panel in enumerate(panels):
        if index:
            row.append(band)
        row.append(_to_uint8(panel))
    return np.hstack(row)


# -- helpers --------------------------------------------------------------------------------------


def _make_directory(directory: Path) -> None:
    try:
        directory.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        reason = _describe(exc, directory)
        raise _UsageError(f"{directory}: cannot create the directory: {reason}") from None


def _key(path: Path) -> str:
    """A comparable name for a path (absolute, symbolic links resolved, case as on disk)."""
    return os.path.normcase(os.path.realpath(path))


def _isatty(stream) -> bool:
    try:
        return stream.isatty()
    except (AttributeError, ValueError):
        return False


def _describe(exc: BaseException, path: Path | str) -> str:
    """One line for an error about ``path``, without repeating the path."""
    from .io import ImageFileError

    if isinstance(exc, ImageFileError):
        return _one_line(exc.reason)
    if isinstance(exc, OSError) and exc.strerror:
        text = exc.strerror
        if exc.filename is not None and _key(Path(exc.filename)) != _key(Path(path)):
            text += f": {exc.filename}"
        return _one_line(text)
    text = _one_line(str(exc)) or type(exc).__name__
    prefix = f"{path}: "
    return text.removeprefix(prefix)


def _one_line(text: str) -> str:
    return " ".join(text.split())


def _error(message: str) -> None:
    print(f"{PROG}: error: {message}", file=sys.stderr, flush=True)


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
