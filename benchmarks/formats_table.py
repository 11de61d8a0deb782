"""The formats of microscopes as the command line reads them: a table of what is read and kept.

Usage::

    python benchmarks/formats_table.py            # the table in markdown, then the versions
    python benchmarks/formats_table.py --keep DIR # keep the files (else a temporary directory)

Needs the ``[formats]`` and ``[dask]`` extras, pylibCZIrw and napari-ome-zarr
(``make formats-table`` makes a venv of them, ``.venv-formats``). It writes,
as other programs write them,

- a 2-D CZI, a z-stack CZI of 2 channels and a CZI of 2 scenes (pylibCZIrw, the
  scenes named in its metadata as in ``tests/io/test_io_bioio.py``);
- an OME-TIFF (bioio's ``OmeTiffWriter``: image name, pixel sizes, channel names);
- an OME-Zarr with its pyramid (the ``ome-zarr`` library: the same);

then renders each with ``napari-labyrinth render`` (2 passes) into an OME-TIFF
and into an OME-Zarr output, timed, and prints for each input the reader the
package read it with, its axes, pixel sizes, channel names and image name, and
whether the outputs keep them (read back with ``io.read_metadata``), whether
the pixels of both outputs equal the API's rendering, and whether the OME-Zarr
output is a valid OME-Zarr 0.5 image (ome-zarr-models), opens in napari-ome-zarr
as a pyramid of more than one level (its full level the API's rendering) and
as layers of a napari viewer. ND2 and LIF files, which nothing on PyPI writes,
are left out. Exits with status 1 if any input is not as expected.
"""

from __future__ import annotations

import argparse
import contextlib
import io as text_io
import os
import shutil
import sys
import tempfile
import time
from importlib.metadata import PackageNotFoundError, version
from pathlib import Path

import numpy as np

from napari_labyrinth import labyrinth
from napari_labyrinth.cli import main
from napari_labyrinth.io import input_format, open_image, read_image, read_metadata

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))  # the CZI writer of the tests

RNG = np.random.default_rng(0)
PASSES, SEED = 2, 1
OPTIONS = ["--passes", str(PASSES), "--seed", str(SEED)]
#: Planes larger than 256 pixels a side, so that an OME-Zarr output has lower levels.
SHAPE = (300, 360)
VERSIONS = ("bioio", "bioio-czi", "bioio-ome-tiff", "pylibCZIrw", "aicspylibczi", "tifffile",
            "zarr", "ome-zarr", "napari-ome-zarr")  # fmt: skip


def textured(shape=SHAPE, high=4000) -> np.ndarray:
    """Smooth blobs plus noise, uint16 from 100 to ``high``."""
    y, x = np.mgrid[: shape[0], : shape[1]]
    phase = RNG.uniform(0, 6)
    base = (
        0.5 + 0.4 * np.sin(x / 7.0 + phase) * np.cos(y / 9.0) + 0.05 * RNG.standard_normal(shape)
    )
    return (100 + np.clip(base, 0, 1) * (high - 100)).astype(np.uint16)


def write_inputs(directory: Path) -> list[tuple[str, Path, str | None]]:
    """(description, input, scene) of every input, written."""
    from bioio.writers import OmeTiffWriter
    from bioio_base.types import PhysicalPixelSizes
    from tests.io.test_io_bioio import write_czi

    inputs = []
    plane = write_czi(
        directory / "plane.czi", {(0, 0, 0): textured()}, name="plane", channels={0: "BF"},
        scale=(0.5e-6, 0.5e-6, None),
    )  # fmt: skip
    inputs.append(("2-D CZI (pylibCZIrw)", plane, None))
    planes = {(0, z, c): textured() for z in range(3) for c in range(2)}
    zstack = write_czi(
        directory / "zstack.czi", planes, name="zstack", channels={0: "DAPI", 1: "GFP"},
        scale=(0.2e-6, 0.2e-6, 1e-6),
    )  # fmt: skip
    inputs.append(("z-stack CZI, 2 channels (pylibCZIrw)", zstack, None))
    scenes = write_czi(
        directory / "scenes.czi", {(0, 0, 0): textured(), (1, 0, 0): textured()}, name="scenes",
        channels={0: "BF"}, scale=(1e-6, 1e-6, None), scenes=("left", "right"),
    )  # fmt: skip
    inputs.append(("CZI of 2 scenes (pylibCZIrw, names added), `--scene right`", scenes, "right"))
    tiff = directory / "cells.ome.tif"
    OmeTiffWriter.save(
        np.stack([np.stack([textured() for _ in range(3)]) for _ in range(2)]), tiff,
        dim_order="CZYX", image_name="cells", channel_names=["DAPI", "GFP"],
        physical_pixel_sizes=PhysicalPixelSizes(2.0, 0.325, 0.325),
    )  # fmt: skip
    inputs.append(("OME-TIFF, `OmeTiffWriter` (bioio-ome-tiff)", tiff, None))
    inputs.append(("OME-Zarr 0.5 with 2 levels (ome-zarr)", write_ome_zarr(directory), None))
    return inputs


