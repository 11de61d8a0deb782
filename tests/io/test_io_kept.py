"""What a file says about its pixels, kept from input to output: TIFF extra samples (alpha) and
planar samples, EXIF orientation, resolution."""

from __future__ import annotations

import numpy as np
import pytest

from napari_labyrinth import labyrinth
from napari_labyrinth.cli import EXIT_FAILED, EXIT_OK, main
from napari_labyrinth.io import (
    ImageFileError,
    ImageMetadata,
    read_image,
    read_metadata,
    write_array,
    write_image,
)

tifffile = pytest.importorskip("tifffile")
data = pytest.importorskip("skimage.data")

CAM = data.camera()[192:256, 192:256]
AST = data.astronaut()[:64, :64]
ALPHA = np.ascontiguousarray(CAM.T)  # varied, so that rendering it would change it


def render(*argv) -> int:
    return main(["render", *map(str, argv), "--passes", "1"])


def tiff_samples(path):
    """Axes, photometric, planar configuration and extra samples of a TIFF file."""
    with tifffile.TiffFile(path) as tif:
        page = tif.series[0].keyframe
        return (
            tif.series[0].axes,
            page.photometric.name,
            int(page.planarconfig),
            [tifffile.EXTRASAMPLE(code).name for code in page.extrasamples],
        )


# -- TIFF extra samples ---------------------------------------------------------------------------


def test_a_grey_alpha_tiff_is_read_as_grey_and_alpha(tmp_path):
    path = tmp_path / "ga.tif"
    tifffile.imwrite(path, np.dstack([CAM, ALPHA]), photometric="minisblack", extrasamples=[2])
    metadata = read_metadata(path)
    assert metadata.channel_axis == -1 and metadata.grey_alpha
    assert metadata.extra_samples == ("unassalpha",) and not metadata.ambiguous
    assert "MINISBLACK" in metadata.colour and "unassalpha" in metadata.colour


def test_a_grey_alpha_tiff_is_rendered_with_its_alpha_kept(tmp_path):
    source, out = tmp_path / "ga.tif", tmp_path / "out.tif"
    tifffile.imwrite(source, np.dstack([CAM, ALPHA]), photometric="minisblack", extrasamples=[2])
    assert render(source, "-o", out) == EXIT_OK
    result = tifffile.imread(out)
    assert result.shape == (64, 64, 2)
    np.testing.assert_array_equal(result[..., 1], ALPHA)
    expected = labyrinth(np.dstack([CAM, ALPHA]), channel_axis=-1, alpha=True, passes=1)
    np.testing.assert_array_equal(result, expected)
    assert tiff_samples(out) == ("YXS", "MINISBLACK", 1, ["UNASSALPHA"])
    assert read_metadata(out).grey_alpha


def test_a_planar_grey_alpha_tiff_is_rendered_with_its_alpha_kept(tmp_path):
    # its alpha plane (channel axis -3) was rendered as a grey plane
    source, out = tmp_path / "gap.tif", tmp_path / "out.tif"
    planes = np.stack([CAM, ALPHA])
    tifffile.imwrite(
        source, planes, photometric="minisblack", planarconfig="separate", extrasamples=[2]
    )
    assert render(source, "-o", out) == EXIT_OK
    result = tifffile.imread(out)
    np.testing.assert_array_equal(result[1], ALPHA)
    expected = labyrinth(planes, channel_axis=0, alpha=True, passes=1)
    np.testing.assert_array_equal(result, expected)
    assert not np.array_equal(result[0], CAM)


@pytest.mark.parametrize("kind", [1, 2], ids=["associated", "unassociated"])
def test_rgb_alpha_tiff_keeps_its_kind_of_alpha(tmp_path, kind):
    source, out = tmp_path / "rgba.tif", tmp_path / "out.tif"
    tifffile.imwrite(source, np.dstack([AST, ALPHA]), photometric="rgb", extrasamples=[kind])
    assert render(source, "-o", out) == EXIT_OK
    np.testing.assert_array_equal(tifffile.imread(out)[..., 3], ALPHA)
    assert tiff_samples(out) == ("YXS", "RGB", 1, [tifffile.EXTRASAMPLE(kind).name])


