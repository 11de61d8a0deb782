"""The lazy rendering of a dask array: equal to the rendering in memory, bit for bit.

Whole planes per block whatever the chunks, every plane its own random stream,
nothing computed until asked, tone limits found once, odd inputs refused by
name before any block is read.
"""

import numpy as np
import pytest

from napari_labyrinth import labyrinth, labyrinth_stack, labyrinth_sweep

da = pytest.importorskip("dask.array")


@pytest.fixture(scope="module")
def camera():
    from skimage import data

    return data.camera()[::4, ::4].copy()  # 128 x 128 uint8


class TestDask:
    da = pytest.importorskip("dask.array")

    def test_lazy_result_equals_the_numpy_result(self, camera):
        stack = np.stack([camera, camera[::-1], camera.T])
        lazy_input = self.da.from_array(stack, chunks=(2, 64, 64))  # splits planes
        lazy = labyrinth(lazy_input, passes=2, seed=8)
        assert isinstance(lazy, self.da.Array)
        assert all(len(c) == 1 for c in lazy.chunks[-2:])  # rechunked to whole planes
        np.testing.assert_array_equal(lazy.compute(), labyrinth(stack, passes=2, seed=8))

    @pytest.mark.parametrize("channel_axis", [None, -1])
    def test_auto_v_of_a_lazy_image_is_that_of_its_array(self, camera, channel_axis):
        # its probe took the tone scale of the sampled planes, not the whole image's: a
        # bright plane left out of the sample moved V, and so the rendering
        cam = camera[:256, :256].astype(np.uint16)
        stack = np.stack([cam * 50, cam[::-1] * 50, cam * 257, cam.T * 50, cam[:, ::-1] * 50])
        if channel_axis is not None:
            stack = np.stack([stack, stack[::-1], stack], axis=-1)
        lazy_input = self.da.from_array(stack, chunks=(1,) + stack.shape[1:])
        options = dict(variance_threshold="auto", passes=1, channel_axis=channel_axis)
        expected = labyrinth(stack, **options)
        np.testing.assert_array_equal(labyrinth(lazy_input, **options).compute(), expected)

    def _counting(self, image):
        calls = []

        def load(block):
            if block.size:  # not dask's probe of the function on an empty block
                calls.append(block.shape)
            return block

        lazy_input = self.da.from_array(image, chunks=(1,) + image.shape[1:])
        return lazy_input.map_blocks(load, dtype=image.dtype), calls

    @pytest.mark.parametrize(
        "bad",
        [dict(passes=-1), dict(mean_threshold="x"), dict(preset="nope"), dict(workers=0),
         dict(seed=-3), dict(plane_offset=-1)],  # fmt: skip
    )
    def test_auto_v_of_a_lazy_image_checks_its_arguments_before_reading(self, bad):
        image = np.random.default_rng(0).random((3, 32, 32)).astype(np.float32)
        lazy_input, calls = self._counting(image)
        with pytest.raises((TypeError, ValueError), match=next(iter(bad))):
            labyrinth(lazy_input, variance_threshold="auto", **bad)
        assert calls == []  # no scan of the image for its tone limits first

    def test_a_lazy_sweep_finds_its_tone_limits_once(self):
        image = np.random.default_rng(0).random((3, 32, 32)).astype(np.float32)
        lazy_input, calls = self._counting(image)
        labyrinth(lazy_input)
        one = len(calls)
        calls.clear()
        sweep = labyrinth_sweep(lazy_input, "seed", [1, 2, 3, 4])
        assert len(calls) == one  # not once per value
        expected = labyrinth_sweep(image, "seed", [1, 2, 3, 4])
        np.testing.assert_array_equal(sweep.compute(), expected)

    @pytest.mark.parametrize(
        "case, message",
        [("unknown chunks", "unknown chunk sizes"), ("no planes", "empty"),
         ("no rows", "empty"), ("one axis", "at least 2 dimensions")],  # fmt: skip
    )
    @pytest.mark.parametrize("limits", [None, (0, 10)])
    def test_auto_v_of_an_odd_lazy_image_is_refused_by_name(self, case, message, limits):
        # with tone limits given its probe computed planes before any check: NaN, index
        # and division errors from inside dask
        from napari_labyrinth import find_window

        planes = self.da.from_array(np.zeros((3, 20, 20), np.float32), chunks=(1, 20, 20))
        image = {
            "unknown chunks": planes[planes[:, 0, 0] >= 0],
            "no planes": self.da.zeros((0, 20, 20), chunks=1),
            "no rows": self.da.zeros((3, 0, 20)),
            "one axis": self.da.zeros(20),
        }[case]
        with pytest.raises(ValueError, match=f"image .*{message}"):
            labyrinth(image, variance_threshold="auto", tone_limits=limits)
        with pytest.raises(ValueError, match=f"image .*{message}"):
            find_window(image, tone_limits=limits)

    def test_a_lazy_masked_array_is_refused(self):
        image = np.random.default_rng(0).random((2, 32, 32)).astype(np.float32)
        masked = self.da.ma.masked_array(self.da.from_array(image), mask=image < 0.1)
        with pytest.raises(TypeError, match="dask masked array, whose mask the rendering"):
            labyrinth(masked)

    def test_nothing_is_computed_until_asked(self, camera):
        calls = []

        def load(block):
            calls.append(block.shape)
            return block

        lazy_input = self.da.from_array(np.stack([camera] * 4), chunks=(1, -1, -1))
        lazy = labyrinth(lazy_input.map_blocks(load, dtype=np.uint8))
        assert calls == [] or all(0 in shape or shape == (1, 1, 1) for shape in calls)
        calls.clear()
        np.testing.assert_array_equal(lazy[2].compute(), labyrinth(np.stack([camera] * 4))[2])
        assert len(calls) == 1  # only the plane that was asked for

    def test_rgba_stack_and_sweep(self):
        from skimage import data

        rgb = data.astronaut()[::8, ::8].copy()
        rgba = np.dstack([rgb, np.full(rgb.shape[:2], 9, np.uint8)])
        lazy_rgba = self.da.from_array(rgba, chunks=(32, 32, 2))
        np.testing.assert_array_equal(
            labyrinth(lazy_rgba, channel_axis=-1).compute(), labyrinth(rgba, channel_axis=-1)
        )
        np.testing.assert_array_equal(
            labyrinth_stack(lazy_rgba, passes=2, channel_axis=-1).compute(),
            labyrinth_stack(rgba, passes=2, channel_axis=-1),
        )
        sweep = labyrinth_sweep(self.da.from_array(rgb[..., 0]), "seed", [1, 2])
        assert isinstance(sweep, self.da.Array)
        np.testing.assert_array_equal(
            sweep.compute(), labyrinth_sweep(rgb[..., 0], "seed", [1, 2])
        )

    def test_other_dtypes_get_the_same_default_tone_limits(self, camera):
        data16 = self.da.from_array(camera.astype(np.uint16) * 50, chunks=(32, 64))
        np.testing.assert_array_equal(
            labyrinth(data16).compute(), labyrinth(camera.astype(np.uint16) * 50)
        )
        floats = np.where(camera > 200, np.nan, camera / 7.0)
        np.testing.assert_array_equal(
            labyrinth(self.da.from_array(floats, chunks=(50, 50))).compute(), labyrinth(floats)
        )
        np.testing.assert_array_equal(
            labyrinth(data16, tone_limits=(0, 12750)).compute(),
            labyrinth(camera.astype(np.uint16) * 50, tone_limits=(0, 12750)),
        )

    def test_unavailable_options_say_so(self, camera):
        lazy = self.da.from_array(camera)
        with pytest.raises(ValueError, match="return_diagnostics"):
            labyrinth(lazy, return_diagnostics=True)
        with pytest.raises(ValueError, match="ProgressBar"):
            labyrinth(lazy, progress=print)
        with pytest.raises(TypeError, match="dtype"):
            labyrinth(self.da.zeros((4, 4), dtype=bool))


def test_a_lazy_image_of_subnormal_values_renders_as_in_memory():
    values = np.random.default_rng(0).random((2, 40, 40)) * 1e-310
    lazy = da.from_array(values, chunks=(1, 40, 40))
    np.testing.assert_array_equal(np.asarray(labyrinth(lazy, seed=1)), labyrinth(values, seed=1))
