"""Initial DistMesh points: a lattice clipped to the domain, thinned by the size function."""

from __future__ import annotations

from typing import Callable

import numpy as np

__all__ = ["lattice", "initial_points", "evaluate_size"]

# lattice constant (cube side) per unit edge length, chosen so that every lattice has about
# the point density of a regular-ish tetrahedral mesh with edges h (1.4 points per h^3)
_CELL = {"cubic": 1.0, "bcc": 1.1, "fcc": 2.0**0.5}
_BASIS = {
    "cubic": np.zeros((1, 3)),
    "bcc": np.array([[0.0, 0.0, 0.0], [0.5, 0.5, 0.5]]),
    "fcc": np.array([[0.0, 0.0, 0.0], [0.5, 0.5, 0.0], [0.5, 0.0, 0.5], [0.0, 0.5, 0.5]]),
}


def lattice(lower: np.ndarray, upper: np.ndarray, h: float, distribution: str) -> np.ndarray:
    """Points of a ``distribution`` lattice with edge length about ``h`` covering the box.

    Examples
    --------
    >>> lattice(np.zeros(3), np.ones(3), 0.5, "cubic").shape
    (27, 3)
    """
    a = _CELL[distribution] * h
    counts = np.floor((upper - lower) / a + 1e-9).astype(np.int64) + 1
    axes = [lower[k] + a * np.arange(counts[k]) for k in range(3)]
    grid = np.stack(np.meshgrid(*axes, indexing="ij"), axis=-1).reshape(-1, 3)
    points = (grid[None, :, :] + a * _BASIS[distribution][:, None, :]).reshape(-1, 3)
    inside = np.all(points <= upper + 1e-9 * a, axis=1)
    return points[inside]


def evaluate_size(size: Callable, points: np.ndarray) -> np.ndarray:
    """``size(points)`` checked: an (N,) array of finite positive numbers."""
    try:
        values = np.asarray(size(points), dtype=np.float64)
    except (TypeError, ValueError) as exc:
        raise ValueError(f"size must return an (N,) array of positive numbers for (N, 3) points; calling it failed: {exc}") from exc
    if values.shape == (points.shape[0], 1):
        values = values[:, 0]
    if values.shape != (points.shape[0],):
        raise ValueError(f"size must return shape ({points.shape[0]},) for {points.shape[0]} points; got {values.shape}")
    bad = ~(np.isfinite(values) & (values > 0))
    if bad.any():
        raise ValueError(
            f"size must return finite values > 0; got {values[bad][0]!r} at point {points[bad][0].tolist()}"
        )
    return values


def initial_points(
    model,
    lower: np.ndarray,
    upper: np.ndarray,
    h: float,
    distribution: str,
    geps: float,
    jitter: float,
    size: Callable | None,
    fixed: np.ndarray,
    rng: np.random.Generator,
) -> np.ndarray:
    """Fixed points followed by lattice points with sdf < ``geps``, thinned by ``size``.

    With a size function a lattice point is kept with probability ``min(size)^3 / size^3``
    (Persson's rejection), so the edge length where ``size`` is smallest is ``h``. Lattice points
    closer than ``h/2`` to a fixed point are dropped.
    """
    points = lattice(lower, upper, h, distribution)
    if jitter > 0:
        points = points + rng.uniform(-jitter * h, jitter * h, size=points.shape)
    points = points[model(points) < geps] if len(points) else points
    if size is not None and len(points):
        r0 = evaluate_size(size, points)
        keep = rng.random(len(points)) < (r0.min() / r0) ** 3
        points = points[keep]
    if len(fixed) and len(points):
        from scipy.spatial import cKDTree

        near = cKDTree(fixed).query(points, distance_upper_bound=0.5 * h)[0]
        points = points[~np.isfinite(near)]
    return np.concatenate([fixed, points]) if len(fixed) else points