def test_associated_alpha_is_refused_as_png(tmp_path, capsys):
    source = tmp_path / "rgba.tif"
    tifffile.imwrite(source, np.dstack([AST, ALPHA]), photometric="rgb", extrasamples=[1])
    assert render(source, "-o", tmp_path / "out.png") == EXIT_FAILED
    assert "assocalpha" in capsys.readouterr().err
    assert not (tmp_path / "out.png").exists()


def test_rgb_with_extra_samples_keeps_them(tmp_path):
    source, out = tmp_path / "rgb5.tif", tmp_path / "out.tif"
    image = np.dstack([AST, CAM, ALPHA])
    tifffile.imwrite(source, image, photometric="rgb", extrasamples=[0, 0])
    assert render(source, "-o", out) == EXIT_OK
    assert tiff_samples(out) == ("YXS", "RGB", 1, ["UNSPECIFIED", "UNSPECIFIED"])
    with pytest.raises(ImageFileError, match="unspecified"):
        write_image(tmp_path / "out.png", image[..., :4], metadata=read_metadata(source))


@pytest.mark.parametrize("extra", [[2, 0], [0, 2], [1, 0], [0, 0, 2]])
def test_alpha_among_several_extra_samples_is_refused_before_rendering(tmp_path, capsys, extra):
    # its alpha was rendered as a plane of data (only a last, single extra sample is kept)
    source, out = tmp_path / "rgbxa.tif", tmp_path / "out.tif"
    planes = [AST] + [ALPHA] * len(extra)
    tifffile.imwrite(source, np.dstack(planes), photometric="rgb", extrasamples=extra)
    assert render(source, "-o", out) == EXIT_FAILED
    err = capsys.readouterr().err
    assert "hold alpha beside other samples" in err and "alpha as its only extra sample" in err
    assert not out.exists()


def test_a_single_unspecified_extra_sample_is_kept_and_said(tmp_path, capsys):
    source, out = tmp_path / "rgbx.tif", tmp_path / "out.tif"
    tifffile.imwrite(source, np.dstack([AST, ALPHA]), photometric="rgb", extrasamples=[0])
    assert render(source, "-o", out) == EXIT_OK
    note = "fourth sample is an unspecified extra sample (not alpha): kept as it is"
    assert note in capsys.readouterr().err
    result = tifffile.imread(out)
    np.testing.assert_array_equal(result[..., 3], ALPHA)
    assert not np.array_equal(result[..., :3], AST)
    assert tiff_samples(out) == ("YXS", "RGB", 1, ["UNSPECIFIED"])


def test_an_rgb_alpha_tiff_is_rendered_without_a_note(tmp_path, capsys):
    source, out = tmp_path / "rgba.tif", tmp_path / "out.tif"
    tifffile.imwrite(source, np.dstack([AST, ALPHA]), photometric="rgb", extrasamples=[2])
    assert render(source, "-o", out) == EXIT_OK
    assert "extra sample" not in capsys.readouterr().err


def test_a_grey_tiff_of_three_samples_is_refused(tmp_path):
    path = tmp_path / "g3.tif"
    grey = np.dstack([CAM, CAM, CAM])
    tifffile.imwrite(path, grey, photometric="minisblack", extrasamples=[0, 0])
    for read in (read_image, read_metadata):
        with pytest.raises(ImageFileError, match="MINISBLACK TIFF of 3 samples per pixel"):
            read(path)


def test_rgba_metadata_without_extra_samples_is_written_as_rgba(tmp_path):
    metadata = ImageMetadata(channel_axis=-1)
    write_image(tmp_path / "out.tif", np.dstack([AST, ALPHA]), metadata=metadata)
    assert tiff_samples(tmp_path / "out.tif") == ("YXS", "RGB", 1, ["UNASSALPHA"])


# -- planar samples -------------------------------------------------------------------------------


def test_a_planar_rgb_tiff_is_written_as_planar_rgb(tmp_path):
    source, out = tmp_path / "planar.tif", tmp_path / "out.tif"
    planar = np.ascontiguousarray(np.moveaxis(AST, -1, 0))
    tifffile.imwrite(source, planar, photometric="rgb", planarconfig="separate")
    assert render(source, "-o", out) == EXIT_OK
    assert tiff_samples(out) == ("SYX", "RGB", 2, [])
    assert read_metadata(out).channel_axis == 0


