"""Image file reading and atomic writing for the command line."""

from __future__ import annotations

import os
import sys
from pathlib import Path

import numpy as np
import pytest

from napari_labyrinth import io as file_io
from napari_labyrinth.io import ImageFileError, read_image, write_image

RNG = np.random.default_rng(0)


def leftovers(directory) -> list[str]:
    """Temporary files left in a directory."""
    return [name for name in os.listdir(directory) if name.endswith(".tmp")]


@pytest.mark.parametrize(
    "array",
    [
        RNG.integers(0, 256, (12, 17), dtype=np.uint8),
        RNG.integers(0, 65536, (12, 17), dtype=np.uint16),
        RNG.integers(-100, 100, (12, 17), dtype=np.int16),
        RNG.random((12, 17), dtype=np.float32),
        RNG.random((12, 17)).astype(np.float16),
        RNG.random((3, 12, 17)),
        RNG.integers(0, 256, (12, 17, 3), dtype=np.uint8),
        RNG.integers(0, 256, (5, 12, 17, 4), dtype=np.uint8),
        RNG.random((2, 3, 12, 17), dtype=np.float32),
        RNG.random((12, 17)) > 0.5,
    ],
    ids=lambda a: f"{a.dtype}-{'x'.join(map(str, a.shape))}",
)
@pytest.mark.parametrize("suffix", [".tif", ".tiff"])
def test_tiff_round_trip_any_dtype_and_dimensions(tmp_path, array, suffix):
    path = tmp_path / f"image{suffix}"
    assert write_image(path, array) == path
    back = read_image(path)
    assert back.dtype == array.dtype and back.shape == array.shape
    np.testing.assert_array_equal(back, array)
    assert leftovers(tmp_path) == []


@pytest.mark.parametrize(
    "array",
    [
        RNG.integers(0, 256, (12, 17), dtype=np.uint8),
        RNG.integers(0, 256, (12, 17, 2), dtype=np.uint8),
        RNG.integers(0, 256, (12, 17, 3), dtype=np.uint8),
        RNG.integers(0, 256, (12, 17, 4), dtype=np.uint8),
        RNG.integers(0, 65536, (12, 17), dtype=np.uint16),
    ],
    ids=lambda a: f"{a.dtype}-{'x'.join(map(str, a.shape))}",
)
def test_png_round_trip(tmp_path, array):
    path = tmp_path / "image.png"
    write_image(path, array)
    back = read_image(path)
    assert back.dtype == array.dtype
    np.testing.assert_array_equal(back, array)


@pytest.mark.parametrize("shape", [(12, 17), (12, 17, 3)])
@pytest.mark.parametrize("suffix", [".jpg", ".jpeg", ".JPG", ".bmp"])
def test_jpeg_and_bmp_round_trip(tmp_path, shape, suffix):
    array = np.full(shape, 100, dtype=np.uint8)
    array[3:9, 4:12] = 180
    path = tmp_path / f"image{suffix}"
    write_image(path, array)
    back = read_image(path)
    assert back.shape == array.shape and back.dtype == np.uint8
    tolerance = 0 if suffix == ".bmp" else 12  # JPEG is lossy
    assert np.abs(back.astype(int) - array).max() <= tolerance


@pytest.mark.parametrize(
    ("suffix", "array"),
    [
        (".png", np.zeros((8, 8), np.float32)),
        (".png", np.zeros((3, 8, 8), np.uint8)),
        (".png", np.zeros((2, 8, 8, 3), np.uint8)),
        (".png", np.zeros((8, 8, 3), np.uint16)),
        (".jpg", np.zeros((8, 8), np.uint16)),
        (".jpg", np.zeros((8, 8, 4), np.uint8)),
        (".jpg", np.zeros((8, 8), np.float64)),
        (".bmp", np.zeros((8, 8), np.int8)),
    ],
)
def test_unstorable_arrays_suggest_tiff(tmp_path, suffix, array):
    path = tmp_path / f"out{suffix}"
    with pytest.raises(ValueError, match=r"\.tif") as info:
        write_image(path, array)
    assert str(path) in str(info.value)
    assert not path.exists()
    assert leftovers(tmp_path) == []


def test_unknown_suffix(tmp_path):
    with pytest.raises(ValueError, match=r"out\.xyz.*unknown image format"):
        write_image(tmp_path / "out.xyz", np.zeros((4, 4), np.uint8))
    (tmp_path / "in.xyz").write_bytes(b"data")
    with pytest.raises(ValueError, match=r"in\.xyz"):
        read_image(tmp_path / "in.xyz")


