"""The file cases of the command line: what is detected, what a round trip keeps. Prints tables.

Usage::

    python benchmarks/file_cases.py            # a table in markdown, then the JPEG loss
    python benchmarks/file_cases.py --keep DIR # keep the files (else a temporary directory)

For each case (format x colour x bit depth x metadata) it writes a small input
with tifffile, imageio or zarr as another program would, then

- reads its metadata (``io.read_metadata``): axes, colour axis and how it was
  found, physical pixel sizes, whether the layout is ambiguous;
- renders it with ``napari-labyrinth render`` (2 passes) into a lossless output
  of the same family (PNG -> PNG, JPEG -> PNG through a directory batch,
  TIFF -> TIFF, zarr -> zarr) and checks that the output's pixels equal the
  API's rendering of the input read with the detected colour axis, that its
  axes and pixel sizes are the input's, and that ``napari-labyrinth reproduce``
  finds it identical bit for bit;
- last, the loss a JPEG output would bring: the camera image rendered once and
  written as PNG and as JPEG (``--lossy``), the difference in grey levels.

Nothing is timed unless ``--checksum-mb N`` asks for the speed of the input
checksum every output records (SHA-256 of the input file: one more read of it),
on an N MB file, best of 3, printed beside the machine's load.
"""

from __future__ import annotations

import argparse
import contextlib
import io as text_io
import os
import shutil
import tempfile
from pathlib import Path

import numpy as np

from napari_labyrinth import labyrinth
from napari_labyrinth.cli import main
from napari_labyrinth.io import open_image, read_image, read_metadata

RNG = np.random.default_rng(0)
OPTIONS = ["--passes", "2", "--seed", "1"]


def textured(shape, dtype=np.uint8):
    """Smooth blobs plus noise, scaled to the dtype's range (uint16: 100-4000)."""
    y, x = np.mgrid[: shape[0], : shape[1]]
    base = 0.5 + 0.4 * np.sin(x / 7.0) * np.cos(y / 9.0) + 0.05 * RNG.standard_normal(shape)
    base = np.clip(base, 0, 1)
    if np.dtype(dtype) == np.uint16:
        return (100 + base * 3900).astype(np.uint16)
    return (base * 255).astype(np.uint8)


def colour(shape, channels=3):
    return np.stack([textured(shape) for _ in range(channels)], axis=-1)