def test_a_lazy_stack_of_planar_rgb_is_written_as_planar_rgb(tmp_path):
    da = pytest.importorskip("dask.array")
    source, out = tmp_path / "planar.tif", tmp_path / "out.tif"
    planar = np.ascontiguousarray(np.moveaxis(AST, -1, 0))
    tifffile.imwrite(source, planar, photometric="rgb", planarconfig="separate")
    stack = np.stack([planar, planar[:, ::-1]])
    metadata = read_metadata(source).for_output("Q", None)
    write_array(out, da.from_array(stack, chunks=(1, 3, 64, 64)), metadata=metadata)
    assert tiff_samples(out) == ("QSYX", "RGB", 2, [])
    np.testing.assert_array_equal(tifffile.imread(out), stack)


# -- EXIF orientation -----------------------------------------------------------------------------


def exif_jpeg(path, orientation, dpi=None):
    from PIL import Image

    image = Image.fromarray(AST[:, :40])
    exif = image.getexif()
    exif[0x0112] = orientation
    image.save(path, exif=exif, quality=95, **({"dpi": dpi} if dpi else {}))


@pytest.mark.parametrize("orientation", range(1, 9))
def test_the_exif_orientation_is_applied(tmp_path, orientation):
    from PIL import Image, ImageOps

    path = tmp_path / "rot.jpg"
    exif_jpeg(path, orientation)
    with Image.open(path) as image:
        upright = np.asarray(ImageOps.exif_transpose(image))
    np.testing.assert_array_equal(read_image(path), upright)
    assert (f"EXIF orientation {orientation}" in read_metadata(path).colour) == (orientation > 1)


@pytest.mark.parametrize("orientation", [3, 6, 8])
def test_a_rendering_is_upright_as_viewers_show_the_input(tmp_path, orientation):
    from PIL import Image, ImageOps

    source, out = tmp_path / "rot.jpg", tmp_path / "out.png"
    exif_jpeg(source, orientation)
    assert render(source, "-o", out) == EXIT_OK
    with Image.open(source) as image:
        upright = np.asarray(ImageOps.exif_transpose(image))
    with Image.open(out) as image:
        assert image.getexif().get(0x0112) in (None, 1)
        rendered = np.asarray(image)
    np.testing.assert_array_equal(rendered, labyrinth(upright, channel_axis=-1, passes=1))


# -- resolution -----------------------------------------------------------------------------------


def test_a_tiff_resolution_is_kept(tmp_path):
    from PIL import Image

    source = tmp_path / "res.tif"
    tifffile.imwrite(source, CAM, resolution=(300, 200), resolutionunit="CENTIMETER")
    assert read_metadata(source).resolution == (300.0, 200.0, "centimeter")
    assert render(source, "-o", tmp_path / "out.tif") == EXIT_OK
    assert read_metadata(tmp_path / "out.tif").resolution == (300.0, 200.0, "centimeter")
    assert render(source, "-o", tmp_path / "out.png") == EXIT_OK
    with Image.open(tmp_path / "out.png") as image:
        np.testing.assert_allclose(image.info["dpi"], (762, 508), rtol=1e-4)  # PNG: per metre


def test_a_png_resolution_is_kept(tmp_path):
    from PIL import Image

    source = tmp_path / "dpi.png"
    Image.fromarray(CAM).save(source, dpi=(600, 600))
    assert render(source, "-o", tmp_path / "out.png") == EXIT_OK
    with Image.open(source) as original, Image.open(tmp_path / "out.png") as image:
        assert image.info["dpi"] == original.info["dpi"]
    assert render(source, "-o", tmp_path / "out.tif") == EXIT_OK
    x, y, unit = read_metadata(tmp_path / "out.tif").resolution
    assert unit == "inch" and x == y == pytest.approx(600, rel=1e-4)


def test_no_resolution_is_invented(tmp_path):
    tifffile.imwrite(tmp_path / "plain.tif", CAM)
    assert read_metadata(tmp_path / "plain.tif").resolution is None
    write_image(tmp_path / "plain.png", CAM)
    assert read_metadata(tmp_path / "plain.png").resolution is None