@pytest.mark.parametrize("suffix", [".png", ".tif", ".jpg", ".bmp"])
def test_corrupt_file_is_a_value_error_naming_it(tmp_path, suffix):
    path = tmp_path / f"broken{suffix}"
    path.write_bytes(b"this is not an image at all" * 10)
    with pytest.raises(ImageFileError) as info:
        read_image(path)
    assert isinstance(info.value, ValueError)
    assert str(path) in str(info.value)
    assert "\n" not in str(info.value)


def test_truncated_png(tmp_path):
    path = tmp_path / "cut.png"
    write_image(path, RNG.integers(0, 256, (64, 64), dtype=np.uint8))
    path.write_bytes(path.read_bytes()[:100])
    with pytest.raises(ValueError, match="cut.png"):
        read_image(path)


def test_missing_file(tmp_path):
    with pytest.raises(FileNotFoundError, match="nothing.png"):
        read_image(tmp_path / "nothing.png")


def test_directory_is_not_an_image(tmp_path):
    (tmp_path / "dir.png").mkdir()
    with pytest.raises(ValueError, match="directory"):
        read_image(tmp_path / "dir.png")
    with pytest.raises(ValueError, match="directory"):
        write_image(tmp_path / "dir.png", np.zeros((4, 4), np.uint8), overwrite=True)


def test_refuses_to_overwrite_without_flag(tmp_path):
    path = tmp_path / "out.png"
    path.write_bytes(b"precious")
    with pytest.raises(FileExistsError, match="out.png"):
        write_image(path, np.zeros((4, 4), np.uint8))
    assert path.read_bytes() == b"precious"
    assert leftovers(tmp_path) == []
    write_image(path, np.ones((4, 4), np.uint8), overwrite=True)
    np.testing.assert_array_equal(read_image(path), np.ones((4, 4), np.uint8))
    assert leftovers(tmp_path) == []


def test_file_appearing_during_the_write_is_not_clobbered(tmp_path, monkeypatch):
    path = tmp_path / "out.tif"
    real_write = file_io._write

    def write_then_race(handle, *args):
        real_write(handle, *args)
        path.write_bytes(b"someone else")

    monkeypatch.setattr(file_io, "_write", write_then_race)
    with pytest.raises(FileExistsError):
        write_image(path, np.zeros((4, 4), np.uint8))
    assert path.read_bytes() == b"someone else"
    assert leftovers(tmp_path) == []


def test_failed_write_leaves_nothing_behind(tmp_path, monkeypatch):
    import tifffile

    def broken(file, *args, **kwargs):
        file.write(b"half a file")
        raise OSError(28, "No space left on device")

    monkeypatch.setattr(tifffile, "imwrite", broken)
    path = tmp_path / "out.tif"
    with pytest.raises(OSError, match="No space"):
        write_image(path, np.zeros((4, 4), np.uint8))
    assert os.listdir(tmp_path) == []


def test_failed_overwrite_keeps_the_old_file(tmp_path, monkeypatch):
    path = tmp_path / "out.png"
    write_image(path, np.full((4, 4), 7, np.uint8))
    before = path.read_bytes()

    def interrupted(*args, **kwargs):
        raise KeyboardInterrupt

    monkeypatch.setattr(file_io, "_write", interrupted)
    with pytest.raises(KeyboardInterrupt):
        write_image(path, np.zeros((4, 4), np.uint8), overwrite=True)
    assert path.read_bytes() == before
    assert leftovers(tmp_path) == []


@pytest.mark.skipif(sys.platform == "win32", reason="POSIX permissions")
def test_written_file_has_ordinary_permissions(tmp_path):
    umask = os.umask(0o022)
    os.umask(umask)
    path = tmp_path / "out.tif"
    write_image(path, np.zeros((4, 4), np.uint8))
    assert path.stat().st_mode & 0o777 == 0o666 & ~umask


def test_input_array_is_not_modified(tmp_path):
    array = RNG.integers(0, 256, (6, 6, 3), dtype=np.uint8)
    copy = array.copy()
    write_image(tmp_path / "a.png", array)
    write_image(tmp_path / "a.tif", array)
    np.testing.assert_array_equal(array, copy)


# -- metadata: colour, axes, pixel sizes, provenance ----------------------------------------------

