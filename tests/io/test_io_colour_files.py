"""Image files whose pixels a reader would get wrong or lossy: read exactly, or refused clearly.

CMYK images, 16-bit colour PNGs, PNG transparency chunks, palette and MINISWHITE TIFFs, TIFFs
holding several series, truncated multi-page TIFFs.
"""

from __future__ import annotations

import struct
import zlib

import numpy as np
import pytest

from napari_labyrinth.io import ImageFileError, open_image, read_image, read_metadata

RNG = np.random.default_rng(5)


def rgb(shape=(32, 32)):
    return RNG.integers(0, 256, (*shape, 3), dtype=np.uint8)


def grey(shape=(32, 32)):
    return RNG.integers(0, 256, shape, dtype=np.uint8)


def refused(path, *words):
    """Assert that reading ``path`` (pixels, metadata) is refused in one line with ``words``."""
    for read in (read_image, read_metadata):
        with pytest.raises(ImageFileError) as info:
            read(path)
        message = str(info.value)
        assert message.startswith(f"{path}: ") and "\n" not in message
        for word in words:
            assert word in message, message


def write_png(path, values, bit_depth, colour_type, trns=None):
    """A PNG file written chunk by chunk (Pillow writes no 16-bit colour, nor 2-bit grey)."""
    values = np.asarray(values)
    rows = []
    for row in values.reshape(values.shape[0], -1):
        if bit_depth == 16:
            data = row.astype(">u2").tobytes()
        else:
            bits = np.unpackbits(row.astype(np.uint8)[:, None], axis=1)[:, -bit_depth:]
            data = np.packbits(bits).tobytes()
        rows.append(b"\0" + data)

    def chunk(kind, data):
        crc = struct.pack(">I", zlib.crc32(kind + data))
        return struct.pack(">I", len(data)) + kind + data + crc

    height, width = values.shape[:2]
    header = struct.pack(">IIBBBBB", width, height, bit_depth, colour_type, 0, 0, 0)
    chunks = chunk(b"IHDR", header)
    if trns is not None:
        chunks += chunk(b"tRNS", trns)
    chunks += chunk(b"IDAT", zlib.compress(b"".join(rows))) + chunk(b"IEND", b"")
    path.write_bytes(b"\x89PNG\r\n\x1a\n" + chunks)


# -- CMYK -----------------------------------------------------------------------------------------


def test_cmyk_jpeg_is_refused(tmp_path):
    from PIL import Image

    path = tmp_path / "cmyk.jpg"
    Image.fromarray(rgb()).convert("CMYK").save(path)
    refused(path, "CMYK JPEG", "not supported", "convert it to RGB")


def test_cmyk_tiff_is_refused(tmp_path):
    import tifffile
    from PIL import Image

    path = tmp_path / "cmyk.tif"
    cmyk = np.asarray(Image.fromarray(rgb()).convert("CMYK"))
    tifffile.imwrite(path, cmyk, photometric="separated")
    refused(path, "CMYK", "TIFF", "convert it to an RGB TIFF")
    with pytest.raises(ImageFileError, match="CMYK"):
        open_image(path, lazy=True)


# -- 16-bit PNG -----------------------------------------------------------------------------------


@pytest.mark.parametrize(
    "colour_type,channels,words", [(2, 3, "RGB"), (6, 4, "RGBA"), (4, 2, "grey + alpha")]
)
def test_16_bit_png_other_than_grey_is_refused(tmp_path, colour_type, channels, words):
    path = tmp_path / "deep.png"
    write_png(path, RNG.integers(0, 65536, (8, 9, channels)), 16, colour_type)
    refused(path, f"16-bit {words} PNG", "only as 8 bits", "TIFF")


def test_16_bit_grey_png_is_read_exactly(tmp_path):
    path = tmp_path / "deep.png"
    values = RNG.integers(0, 65536, (8, 9))
    write_png(path, values, 16, 0)
    image = read_image(path)
    assert image.dtype == np.uint16
    np.testing.assert_array_equal(image, values)
    assert read_metadata(path).channel_axis is None


# -- PNG transparency (tRNS) ----------------------------------------------------------------------


def test_palette_png_with_transparency_is_read_as_rgba(tmp_path):
    from PIL import Image

    path = tmp_path / "p.png"
    palette = Image.fromarray(rgb()).convert("P", palette=Image.ADAPTIVE)
    palette.save(path, transparency=0)
    image = read_image(path)
    assert image.shape == (32, 32, 4)
    np.testing.assert_array_equal(image[..., :3], np.asarray(palette.convert("RGB")))
    indices = np.asarray(palette)
    np.testing.assert_array_equal(image[..., 3], np.where(indices == 0, 0, 255))
    metadata = read_metadata(path)
    assert metadata.channel_axis == -1 and not metadata.grey_alpha
    assert "tRNS" in metadata.colour and "RGBA" in metadata.colour