def test_the_resolution_follows_the_exif_orientation(tmp_path):
    exif_jpeg(tmp_path / "rot.jpg", 6, dpi=(72, 144))
    assert read_metadata(tmp_path / "rot.jpg").resolution == (144.0, 72.0, "inch")


def _srgb_profile() -> bytes:
    from PIL import ImageCms

    return ImageCms.ImageCmsProfile(ImageCms.createProfile("sRGB")).tobytes()


@pytest.mark.parametrize("suffix,output", [(".png", ".png"), (".jpg", ".tif"), (".tif", ".tif"),
                                           (".png", ".jpg"), (".tif", ".png")])  # fmt: skip
def test_an_icc_profile_is_embedded_again(tmp_path, suffix, output):
    # the profile says what the values mean: it was dropped, and the output read as sRGB
    from PIL import Image

    profile = _srgb_profile()
    source, out = tmp_path / f"in{suffix}", tmp_path / f"out{output}"
    if suffix == ".tif":
        tifffile.imwrite(source, AST, photometric="rgb", iccprofile=profile)
    else:
        Image.fromarray(AST).save(source, icc_profile=profile)
    assert read_metadata(source).icc_profile == profile
    assert render(source, "-o", out, *(["--lossy"] if output == ".jpg" else [])) == EXIT_OK
    if output == ".tif":
        with tifffile.TiffFile(out) as tif:
            assert bytes(tif.pages[0].tags[34675].value) == profile
    else:
        with Image.open(out) as image:
            assert image.info.get("icc_profile") == profile
    assert read_metadata(out).icc_profile == profile


def test_no_icc_profile_is_invented(tmp_path):
    source, out = tmp_path / "in.png", tmp_path / "out.tif"
    write_image(source, AST)
    assert read_metadata(source).icc_profile is None
    assert render(source, "-o", out) == EXIT_OK
    with tifffile.TiffFile(out) as tif:
        assert 34675 not in tif.pages[0].tags


# -- channel names --------------------------------------------------------------------------------


def _named_ome_tiff(path, names=("DAPI", "GFP")):
    planes = np.stack([CAM, CAM.T])[: len(names)]
    tifffile.imwrite(
        path, planes, ome=True, metadata={"axes": "CYX", "Channel": {"Name": list(names)}}
    )


@pytest.mark.parametrize(
    "output,variant",
    [("out.ome.tif", []), ("out.zarr", []), ("stack.ome.tif", ["--stack"]),
     ("stack.zarr", ["--stack"])],
)  # fmt: skip
def test_ome_channel_names_are_kept(tmp_path, output, variant):
    # an OME-TIFF's DAPI and GFP channels came out unnamed
    pytest.importorskip("zarr")
    source = tmp_path / "in.ome.tif"
    _named_ome_tiff(source)
    assert read_metadata(source).channel_names == ("DAPI", "GFP")
    assert render(source, "-o", tmp_path / output, *variant) == EXIT_OK
    kept = read_metadata(tmp_path / output)
    assert kept.channel_names == ("DAPI", "GFP") and kept.axes.endswith("CYX")
    back = tmp_path / "back.ome.tif"  # and from the zarr store (omero labels) to a TIFF
    assert render(tmp_path / output, "-o", back) == EXIT_OK
    assert read_metadata(back).channel_names == ("DAPI", "GFP")


def test_channel_names_are_kept_only_when_they_name_every_channel(tmp_path):
    metadata = ImageMetadata(axes="CYX", ome=True, channel_names=("DAPI", "GFP", "RFP"))
    write_array(tmp_path / "three.ome.tif", np.stack([CAM, CAM]), metadata=metadata)
    assert read_metadata(tmp_path / "three.ome.tif").channel_names == ()
    tifffile.imwrite(  # one channel unnamed: none is named
        tmp_path / "partly.ome.tif", np.stack([CAM, CAM]), ome=True,
        metadata={"axes": "CYX", "Channel": {"Name": ["DAPI", ""]}},
    )  # fmt: skip
    assert read_metadata(tmp_path / "partly.ome.tif").channel_names == ()
    tifffile.imwrite(tmp_path / "plain.tif", np.stack([CAM, CAM]))
    assert read_metadata(tmp_path / "plain.tif").channel_names == ()


