"""The hostile-input property: any small image, any valid parameters, nothing but a clean result
or a ValueError/TypeError.

Random images of every supported dtype (both byte orders) and layout (2-D,
stacks, 2/3/4 channels on any axis, alpha or not) with extreme values (NaN,
infinities, the dtype's limits, subnormals) and random valid parameters drawn
from the parameter table's own bounds. For each:

- only ValueError or TypeError escape;
- the output has the input's shape and dtype, and the input is unmodified;
- the same seed gives the same bytes, and 1 or 2 workers give the same bytes;
- a finite input gives a finite output; a NaN pixel stays NaN.

``make test`` runs ``HOSTILE_EXAMPLES`` examples (default 2000); ``make fuzz``
runs 20,000.
"""

import math
import os

import numpy as np
import pytest
from hypothesis import HealthCheck, given, seed, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays

from napari_labyrinth import labyrinth
from napari_labyrinth.core.parameters import PARAMETERS, SEED
from napari_labyrinth.core.tone_scale import SUPPORTED_DTYPES

EXAMPLES = int(os.environ.get("HOSTILE_EXAMPLES", "2000"))
#: The examples run in this many tests of their own (one seed each unless HOSTILE_SEED is
#: set), so that the test processes share them.
SHARDS = 4

FUZZ = settings(
    max_examples=max(1, EXAMPLES // SHARDS),
    deadline=None,
    suppress_health_check=list(HealthCheck),
    database=None,
)

DTYPES = [*SUPPORTED_DTYPES, *(d.newbyteorder(">") for d in SUPPORTED_DTYPES if d.itemsize > 1)]


def _values(dtype: np.dtype):
    if dtype.kind == "f":
        info = np.finfo(dtype)
        return st.one_of(
            st.floats(allow_nan=True, allow_infinity=True, width=8 * dtype.itemsize),
            st.sampled_from([float(info.max), float(info.min), float(info.tiny), 0.0, -0.0]),
        )
    info = np.iinfo(dtype)
    return st.one_of(
        st.integers(int(info.min), int(info.max)),
        st.sampled_from([int(info.min), int(info.max), 0]),
    )


@st.composite
def images(draw):
    """(image, channel_axis, alpha): a small image of any supported dtype and layout."""
    dtype = draw(st.sampled_from(DTYPES))
    height, width = draw(st.integers(1, 7)), draw(st.integers(1, 7))
    layout = draw(st.sampled_from(["2d", "stack", "channels"]))
    channel_axis = alpha = None
    if layout == "2d":
        shape = (height, width)
    elif layout == "stack":
        shape = (draw(st.integers(1, 3)), height, width)
    else:
        channels = draw(st.sampled_from([2, 3, 4]))
        channel_axis = draw(st.sampled_from([0, -1]))
        shape = (channels, height, width) if channel_axis == 0 else (height, width, channels)
        alpha = draw(st.sampled_from([None, True] + ([False] if channels != 4 else [])))
    constant = draw(st.booleans())
    if constant:  # constant images: collapsing tone limits, 1e16 and the like
        image = np.full(shape, draw(_values(dtype)), dtype=dtype)
    else:
        image = draw(arrays(dtype, shape, elements=_values(dtype)))
    return image, channel_axis, alpha


def _bounded(name, low=None, high=None):
    parameter = PARAMETERS[name]
    low = parameter.low if low is None else low
    high = parameter.high if high is None else high
    if parameter.kind == "float":
        return st.one_of(st.floats(low, high), st.sampled_from([parameter.low, parameter.high]))
    return st.integers(low, high)


@st.composite
def options(draw):
    """Valid keyword arguments: every parameter within the table's bounds (passes and
    max_tries kept small so that an example stays fast)."""
    chosen = {
        "mean_threshold": draw(_bounded("mean_threshold")),
        "variance_threshold": draw(_bounded("variance_threshold")),
        "passes": draw(st.integers(0, 3)),
        "max_tries": draw(st.integers(0, 12)),
        "seed": draw(st.one_of(st.integers(0, SEED.high), st.just(SEED.high))),
    }
    for name, parameter in PARAMETERS.items():
        if parameter.kind == "choice":
            chosen[name] = draw(st.sampled_from(parameter.choices))
        elif parameter.kind == "bool":
            chosen[name] = draw(st.booleans())
    ranges = draw(st.one_of(st.integers(1, 255), st.just(None)))
    if ranges is not None:
        chosen["tone_ranges"] = ranges
    if draw(st.booleans()):
        low = draw(st.floats(-1e30, 1e30))
        width = draw(st.floats(1e-3, 1e30))
        if math.isfinite(low + width) and low + width > low:
            chosen["tone_limits"] = (low, low + width)
    return chosen


def _same(a: np.ndarray, b: np.ndarray) -> bool:
    return a.dtype == b.dtype and a.shape == b.shape and a.tobytes() == b.tobytes()


@pytest.mark.slow
@pytest.mark.parametrize("shard", range(SHARDS))
def test_any_small_image_renders_cleanly_or_is_refused_with_a_value_or_type_error(shard):
    check = given(
        case=images(), kwargs=options(), colour=st.sampled_from([None, "channels", "luminance"])
    )(_renders_cleanly_or_is_refused)
    if os.environ.get("HOSTILE_SEED") is None:
        check = seed(shard)(check)  # the same examples on every run
    FUZZ(check)()


def _renders_cleanly_or_is_refused(case, kwargs, colour):
    image, channel_axis, alpha = case
    before = image.copy()
    call = dict(kwargs, channel_axis=channel_axis, alpha=alpha, colour=colour)
    try:
        first = labyrinth(image, workers=1, **call)
    except (ValueError, TypeError):
        assert _same(image, before)
        return
    assert _same(image, before), "the input was modified"
    assert first.shape == image.shape and first.dtype == image.dtype
    assert _same(labyrinth(image, workers=1, **call), first), "same seed, other bytes"
    assert _same(labyrinth(image, workers=2, **call), first), "workers changed the bytes"
    if image.dtype.kind == "f":
        finite = np.isfinite(image)
        assert np.isfinite(first[finite]).all(), "a finite pixel became inf or NaN"
        assert np.isnan(first[np.isnan(image)]).all()
    if alpha or (alpha is None and channel_axis is not None and image.shape[channel_axis] == 4):
        last = np.take(image, -1, axis=channel_axis)
        assert _same(np.take(first, -1, axis=channel_axis), last), "alpha was rendered"


@pytest.mark.parametrize("dtype", DTYPES, ids=str)
def test_every_dtype_in_the_property_renders_at_least_once(dtype):
    # the property would pass vacuously if every example were refused
    image = np.arange(36, dtype=np.float64).reshape(6, 6).astype(dtype)
    out = labyrinth(image, passes=2, seed=3)
    assert out.dtype == image.dtype and out.shape == image.shape