RECORD = {
    "schema": "napari-labyrinth/provenance/1",
    "version": "0.1.0",
    "mode": "single",
    "function": "labyrinth",
    "preset": "labyrinth",
    "seed": 3,
    "arguments": {"preset": "labyrinth", "seed": 3, "tone_limits": [0.1, 1 / 3]},
    "input": {"name": "in.tif", "sha256": "ab", "shape": [4, 5], "dtype": "uint8"},
}


HALF_MICRON = {"X": (0.5, "micrometer"), "Y": (0.5, "micrometer")}


def _write_case(path, case):
    """Write one file case of ``test_metadata_of_each_file_case``."""
    import imageio.v3 as iio
    import tifffile
    import zarr

    rng = np.random.default_rng(1)
    grey = rng.integers(0, 256, (12, 17), dtype=np.uint8)
    colour = {2: "LA", 3: "RGB", 4: "RGBA"}
    if case.startswith("png-"):
        channels = int(case[4:])
        data = grey if channels == 1 else rng.integers(0, 256, (12, 17, channels), np.uint8)
        iio.imwrite(path, data, plugin="pillow", mode=colour.get(channels, "L"))
    elif case == "jpeg-rgb":
        iio.imwrite(path, rng.integers(0, 256, (12, 17, 3), np.uint8))
    elif case == "jpeg-grey":
        iio.imwrite(path, grey)
    elif case == "tiff-rgb":
        tifffile.imwrite(path, rng.integers(0, 256, (12, 17, 3), np.uint8), photometric="rgb")
    elif case == "tiff-grey-3":
        data = rng.integers(0, 256, (12, 17, 3), np.uint8)
        tifffile.imwrite(path, data, photometric="minisblack")
    elif case == "tiff-16-stack":
        data = rng.integers(0, 65536, (3, 12, 17), np.uint16)
        tifffile.imwrite(path, data, photometric="minisblack")
    elif case == "tiff-planar-rgb":
        data = rng.integers(0, 65536, (3, 12, 17), np.uint16)
        tifffile.imwrite(path, data, photometric="rgb", planarconfig="separate")
    elif case == "ome-tiff":
        tifffile.imwrite(
            path,
            rng.integers(0, 65536, (2, 3, 12, 17), np.uint16),
            ome=True,
            metadata={
                "axes": "TZYX",
                "PhysicalSizeX": 0.25,
                "PhysicalSizeY": 0.25,
                "PhysicalSizeZ": 1.5,
                "PhysicalSizeZUnit": "nm",
            },
        )
    elif case == "zarr-3":
        zarr.create_array(path, shape=(12, 17, 3), dtype="uint8")
    elif case in ("ome-zarr-0.4", "ome-zarr-0.5"):
        group = zarr.open_group(path, mode="w", zarr_format=2 if case.endswith("4") else 3)
        group.create_array("0", shape=(3, 12, 17), dtype="uint16")
        axes = [{"name": "c", "type": "channel"}] + [
            {"name": n, "type": "space", "unit": "micrometer"} for n in "yx"
        ]
        scale = [{"type": "scale", "scale": [1.0, 0.5, 0.5]}]
        dataset = {"path": "0", "coordinateTransformations": scale}
        multiscales = [{"axes": axes, "datasets": [dataset]}]
        if case.endswith("4"):
            group.attrs["multiscales"] = [dict(multiscales[0], version="0.4")]
        else:
            group.attrs["ome"] = {"version": "0.5", "multiscales": multiscales}


@pytest.mark.parametrize(
    "case,suffix,axes,channel_axis,sizes,ambiguous",
    [
        ("png-1", ".png", "YX", None, {}, False),
        ("png-2", ".png", "YXS", -1, {}, False),
        ("png-3", ".png", "YXS", -1, {}, False),
        ("png-4", ".png", "YXS", -1, {}, False),
        ("jpeg-grey", ".jpg", "YX", None, {}, False),
        ("jpeg-rgb", ".jpg", "YXS", -1, {}, False),
        ("tiff-rgb", ".tif", None, 2, {}, False),
        ("tiff-grey-3", ".tif", None, None, {}, True),
        ("tiff-16-stack", ".tif", None, None, {}, False),
        ("tiff-planar-rgb", ".tif", None, 0, {}, False),
        (
            "ome-tiff",
            ".ome.tif",
            "TZYX",
            None,
            {"X": (0.25, "micrometer"), "Y": (0.25, "micrometer"), "Z": (1.5, "nanometer")},
            False,
        ),
        ("zarr-3", ".zarr", None, None, {}, True),
        ("ome-zarr-0.4", ".zarr", "CYX", None, HALF_MICRON, False),
        ("ome-zarr-0.5", ".zarr", "CYX", None, HALF_MICRON, False),
    ],
)
def test_metadata_of_each_file_case(tmp_path, case, suffix, axes, channel_axis, sizes, ambiguous):
    path = tmp_path / f"image{suffix}"
    _write_case(path, case)
    metadata = file_io.read_metadata(path)
    assert metadata.axes == axes
    assert metadata.channel_axis == channel_axis
    assert metadata.pixel_sizes == sizes
    assert metadata.ambiguous is ambiguous
    assert metadata.ome is case.startswith("ome")
    assert metadata.provenance is None