def test_palette_png_without_transparency_is_still_read_as_rgb(tmp_path):
    from PIL import Image

    path = tmp_path / "p.png"
    palette = Image.fromarray(rgb()).convert("P", palette=Image.ADAPTIVE)
    palette.save(path)
    image = read_image(path)
    np.testing.assert_array_equal(image, np.asarray(palette.convert("RGB")))
    assert read_metadata(path).colour == "PNG colour type palette"


def test_grey_png_with_a_transparent_level_is_read_as_grey_and_alpha(tmp_path):
    from PIL import Image

    path = tmp_path / "l.png"
    values = grey()
    key = int(values[0, 0])
    Image.fromarray(values).save(path, transparency=key)
    image = read_image(path)
    assert image.shape == (32, 32, 2)
    np.testing.assert_array_equal(image[..., 0], values)
    np.testing.assert_array_equal(image[..., 1], np.where(values == key, 0, 255))
    metadata = read_metadata(path)
    assert metadata.channel_axis == -1 and metadata.grey_alpha
    assert "tRNS" in metadata.colour


def test_rgb_png_with_a_transparent_colour_is_read_as_rgba(tmp_path):
    from PIL import Image

    path = tmp_path / "rgb.png"
    values = rgb()
    key = tuple(int(v) for v in values[0, 0])
    Image.fromarray(values).save(path, transparency=key)
    image = read_image(path)
    np.testing.assert_array_equal(image[..., :3], values)
    transparent = (values == key).all(axis=-1)
    np.testing.assert_array_equal(image[..., 3], np.where(transparent, 0, 255))


@pytest.mark.parametrize("bit_depth", [2, 4, 16])
def test_grey_png_whose_transparent_level_pillow_misreads_is_refused(tmp_path, bit_depth):
    path = tmp_path / "key.png"
    values = RNG.integers(0, 2**bit_depth, (8, 16))
    write_png(path, values, bit_depth, 0, trns=struct.pack(">H", int(values[0, 0])))
    refused(path, f"{bit_depth}-bit grey PNG", "tRNS", "TIFF")


# -- TIFF: photometric interpretation -------------------------------------------------------------


def test_palette_tiff_is_refused(tmp_path):
    from PIL import Image

    path = tmp_path / "pal.tif"
    Image.fromarray(rgb()).convert("P", palette=Image.ADAPTIVE).save(path)
    refused(path, "palette", "colour map", "RGB TIFF")


def test_miniswhite_tiff_is_refused(tmp_path):
    import tifffile

    path = tmp_path / "mw.tif"
    tifffile.imwrite(path, grey(), photometric="miniswhite")
    refused(path, "MINISWHITE", "inverted", "MINISBLACK")


# -- TIFF: several series -------------------------------------------------------------------------


def test_tiff_with_two_series_is_refused(tmp_path):
    import tifffile

    path = tmp_path / "ms.tif"
    image = grey((128, 128))
    with tifffile.TiffWriter(path) as tiff:
        tiff.write(image)
        tiff.write(image[:64, :64])
    refused(path, "2 images", "(128, 128), (64, 64)", "one image")
    with pytest.raises(ImageFileError, match="2 images"):
        open_image(path, lazy=True)


def test_ome_tiff_with_two_images_is_refused(tmp_path):
    import tifffile

    path = tmp_path / "ms.ome.tif"
    image = grey((128, 128))
    with tifffile.TiffWriter(path, ome=True) as tiff:
        tiff.write(image)
        tiff.write(image[:64, :64])
    refused(path, "2 images")


# -- TIFF: truncated ------------------------------------------------------------------------------


@pytest.fixture
def truncated_tiff(tmp_path):
    """Ten 32x32 pages, each written on its own, the file cut inside the tenth page's IFD."""
    import tifffile

    path = tmp_path / "cut.tif"
    with tifffile.TiffWriter(path) as tiff:
        for plane in RNG.integers(0, 256, (10, 32, 32), dtype=np.uint8):
            tiff.write(plane, contiguous=False, metadata=None)
    with tifffile.TiffFile(path) as tiff:
        assert len(tiff.pages) == 10 and len(tiff.series) == 1
        tenth = tiff.pages[9].offset
    path.write_bytes(path.read_bytes()[: tenth + 1])
    return path


def test_truncated_multi_page_tiff_is_refused(truncated_tiff):
    refused(truncated_tiff, "corrupted or truncated TIFF file", "tifffile: corrupted tag list")
    with pytest.raises(ImageFileError, match="corrupted or truncated"):
        open_image(truncated_tiff, lazy=True)


def test_truncated_tiff_fails_the_command_line(truncated_tiff, tmp_path, capsys):
    from napari_labyrinth.cli import EXIT_OK, main

    code = main(["render", str(truncated_tiff), "-o", str(tmp_path / "out"), "--passes", "1"])
    assert code != EXIT_OK
    assert "corrupted or truncated TIFF file" in capsys.readouterr().err
    assert not (tmp_path / "out" / "cut_labyrinth.tif").exists()