def write_cases(directory: Path) -> list[tuple[str, str, Path, Path]]:
    """(format, description, input, output) of every case, inputs written."""
    import imageio.v3 as iio
    import tifffile
    import zarr

    shape = (48, 64)
    cases = []

    def case(fmt, what, name, output):
        cases.append((fmt, what, directory / name, directory / "out" / output))

    iio.imwrite(directory / "grey8.png", textured(shape))
    case("PNG", "grey, uint8", "grey8.png", "grey8_labyrinth.png")
    iio.imwrite(directory / "grey16.png", textured(shape, np.uint16))
    case("PNG", "grey, uint16", "grey16.png", "grey16_labyrinth.png")
    iio.imwrite(directory / "rgb.png", colour(shape))
    case("PNG", "RGB, uint8", "rgb.png", "rgb_labyrinth.png")
    iio.imwrite(directory / "rgba.png", colour(shape, 4))
    case("PNG", "RGBA, uint8", "rgba.png", "rgba_labyrinth.png")
    iio.imwrite(directory / "la.png", colour(shape, 2), mode="LA")
    case("PNG", "grey + alpha, uint8", "la.png", "la_labyrinth.png")
    from PIL import Image

    Image.fromarray(colour(shape)).quantize(64).save(directory / "palette.png")
    case("PNG", "palette (64 colours)", "palette.png", "palette_labyrinth.png")
    iio.imwrite(directory / "grey.jpg", textured(shape))
    case("JPEG", "grey, uint8", "grey.jpg", "jpeg/grey_labyrinth.png")
    iio.imwrite(directory / "rgb.jpg", colour(shape))
    case("JPEG", "RGB, uint8", "rgb.jpg", "jpeg/rgb_labyrinth.png")
    tifffile.imwrite(directory / "grey.tif", textured(shape))
    case("TIFF", "grey, uint8", "grey.tif", "grey_labyrinth.tif")
    tifffile.imwrite(directory / "rgb.tif", colour(shape), photometric="rgb")
    case("TIFF", "RGB (photometric), uint8", "rgb.tif", "rgb_labyrinth.tif")
    stack = np.stack([textured(shape, np.uint16) for _ in range(3)])
    tifffile.imwrite(directory / "stack16.tif", stack, photometric="minisblack")
    case("TIFF", "3-plane stack, uint16", "stack16.tif", "stack16_labyrinth.tif")
    tifffile.imwrite(directory / "grey3.tif", colour(shape), photometric="minisblack")
    case("TIFF", "(48, 64, 3) as grey, uint8", "grey3.tif", "grey3_labyrinth.tif")
    sizes = {"PhysicalSizeX": 0.325, "PhysicalSizeY": 0.325, "PhysicalSizeZ": 2.0}
    tifffile.imwrite(
        directory / "zstack.ome.tif", stack, ome=True, metadata={"axes": "ZYX", **sizes}
    )
    case("OME-TIFF", "ZYX, uint16, sizes", "zstack.ome.tif", "zstack_labyrinth.ome.tif")
    tifffile.imwrite(
        directory / "rgb.ome.tif",
        colour(shape),
        ome=True,
        photometric="rgb",
        metadata={"axes": "YXS", "PhysicalSizeX": 0.5, "PhysicalSizeY": 0.5},
    )
    case("OME-TIFF", "RGB YXS, uint8, sizes", "rgb.ome.tif", "rgb_labyrinth.ome.tif")
    zarr.create_array(directory / "movie.zarr", shape=stack.shape, dtype="uint16")[...] = stack
    case("zarr", "3-plane stack, uint16", "movie.zarr", "movie_labyrinth.zarr")
    zarr.create_array(directory / "rgb.zarr", shape=shape + (3,), dtype="uint8")[...] = colour(
        shape
    )
    case("zarr", "(48, 64, 3), uint8", "rgb.zarr", "rgb_labyrinth.zarr")
    for version in ("0.4", "0.5"):
        name = f"v{version[-1]}.ome.zarr"
        zarr_format = 2 if version == "0.4" else 3
        group = zarr.open_group(directory / name, mode="w", zarr_format=zarr_format)
        group.create_array("0", shape=stack.shape, dtype="uint16")[...] = stack
        axes = [{"name": n, "type": "space", "unit": "micrometer"} for n in "zyx"]
        scale = {"type": "scale", "scale": [2.0, 0.325, 0.325]}
        dataset = {"path": "0", "coordinateTransformations": [scale]}
        multiscale = {"axes": axes, "datasets": [dataset]}
        if version == "0.4":
            group.attrs["multiscales"] = [dict(multiscale, version="0.4")]
        else:
            group.attrs["ome"] = {"version": "0.5", "multiscales": [multiscale]}
        case("OME-Zarr", f"{version}, ZYX, uint16, sizes", name, f"v{version[-1]}_labyrinth.zarr")
    return cases


def quiet(argv) -> tuple[int, str]:
    """Run the command; its exit code and its stderr."""
    err = text_io.StringIO()
    with contextlib.redirect_stderr(err), contextlib.redirect_stdout(text_io.StringIO()):
        code = main(argv)
    return code, err.getvalue()


def sizes_text(sizes) -> str:
    if not sizes:
        return "-"
    return " ".join(f"{k}={v:g}{' ' + u if u else ''}" for k, (v, u) in sorted(sizes.items()))


