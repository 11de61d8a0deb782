"""Integer codes shared by the numba kernel, the oracle and the parameter table.

The kernel takes every option as an integer; these names say what each
integer means. numba reads module-level integers as compile-time constants,
so ``border == INSIDE`` in the kernel costs nothing. The option names of the
parameter table are the keys of the ``*_CODES`` mappings below: a name is
tied to its code here, once, and reordering a mapping changes nothing.
"""

from __future__ import annotations

from types import MappingProxyType

# border: which neighbours a border pixel has (Eq. 1)
INSIDE, MIRROR, NEAREST, WRAP = 0, 1, 2, 3
BORDER_CODES = MappingProxyType(
    {"inside": INSIDE, "mirror": MIRROR, "nearest": NEAREST, "wrap": WRAP}
)

# variance_ratio: R2 of Eq. 4
SQRT_V_OVER_N, SQRT_V = 0, 1
VARIANCE_RATIO_CODES = MappingProxyType({"sqrt(V/N)/M": SQRT_V_OVER_N, "sqrt(V)/M": SQRT_V})

# variance_action: what Eq. 4 does where it holds
LEAVE, PUSH_IN_RANGE, PUSH_FULL_SCALE = 0, 1, 2
VARIANCE_ACTION_CODES = MappingProxyType(
    {"leave": LEAVE, "push_in_range": PUSH_IN_RANGE, "push_full_scale": PUSH_FULL_SCALE}
)

# condition_order: which of Eq. 2 and Eq. 4 decides first
MEAN_FIRST, VARIANCE_FIRST = 0, 1
CONDITION_ORDER_CODES = MappingProxyType(
    {"mean_first": MEAN_FIRST, "variance_first": VARIANCE_FIRST}
)

# on_exhausted: a pixel none of whose draws satisfied Eq. 2
KEEP, LAST_DRAW = 0, 1
ON_EXHAUSTED_CODES = MappingProxyType({"keep": KEEP, "last_draw": LAST_DRAW})

# scan: the order of the in-place update
RASTER, SERPENTINE, CHECKERBOARD = 0, 1, 2
SCAN_CODES = MappingProxyType(
    {"raster": RASTER, "serpentine": SERPENTINE, "checkerboard": CHECKERBOARD}
)

# What a pass did with each pixel: the index of its count in ``counts``.
KEPT_BY_MEAN = 0  # Eq. 2 held: g kept
LEFT_BY_VARIANCE = 1  # Eq. 4 held: g left as it is (no push succeeded)
PUSHED = 2  # Eq. 4 held: a draw further from M replaced g (the push readings)
REDRAWN = 3  # a draw of Eq. 3 satisfied Eq. 2 and replaced g
OUT_OF_TRIES = 4  # max_tries draws, none satisfied Eq. 2
SKIPPED = 5  # g not finite, or no finite neighbour
NOISE_GATED = 6  # not kept by Eq. 2 first, but its neighbourhood varies no more than the noise
DIAGNOSTIC_CODES = MappingProxyType(
    {
        "kept_by_mean": KEPT_BY_MEAN,
        "left_by_variance": LEFT_BY_VARIANCE,
        "pushed": PUSHED,
        "redrawn": REDRAWN,
        "out_of_tries": OUT_OF_TRIES,
        "skipped": SKIPPED,
        "noise_gated": NOISE_GATED,
    }
)

#: The diagnostic names in the order of their codes: the fields of the counts.
DIAGNOSTIC_FIELDS = tuple(sorted(DIAGNOSTIC_CODES, key=DIAGNOSTIC_CODES.__getitem__))

#: The option codes of each option parameter, by parameter name.
OPTION_CODES = MappingProxyType(
    {
        "border": BORDER_CODES,
        "variance_ratio": VARIANCE_RATIO_CODES,
        "variance_action": VARIANCE_ACTION_CODES,
        "condition_order": CONDITION_ORDER_CODES,
        "on_exhausted": ON_EXHAUSTED_CODES,
        "scan": SCAN_CODES,
    }
)

assert all(sorted(codes.values()) == list(range(len(codes))) for codes in OPTION_CODES.values())
assert sorted(DIAGNOSTIC_CODES.values()) == list(range(len(DIAGNOSTIC_CODES)))
