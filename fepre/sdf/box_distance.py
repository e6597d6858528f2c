"""Exact signed distance to an axis-aligned box, and its gradient, on coordinate arrays.

The guard of booleans (:mod:`fepre.sdf.booleans`) and the deformations
(:mod:`fepre.sdf.deform`) both measure it; it knows nothing of models.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:
    from .core import Bounds, Coords

__all__ = ["box_distance", "box_distance_and_gradient"]


def box_distance(coords: Coords, bounds: Bounds) -> np.ndarray:
    """Exact signed distance to the axis-aligned box ``bounds`` (per-axis work on axis arrays)."""
    lo, hi = np.asarray(bounds[0], dtype=float), np.asarray(bounds[1], dtype=float)
    centre, half = (lo + hi) / 2.0, (hi - lo) / 2.0
    d = [np.abs(c - float(m)) - float(h) for c, m, h in zip(coords, centre, half)]
    outside = np.sqrt(sum(np.maximum(di, 0.0) ** 2 for di in d))
    inside = d[0]
    for di in d[1:]:
        inside = np.maximum(inside, di)
    return outside + np.minimum(inside, 0.0)


def box_distance_and_gradient(coords: Coords, bounds: Bounds) -> tuple[np.ndarray, Coords]:
    """Box distance and its gradient."""
    lo, hi = np.asarray(bounds[0], dtype=float), np.asarray(bounds[1], dtype=float)
    centre, half = (lo + hi) / 2.0, (hi - lo) / 2.0
    shifted = np.broadcast_arrays(*(c - float(m) for c, m in zip(coords, centre)))
    d = [np.abs(s) - float(h) for s, h in zip(shifted, half)]
    positive = [np.maximum(di, 0.0) for di in d]
    outside = np.sqrt(sum(p * p for p in positive))
    dmax = np.max(d, axis=0)
    safe = np.where(outside > 0, outside, 1.0)
    axis_of_max = np.argmax(d, axis=0)
    gradient = tuple(
        np.where(outside > 0, positive[i] / safe, (axis_of_max == i).astype(float)) * np.sign(shifted[i] + (shifted[i] == 0))
        for i in range(len(coords))
    )
    return outside + np.minimum(dmax, 0.0), gradient