def write_ome_zarr(directory: Path) -> Path:
    """A CYX OME-Zarr written by the ome-zarr library: its pyramid, scale, units, image name
    and channel labels."""
    import zarr
    from ome_zarr.writer import write_image

    path = directory / "tissue.ome.zarr"
    window = {"min": 0, "max": 65535, "start": 100, "end": 4000}  # ome-zarr requires one
    group = zarr.open_group(path, mode="w")
    write_image(
        np.stack([textured(), textured()]), group, scale_factors=(2,), name="tissue",
        axes=["c", "y", "x"], scale={"c": 1.0, "y": 0.65, "x": 0.65},
        axes_units={"y": "micrometer", "x": "micrometer"},
        omero={"channels": [{"label": label, "color": colour, "window": window}
                            for label, colour in (("DAPI", "0000FF"), ("GFP", "00FF00"))]},
    )  # fmt: skip
    return path


def reader_of(path: Path) -> str:
    """The reader the package reads ``path`` with: its own, or the bioio plugin bioio
    chooses for it."""
    kind = input_format(path)
    if kind != "BIOIO":
        return {"TIFF": "the package (tifffile)", "ZARR": "the package (zarr)"}.get(kind, kind)
    import bioio

    with contextlib.redirect_stderr(text_io.StringIO()):
        module = type(bioio.BioImage(path).reader).__module__
    return module.split(".")[0].replace("_", "-")


def quiet(argv) -> tuple[int, str, float]:
    """Run the command: its exit code, its stderr and its wall time."""
    err = text_io.StringIO()
    start = time.perf_counter()
    with contextlib.redirect_stderr(err), contextlib.redirect_stdout(text_io.StringIO()):
        code = main(argv)
    return code, err.getvalue(), time.perf_counter() - start


def sizes_text(sizes) -> str:
    if not sizes:
        return "-"
    units = {unit for _, unit in sizes.values()}
    unit = units.pop() if len(units) == 1 else ""
    values = ", ".join(
        f"{k} {v:g}{'' if unit else ' ' + u}" for k, (v, u) in sorted(sizes.items())
    )
    return f"{values} {'µm' if unit == 'micrometer' else unit}".strip()


def name_text(name) -> str:
    return "-" if name is None else f"`{name}`"


def names_text(names) -> str:
    return ", ".join(names) if names else "-"


def one_line(error: Exception) -> str:
    return f"{type(error).__name__}: {' '.join(str(error).split())}"


def napari_ome_zarr_text(path: Path, expected: np.ndarray) -> tuple[str, bool]:
    """How an OME-Zarr output opens: valid for ome-zarr-models or not, what napari-ome-zarr's
    reader gives (levels, layer names) and whether a napari viewer (``ViewerModel``, no Qt)
    takes it; and whether all is well: valid, more than one level, taken by the viewer, and
    the full level napari-ome-zarr reads holding ``expected``."""
    import zarr
    from napari.components import ViewerModel
    from napari_ome_zarr import napari_get_reader
    from ome_zarr_models.common.omero import Omero
    from ome_zarr_models.v05 import Image

    group = zarr.open_group(path, mode="r")
    try:
        Image.from_zarr(group)
        if "omero" in group.attrs["ome"]:
            Omero.model_validate(group.attrs["ome"]["omero"])
        valid = ""
    except Exception as error:  # noqa: BLE001 - pydantic's ValidationError, said in the table
        reason = str(error).splitlines()[-2].strip().split(" [type=")[0]
        valid = f"INVALID ({reason})"
    try:
        with contextlib.redirect_stdout(text_io.StringIO()):  # the reader prints the group
            reader = napari_get_reader(str(path))
            layers = reader(str(path)) if reader is not None else []
    except Exception as error:  # noqa: BLE001 - the reader's failure, said in the table
        return f"{valid or 'valid'}; napari-ome-zarr FAILED ({one_line(error)})", False
    if not layers:
        return f"{valid or 'valid'}; napari-ome-zarr: NO LAYER", False
    data, meta, kind = layers[0]
    levels = len(data)
    try:
        added = getattr(ViewerModel(), f"add_{kind}")(data, **meta)
        names = [layer.name for layer in (added if isinstance(added, list) else [added])]
        shown = f"napari: {', '.join(repr(name) for name in names)}"
    except Exception as error:  # noqa: BLE001 - napari's refusal, said in the table
        shown = f"napari REFUSED ({one_line(error)})"
    text = f"{levels} levels" if levels > 1 else "ONE LEVEL"
    if not np.array_equal(np.asarray(data[0]), expected):
        text += ", its full level NOT the API's rendering"
    ok = not valid and levels > 1 and "NOT" not in text and "REFUSED" not in shown
    return f"{valid or 'valid'}; {text}; {shown}", ok


