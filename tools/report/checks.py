"""Input checks shared by the report's tables and plots: one clear ``ValueError`` each."""

from __future__ import annotations

import math
from typing import Any

import numpy as np

__all__ = ["as_2d", "as_mask", "as_real_2d", "finite_where", "positive_finite", "same_shape"]


def as_2d(array: Any, name: str) -> np.ndarray:
    a = np.asarray(array)
    if a.ndim != 2:
        raise ValueError(f"{name} must be a 2-D array, not {a.ndim}-D with shape {a.shape}")
    if a.size == 0:
        raise ValueError(f"{name} must not be empty, got shape {a.shape}")
    return a


def as_real_2d(array: Any, name: str) -> np.ndarray:
    a = as_2d(array, name)
    if a.dtype == np.bool_ or not np.issubdtype(a.dtype, np.number):
        raise ValueError(f"{name} must hold real numbers, not dtype {a.dtype}")
    if np.iscomplexobj(a):
        raise ValueError(f"{name} must hold real numbers, not dtype {a.dtype}")
    return a.astype(np.float64, copy=False)


def as_mask(array: Any, name: str = "valid") -> np.ndarray:
    a = as_2d(array, name)
    if a.dtype != np.bool_:
        raise ValueError(f"{name} must be a boolean array, not dtype {a.dtype}")
    return a


def same_shape(**arrays: np.ndarray) -> None:
    shapes = {name: a.shape for name, a in arrays.items()}
    if len(set(shapes.values())) > 1:
        listed = ", ".join(f"{name} {shape}" for name, shape in shapes.items())
        raise ValueError(f"array shapes differ: {listed}")


def finite_where(a: np.ndarray, mask: np.ndarray, name: str, where: str) -> None:
    bad = mask & ~np.isfinite(a)
    if bad.any():
        r, c = np.argwhere(bad)[0]
        raise ValueError(
            f"{name} must be finite {where}; {int(bad.sum())} value(s) are not, "
            f"first at row {r}, column {c}: {float(a[r, c])!r}"
        )


def positive_finite(value: Any, name: str) -> float:
    try:
        v = float(value)
    except (TypeError, ValueError):
        raise ValueError(f"{name} must be a positive finite number, not {value!r}") from None
    if not math.isfinite(v) or v <= 0:
        raise ValueError(f"{name} must be a positive finite number, not {value!r}")
    return v