# -- time increment -------------------------------------------------------------------------------


@pytest.mark.parametrize(
    "output,variant",
    [("out.ome.tif", []), ("out.zarr", []), ("stack.tif", ["--stack"]),
     ("stack.zarr", ["--stack"])],
)  # fmt: skip
def test_the_time_between_frames_is_kept(tmp_path, output, variant):
    # an OME-TIFF's 30 s between frames came out as no interval (OME-TIFF) or 1 (OME-Zarr)
    pytest.importorskip("zarr")
    source = tmp_path / "movie.ome.tif"
    frames = np.stack([CAM, CAM.T, CAM[::-1]])
    metadata = {"axes": "TYX", "TimeIncrement": 30.0, "TimeIncrementUnit": "s"}
    tifffile.imwrite(source, frames, ome=True, metadata=metadata)
    assert read_metadata(source).time_increment == (30.0, "second")
    assert render(source, "-o", tmp_path / output, *variant) == EXIT_OK
    kept = read_metadata(tmp_path / output)
    assert kept.time_increment == (30.0, "second") and kept.axes.endswith("TYX")
    back = tmp_path / "back.ome.tif"
    assert render(tmp_path / output, "-o", back) == EXIT_OK
    assert read_metadata(back).time_increment == (30.0, "second")


def test_no_time_increment_is_invented(tmp_path):
    source = tmp_path / "movie.ome.tif"
    tifffile.imwrite(source, np.stack([CAM, CAM.T]), ome=True, metadata={"axes": "TYX"})
    assert read_metadata(source).time_increment is None
    assert render(source, "-o", tmp_path / "out.zarr") == EXIT_OK
    assert read_metadata(tmp_path / "out.zarr").time_increment is None


def test_an_ome_output_that_ome_cannot_hold_is_said(tmp_path, capsys):
    # a stack of a CYX OME-TIFF (QCYX) went to a plain zarr array without a word
    pytest.importorskip("zarr")
    source = tmp_path / "in.ome.tif"
    _named_ome_tiff(source)
    assert render(source, "-o", tmp_path / "one.zarr") == EXIT_OK
    assert "cannot hold the axes" not in capsys.readouterr().err
    assert render(source, "-o", tmp_path / "stack.zarr", "--stack") == EXIT_OK
    err = capsys.readouterr().err
    assert "stack.zarr: OME-Zarr (2 to 5 axes" in err and "cannot hold the axes QCYX" in err
    assert read_metadata(tmp_path / "stack.zarr").axes == "QCYX"  # kept, in its own words


# -- the image name -------------------------------------------------------------------------------


@pytest.mark.parametrize("output", ["out.ome.tif", "out.zarr", "out_stack.tif"])
def test_the_ome_image_name_is_kept_through_render(tmp_path, output):
    source = tmp_path / "in.ome.tif"
    tifffile.imwrite(source, np.stack([CAM, ALPHA]), ome=True,
                     metadata={"axes": "ZYX", "Name": "zstack"})  # fmt: skip
    assert read_metadata(source).image_name == "zstack"
    stack = ["--stack"] if "stack" in output else []
    assert render(source, "-o", tmp_path / output, *stack) == EXIT_OK
    assert read_metadata(tmp_path / output).image_name == "zstack"


def test_the_image_name_of_an_ome_tiff_written_by_bioio_is_kept(tmp_path):
    writer = pytest.importorskip("bioio.writers").OmeTiffWriter
    source = tmp_path / "zstack.ome.tif"
    writer.save(np.stack([CAM, ALPHA]), source, dim_order="ZYX", image_name="zstack",
                channel_names=["DAPI"])  # fmt: skip
    assert render(source, "-o", tmp_path / "out.ome.tif") == EXIT_OK
    metadata = read_metadata(tmp_path / "out.ome.tif")
    assert metadata.image_name == "zstack" and metadata.channel_names == ("DAPI",)
    with tifffile.TiffFile(tmp_path / "out.ome.tif") as tif:
        assert 'Name="zstack"' in tif.ome_metadata