def test_an_ome_zarr_multiscales_own_scale_multiplies_its_datasets(tmp_path):
    # the multiscale's coordinate transformations apply after the dataset's: 0.5 um
    # sampled every 2 pixels is 1 um a pixel (0.5 was recorded)
    import zarr

    group = zarr.open_group(tmp_path / "image.zarr", mode="w")
    group.create_array("s0", shape=(12, 17), dtype="uint16")
    axes = [{"name": n, "type": "space", "unit": "micrometer"} for n in "yx"]
    transforms = [{"type": "scale", "scale": [0.5, 0.25]}]
    dataset = {"path": "s0", "coordinateTransformations": transforms}
    group.attrs["ome"] = {
        "version": "0.5",
        "multiscales": [
            {
                "axes": axes,
                "datasets": [dataset],
                "coordinateTransformations": [{"type": "scale", "scale": [2.0, 4.0]}],
            }
        ],
    }
    sizes = file_io.read_metadata(tmp_path / "image.zarr").pixel_sizes
    assert sizes == {"Y": (1.0, "micrometer"), "X": (1.0, "micrometer")}


def test_a_zarr_group_of_groups_names_the_one_to_give(tmp_path):
    # a bioformats2raw layout: the message said only "a zarr group without arrays"
    import zarr

    root = zarr.open_group(tmp_path / "b2r.zarr", mode="w")
    root.create_group("0").create_array("0", shape=(8, 8), dtype="uint8")
    root.create_group("OME")
    message = "group of groups \\(0, OME\\).*name one: .*b2r.zarr/0"
    with pytest.raises(ImageFileError, match=message):
        file_io.open_image(tmp_path / "b2r.zarr")

@pytest.mark.parametrize("name", ["out.tif", "out.ome.tif", "out.png", "out.jpg", "out.zarr"])
def test_provenance_round_trip(tmp_path, name):
    array = RNG.integers(0, 256, (4, 5), dtype=np.uint8)
    ome = name.endswith(".ome.tif")
    metadata = file_io.ImageMetadata(
        axes="YX" if ome else None,
        pixel_sizes={"X": (0.5, "micrometer")} if ome else {},
        ome=ome,
        provenance=RECORD,
    )
    file_io.write_array(tmp_path / name, array, metadata=metadata)
    assert file_io.read_provenance(tmp_path / name) == RECORD  # floats exactly: 1/3
    if not name.endswith(".jpg"):
        np.testing.assert_array_equal(file_io.read_image(tmp_path / name), array)


def test_a_file_without_a_record_says_so(tmp_path):
    write_image(tmp_path / "plain.png", np.zeros((4, 5), np.uint8))
    with pytest.raises(ImageFileError, match="no napari-labyrinth provenance record"):
        file_io.read_provenance(tmp_path / "plain.png")


@pytest.mark.parametrize("lazy", [False, True])
@pytest.mark.parametrize("name", ["out.tif", "out.zarr"])
def test_ome_axes_and_pixel_sizes_are_written_back(tmp_path, name, lazy):
    import dask.array as da

    source = tmp_path / "in.ome.tif"
    _write_case(source, "ome-tiff")
    metadata = file_io.read_metadata(source)
    data = file_io.read_image(source)
    stack = np.stack([data, data])  # a rendering with a leading axis (the passes of a stack)
    array = da.from_array(stack, chunks=(1, 1, 1, 12, 17)) if lazy else stack
    out = tmp_path / name
    file_io.write_array(out, array, metadata=metadata.for_output("Q", RECORD))
    back = file_io.read_metadata(out)
    # OME-Zarr wants time first: a zarr store keeps the axes and sizes in its own attributes
    assert back.axes == "QTZYX" and back.ome is name.endswith(".tif")
    assert back.pixel_sizes == metadata.pixel_sizes
    assert back.provenance == RECORD
    np.testing.assert_array_equal(np.asarray(file_io.open_image(out, lazy=False)), stack)


