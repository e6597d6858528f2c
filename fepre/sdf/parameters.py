"""Parameter checks and conversions shared by the primitive shapes."""

from __future__ import annotations

from typing import Any

import numpy as np

from ..arguments import as_vector

__all__ = ["floats", "positive_vector", "unit_vector"]


def floats(vector: np.ndarray) -> tuple[float, ...]:
    """Python floats, so arithmetic with float32 arrays stays float32 (numpy scalars would not)."""
    return tuple(float(v) for v in vector)


def positive_vector(value: Any, dim: int, name: str) -> np.ndarray:
    """A finite vector of ``dim`` entries, each > 0 (a number is repeated ``dim`` times)."""
    vector = as_vector(value, dim, name, allow_scalar=True)
    if np.any(vector <= 0):
        raise ValueError(f"{name} must have every entry > 0; got {np.asarray(value).tolist()}")
    return vector


def unit_vector(vector: np.ndarray, name: str) -> np.ndarray:
    """``vector`` normalised; a zero vector is refused."""
    length = float(np.linalg.norm(vector))
    if length == 0.0 or not np.isfinite(length):
        raise ValueError(f"{name} must be a non-zero finite vector; got {vector.tolist()}")
    return vector / length