def run_case(fmt, what, source: Path, output: Path) -> dict:
    metadata = read_metadata(source)
    target = output.parent if fmt == "JPEG" else output  # JPEG: a directory batch
    target = str(target) + ("/" if fmt == "JPEG" else "")
    code, err = quiet(["render", str(source), "-o", target, *OPTIONS])
    row = {
        "format": fmt,
        "input": what,
        "axes": metadata.axes or "-",
        "colour": (
            f"axis {metadata.channel_axis} ({metadata.colour})"
            if metadata.channel_axis is not None
            else (metadata.colour or "none")
        ),
        "sizes": sizes_text(metadata.pixel_sizes),
        "note": "ambiguous: note" if "no colour metadata" in err else "",
    }
    if code != 0:
        row.update(output=output.name, pixels=f"render failed: {err.strip()}")
        return row
    written = np.asarray(open_image(output, lazy=False))
    image = np.asarray(open_image(source, lazy=False))
    if metadata.grey_alpha:
        expected = np.stack([labyrinth(image[..., 0], passes=2, seed=1), image[..., 1]], -1)
    else:
        expected = labyrinth(image, channel_axis=metadata.channel_axis, passes=2, seed=1)
    back = read_metadata(output)
    code, _ = quiet(["reproduce", str(output)])
    row.update(
        output=output.name if fmt != "JPEG" else f"jpeg/{output.name} (directory batch)",
        pixels="yes" if np.array_equal(written, expected) else "NO",
        axes_kept="yes" if back.axes == metadata.axes else f"{back.axes} (was {metadata.axes})",
        sizes_kept=(
            "yes" if back.pixel_sizes == metadata.pixel_sizes else sizes_text(back.pixel_sizes)
        ),
        reproduce="identical" if code == 0 else "DIFFERS",
    )
    return row


def jpeg_loss(directory: Path) -> str:
    from skimage import data

    import imageio.v3 as iio

    iio.imwrite(directory / "camera.png", data.camera())
    quiet(["render", str(directory / "camera.png"), "-o", str(directory / "camera_l.png")])
    jpeg = str(directory / "camera_l.jpg")
    quiet(["render", str(directory / "camera.png"), "-o", jpeg, "--lossy"])
    png = read_image(directory / "camera_l.png").astype(int)
    jpg = read_image(directory / "camera_l.jpg").astype(int)
    diff = np.abs(png - jpg)
    refused, err = quiet(["render", str(directory / "camera.png"), "-o", str(directory / "x.jpg")])
    return (
        f"camera (512x512) rendered with the default preset, written as PNG and as JPEG "
        f"(quality 95, --lossy): mean |difference| {diff.mean():.1f} grey levels, max "
        f"{diff.max()}, {np.count_nonzero(diff) / diff.size:.0%} of pixels changed.\n"
        f"Without --lossy: exit code {refused}, {err.strip()}"
    )


def checksum_speed(directory: Path, megabytes: int) -> str:
    import time

    from napari_labyrinth.provenance import file_checksum

    path = directory / "checksum.bin"
    path.write_bytes(RNG.integers(0, 256, megabytes << 20, dtype=np.uint8).tobytes())
    best = float("inf")
    for _ in range(3):
        start = time.perf_counter()
        file_checksum(path)
        best = min(best, time.perf_counter() - start)
    load = " ".join(f"{v:.2f}" for v in os.getloadavg())
    return (
        f"SHA-256 of a {megabytes} MB input (the checksum in every record): best of 3 "
        f"{best:.3f} s = {megabytes / best:.0f} MB/s (file in the page cache); load {load}"
    )


def main_(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--keep", metavar="DIR", help="write the files here and keep them")
    parser.add_argument("--checksum-mb", type=int, metavar="N", help="time the input checksum")
    args = parser.parse_args(argv)
    directory = Path(args.keep or tempfile.mkdtemp(prefix="file-cases-"))
    directory.mkdir(parents=True, exist_ok=True)
    (directory / "out").mkdir(exist_ok=True)
    try:
        rows = [run_case(*case) for case in write_cases(directory)]
        columns = [
            "format", "input", "axes", "colour", "sizes", "note",
            "output", "pixels", "axes_kept", "sizes_kept", "reproduce",
        ]
        print("| " + " | ".join(columns) + " |")
        print("|" + "---|" * len(columns))
        for row in rows:
            print("| " + " | ".join(str(row.get(c, "")) for c in columns) + " |")
        print()
        print("pixels: output == labyrinth(input, channel_axis=<detected>, passes=2, seed=1)")
        print("axes_kept / sizes_kept: read back from the output")
        print("reproduce: `napari-labyrinth reproduce OUTPUT` (exit code 0: identical)")
        print()
        print(jpeg_loss(directory))
        if args.checksum_mb:
            print(checksum_speed(directory, args.checksum_mb))
    finally:
        if not args.keep:
            shutil.rmtree(directory, ignore_errors=True)


if __name__ == "__main__":
    os.environ.setdefault("NUMBA_NUM_THREADS", "2")
    main_()