def test_axes_outside_ome_zarr_rules_give_a_plain_array_with_the_record(tmp_path):
    metadata = file_io.ImageMetadata(axes="QQTZYX", ome=True, provenance=RECORD)
    array = np.zeros((1, 1, 1, 2, 3, 4), np.uint8)
    file_io.write_array(tmp_path / "out.zarr", array, metadata=metadata)
    back = file_io.read_metadata(tmp_path / "out.zarr")
    assert back.provenance == RECORD and not back.ome


def test_release_files_closes_the_tiffs_opened_lazily(tmp_path, monkeypatch):
    # they were only forgotten: the file was closed when the garbage collector came by,
    # with a ResourceWarning wherever that happened
    import gc
    import warnings

    from napari_labyrinth import io as file_io

    write_image(tmp_path / "in.tif", np.zeros((2, 16, 16), np.uint16))
    monkeypatch.setattr(file_io, "LAZY_TIFF_BYTES", 0)
    lazy = file_io.open_image(tmp_path / "in.tif")
    assert int(lazy.sum().compute()) == 0
    del lazy
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        file_io.release_files()
        gc.collect()
    assert [w for w in caught if issubclass(w.category, ResourceWarning)] == []


# -- a destination that cannot be written: the error names it, never the temporary -------------


def _cannot_create_in(directory: Path) -> bool:
    """Whether a file cannot be created in ``directory`` (root writes where chmod forbids)."""
    try:
        with open(directory / ".probe", "x"):
            pass
    except OSError:
        return True
    os.unlink(directory / ".probe")
    return False


@pytest.fixture(params=["under a file", "/proc", "read-only"])
def unwritable(request, tmp_path):
    """A directory no file can be created in: a path under a regular file (ENOTDIR, even for
    root), /proc, or a directory made read-only (not for root)."""
    if request.param == "under a file":
        (tmp_path / "file").write_bytes(b"")
        return tmp_path / "file"
    if request.param == "/proc":
        if not os.path.isdir("/proc") or not _cannot_create_in(Path("/proc")):
            pytest.skip("no /proc that refuses new files")
        return Path("/proc")
    if sys.platform == "win32":
        pytest.skip("POSIX permissions")
    directory = tmp_path / "read-only"
    directory.mkdir()
    directory.chmod(0o555)
    request.addfinalizer(lambda: directory.chmod(0o755))
    if not _cannot_create_in(directory):
        pytest.skip("this user writes in a read-only directory (root)")
    return directory


def _write_bands(path, plane):
    from napari_labyrinth.io.bands import plane_bands_written

    with plane_bands_written(path, plane.shape, plane.dtype, 4) as write:
        write(0, plane[:4])
        write(4, plane[4:])


def _lazy(plane):
    import dask.array as da

    return da.from_array(np.stack([plane, plane]), chunks=(1, 8, 8))


WRITES = {
    "png": lambda directory, plane: write_image(directory / "out.png", plane),
    "tif": lambda directory, plane: write_image(directory / "out.tif", plane),
    "jpg": lambda directory, plane: write_image(directory / "out.jpg", plane),
    "bmp": lambda directory, plane: write_image(directory / "out.bmp", plane),
    "zarr": lambda directory, plane: file_io.write_array(directory / "out.zarr", plane),
    "lazy tif": lambda directory, plane: file_io.write_array(directory / "out.tif", _lazy(plane)),
    "lazy zarr": lambda d, plane: file_io.write_array(d / "out.zarr", _lazy(plane)),
    "bands tif": lambda directory, plane: _write_bands(directory / "out.tif", plane),
    "bands zarr": lambda directory, plane: _write_bands(directory / "out.zarr", plane),
}


@pytest.mark.parametrize("write", WRITES.values(), ids=WRITES.keys())
def test_an_unwritable_destination_is_named_not_its_temporary(unwritable, write):
    # /proc/x.png said "No such file or directory: /proc/.x.png.0a7c9c-1234-5ef55aa3.tmp"
    plane = RNG.integers(0, 256, (8, 8), dtype=np.uint8)
    with pytest.raises(OSError) as raised:
        write(unwritable, plane)
    error = raised.value
    assert Path(error.filename).parent == unwritable and error.filename2 is None
    assert Path(error.filename).name.startswith("out.")
    assert error.strerror and error.strerror in str(error)
    assert ".tmp" not in str(error) and ".out." not in str(error)
