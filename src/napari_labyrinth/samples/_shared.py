"""What the sample images share: their arguments checked, seeded points and boxes."""

from __future__ import annotations

import numbers
from typing import Any

import numpy as np


def _is_finite_real(value: Any) -> bool:
    return (
        isinstance(value, numbers.Real)
        and not isinstance(value, (bool, np.bool_))
        and bool(np.isfinite(value))
    )


def _validate_shape(shape: Any) -> tuple[int, int]:
    if isinstance(shape, (str, bytes)) or not hasattr(shape, "__len__") or len(shape) != 2:
        raise TypeError(f"shape must be (rows, columns), got {shape!r}")
    if not all(isinstance(n, numbers.Integral) and not isinstance(n, bool) for n in shape):
        raise TypeError(f"shape must hold integers, got {shape!r}")
    rows, columns = (int(n) for n in shape)
    if rows < 1 or columns < 1:
        raise ValueError(f"shape must be positive, got {shape!r}")
    return rows, columns


def _validate_seed(seed: Any) -> int:
    if not isinstance(seed, numbers.Integral) or isinstance(seed, bool) or seed < 0:
        raise ValueError(f"seed must be a non-negative integer, got {seed!r}")
    return int(seed)


def _validate_noise(noise: Any) -> float:
    if not isinstance(noise, numbers.Real) or isinstance(noise, bool):
        raise TypeError(f"noise must be a real number, got {noise!r}")
    if not np.isfinite(noise) or noise < 0:
        raise ValueError(f"noise must be finite and >= 0, got {noise!r}")
    return float(noise)


def _validate_defects(defects: Any) -> np.ndarray:
    table = np.asarray(defects, dtype=np.float64)
    if table.ndim != 2 or table.shape[1] != 3:
        raise ValueError(f"defects must be rows (y, x, strength), got shape {table.shape}")
    if not np.isfinite(table).all():
        raise ValueError("defects must be finite")
    doubled = 2.0 * table[:, 2]
    if np.any(doubled == 0) or not np.allclose(doubled, np.round(doubled)):
        raise ValueError(
            f"defect strengths must be non-zero multiples of 1/2, got {table[:, 2].tolist()}"
        )
    return table


def _validate_retardance(retardance: Any, shape: tuple[int, int]) -> np.ndarray:
    field = np.asarray(retardance, dtype=np.float64)
    try:
        field = np.broadcast_to(field, shape)
    except ValueError:
        raise ValueError(
            f"retardance must be a scalar or broadcastable to {shape}, got shape {field.shape}"
        ) from None
    if not np.isfinite(field).all():
        raise ValueError("retardance must be finite")
    return field


def _box(cy: float, cx: float, reach: float, rows: int, columns: int) -> tuple[slice, slice]:
    """The slices of the pixels within ``reach`` (rows and columns) of ``(cy, cx)``."""
    top, bottom = max(0, int(cy - reach)), min(rows, int(cy + reach) + 2)
    left, right = max(0, int(cx - reach)), min(columns, int(cx + reach) + 2)
    return slice(top, max(top, bottom)), slice(left, max(left, right))


def _zero_sum_strengths(rng: np.random.Generator, count: int) -> np.ndarray:
    """``count`` strengths from ``liquid_crystals.DEFECT_STRENGTHS`` adding up to zero."""
    halves = np.array([-2, -1, 1, 2])  # strengths in units of 1/2
    # Half-integer defects are the common ones in nematic films: favour them.
    weights = np.array([1.0, 2.0, 2.0, 1.0])
    weights /= weights.sum()
    for _ in range(1000):
        draw = rng.choice(halves, size=count, p=weights)
        if draw.sum() == 0:
            return draw / 2.0
    # Not reached in practice (each try succeeds with probability > 1/4 for
    # count >= 2): opposite pairs, and one +1, -1/2, -1/2 triple for odd counts.
    draw = np.resize([1, -1], count)
    if count % 2:
        draw[-3:] = [2, -1, -1]
    return draw / 2.0


def _spread_points(rng: np.random.Generator, count: int, rows: int, columns: int) -> np.ndarray:
    """``count`` seeded points ``(y, x)``, kept apart and off the border when possible."""
    margin_y, margin_x = 0.08 * rows, 0.08 * columns
    spacing = 0.6 * np.sqrt(rows * columns / count)
    points: list[tuple[float, float]] = []
    for _ in range(200 * count):
        if len(points) == count:
            break
        y = rng.uniform(margin_y, rows - 1 - margin_y)
        x = rng.uniform(margin_x, columns - 1 - margin_x)
        if all(np.hypot(y - py, x - px) >= spacing for py, px in points):
            points.append((y, x))
        else:
            spacing *= 0.995  # relax slowly so that the loop always ends
    while len(points) < count:
        points.append((rng.uniform(0, rows - 1), rng.uniform(0, columns - 1)))
    # Offset by a quarter pixel so that no defect sits exactly on a pixel centre.
    return np.asarray(points) + 0.25