def run_input(what: str, source: Path, scene: str | None, outputs: Path) -> dict:
    """The row of one input; its ``ok``: every output written, kept and equal to the API's
    rendering, the OME-Zarr output opened as a pyramid."""
    metadata = read_metadata(source, scene=scene)
    image = read_image(source, scene=scene)
    expected = labyrinth(image, channel_axis=metadata.channel_axis, passes=PASSES, seed=SEED)
    row = {
        "file": what,
        "reader": reader_of(source),
        "axes": metadata.axes or "-",
        "pixel sizes": sizes_text(metadata.pixel_sizes),
        "channel names": names_text(metadata.channel_names),
    }
    names, kept, pixels, times = [], [], [], []
    stem = source.name.split(".")[0]
    scene_args = ["--scene", scene] if scene is not None else []
    for label, suffix in (("OME-TIFF", ".ome.tif"), ("OME-Zarr", ".zarr")):
        output = outputs / f"{stem}_labyrinth{suffix}"
        code, err, seconds = quiet(["render", str(source), "-o", str(output), *OPTIONS,
                                    *scene_args])  # fmt: skip
        times.append(f"{seconds:.2f}")
        if code != 0:
            names.append(f"{label}: FAILED")
            kept.append(f"{label}: render FAILED: {' '.join(err.split())}")
            pixels.append(f"{label}: -")
            row["ok"] = False
            continue
        back = read_metadata(output)
        names.append(name_text(back.image_name))
        lost = [
            field
            for field, before, after in (
                ("axes", metadata.axes, back.axes),
                ("sizes", metadata.pixel_sizes, back.pixel_sizes),
                ("names", metadata.channel_names, back.channel_names),
                ("image name", metadata.image_name, back.image_name),
            )
            if before != after
        ]
        kept.append(f"{label}: NOT {', '.join(lost)}" if lost else "")
        written = np.asarray(open_image(output, lazy=False))
        pixels.append("yes" if np.array_equal(written, expected) else f"{label}: NO")
        row["ok"] = row.get("ok", True) and not lost and pixels[-1] == "yes"
        if label == "OME-Zarr":
            row["OME-Zarr output"], opened = napari_ome_zarr_text(output, expected)
            row["ok"] = row["ok"] and opened
    row["image name"] = f"{name_text(metadata.image_name)} → {', '.join(names)}"
    row["kept"] = "; ".join(k for k in kept if k) or "yes, both"
    row["pixels = API"] = "yes, both" if pixels == ["yes", "yes"] else "; ".join(pixels)
    row["render s"] = ", ".join(times)
    return row


def versions_text() -> str:
    def of(name):
        try:
            return version(name)
        except PackageNotFoundError:
            return "not installed"

    return ", ".join(f"{name} {of(name)}" for name in VERSIONS)


def main_(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--keep", metavar="DIR", help="write the files here and keep them")
    args = parser.parse_args(argv)
    directory = Path(args.keep or tempfile.mkdtemp(prefix="formats-table-"))
    directory.mkdir(parents=True, exist_ok=True)
    outputs = directory / "out"
    if outputs.exists():
        shutil.rmtree(outputs)
    outputs.mkdir()
    try:
        rows = [run_input(*entry, outputs) for entry in write_inputs(directory)]
        columns = [
            "file", "reader", "axes", "pixel sizes", "channel names", "image name",
            "kept", "pixels = API", "OME-Zarr output", "render s",
        ]  # fmt: skip
        print("| " + " | ".join(columns) + " |")
        print("|" + "---|" * len(columns))
        for row in rows:
            print("| " + " | ".join(str(row.get(c, "")) for c in columns) + " |")
        print()
        print("reader: the package reads .tif and .zarr itself (tifffile, zarr), whoever wrote "
              "them; bioio (the plugin it chose) reads every other suffix")  # fmt: skip
        print("image name: the input's (io.read_metadata) -> read back from the OME-TIFF and "
              "the OME-Zarr output")  # fmt: skip
        print("kept: the input's axes, pixel sizes, channel names and image name read back from "
              "both outputs")  # fmt: skip
        print(f"pixels = API: both outputs == labyrinth(input, channel_axis=<detected>, "
              f"passes={PASSES}, seed={SEED}), the OME-Zarr output's also as napari-ome-zarr "
              "reads its full level")  # fmt: skip
        print("OME-Zarr output: valid for ome-zarr-models (OME-Zarr 0.5 image, omero channels); "
              "the levels napari-ome-zarr's reader gives; the layers a napari ViewerModel makes "
              "of them")  # fmt: skip
        print(f"render s: wall time of `napari-labyrinth render INPUT -o OUTPUT "
              f"{' '.join(OPTIONS)}` into an OME-TIFF, into an OME-Zarr (numba's kernels "
              "compiled beforehand by the API's rendering)")  # fmt: skip
        print("ND2 and LIF: read by bioio-nd2 and bioio-lif (installed), but no program on PyPI "
              "writes these formats: not in the table.")  # fmt: skip
        print()
        print(f"Versions: {versions_text()}; Python {sys.version.split()[0]}")
        failed = [row["file"] for row in rows if not row["ok"]]
        if failed:
            sys.exit(f"\nNot as expected: {'; '.join(failed)}")
    finally:
        if not args.keep:
            shutil.rmtree(directory, ignore_errors=True)


if __name__ == "__main__":
    os.environ.setdefault("NUMBA_NUM_THREADS", "2")
    main_()
