"""Points on one face of the periodic cell: a small 2D DistMesh (Persson and Strang 2004).

The face's solid region is ``{model < 0}`` on the face's plane. Its sides carry fixed nodes
(the cell's edge nodes and corners, shared with every face that meets there); free points
start on a triangular lattice, are pushed apart by the bar forces of their Delaunay
triangulation, are projected back onto the region's rim (the model's zero curve in the plane)
when they leave it and are kept a little away from the sides, which only the fixed nodes
represent. The opposite face receives these points translated by one period.
"""

from __future__ import annotations

import numpy as np

__all__ = ["face_points"]

#: free points stay this far (times h) from the face's sides
SIDE_MARGIN = 0.3
#: the loop stops when no interior point moves more than this (times h)
TOLERANCE = 1e-3
MAXITER = 400
DELTA_T = 0.2
#: retriangulate when a point moved this far (times h) since the last triangulation
RETRIANGULATE = 0.1


class _Plane:
    """The model on the plane ``axis = level``, in the in-plane coordinates ``(u, v)``."""

    def __init__(self, model, axis: int, level: float):
        self.model, self.axis, self.level = model, axis, level
        self.inplane = [a for a in range(3) if a != axis]

    def lift(self, uv: np.ndarray) -> np.ndarray:
        points = np.empty((uv.shape[0], 3))
        points[:, self.inplane] = uv
        points[:, self.axis] = self.level
        return points

    def values(self, uv: np.ndarray) -> np.ndarray:
        return self.model(self.lift(uv))

    def project(self, uv: np.ndarray, iterations: int = 1) -> np.ndarray:
        """Newton steps onto the zero curve with the in-plane part of the gradient."""
        uv = uv.copy()
        for _ in range(iterations):
            values, gradient = self.model.value_and_gradient(self.lift(uv))
            g = gradient[:, self.inplane]
            norm2 = np.einsum("ij,ij->i", g, g)
            norm2 = np.where(norm2 > 1e-24, norm2, 1.0)
            uv -= (values / norm2)[:, None] * g
        return uv


def _lattice(lower: np.ndarray, upper: np.ndarray, h: float) -> np.ndarray:
    """A triangular lattice of spacing ``h`` over the rectangle, rows offset by ``h/2``."""
    dy = h * np.sqrt(3.0) / 2.0
    rows = np.arange(lower[1], upper[1] + 1e-9 * h, dy)
    columns = np.arange(lower[0], upper[0] + h, h)
    u = columns[None, :] + 0.5 * h * (np.arange(rows.size) % 2)[:, None]
    v = np.broadcast_to(rows[:, None], u.shape)
    return np.column_stack([u.ravel(), v.ravel()])


def _bars(triangles: np.ndarray) -> np.ndarray:
    edges = np.sort(triangles[:, [[0, 1], [1, 2], [2, 0]]].reshape(-1, 2), axis=1)
    return np.unique(edges, axis=0)


def face_points(model, axis: int, level: float, lower: np.ndarray, upper: np.ndarray, h: float,
                fixed: np.ndarray, seed: int = 0) -> np.ndarray:
    """Free points ``(K, 2)`` of the face ``axis = level`` of the rectangle ``[lower, upper]``
    (in-plane coordinates), spaced about ``h`` and fitting the fixed side nodes ``fixed``."""
    from scipy.spatial import Delaunay, cKDTree

    plane = _Plane(model, axis, level)
    geps = 1e-3 * h
    margin = SIDE_MARGIN * h
    low, high = lower + margin, upper - margin
    free = _lattice(lower, upper, h)
    free += np.random.default_rng(seed).uniform(-1e-3 * h, 1e-3 * h, free.shape)  # no co-circular ties
    free = free[((free >= lower + 0.5 * h) & (free <= upper - 0.5 * h)).all(axis=1)]
    free = free[plane.values(free) < -geps]
    if len(fixed) and len(free):
        distance, _ = cKDTree(fixed).query(free)
        free = free[distance > 0.5 * h]
    if len(free) == 0:
        return free
    n_fixed = len(fixed)
    p = np.vstack([fixed, free]) if n_fixed else free.copy()
    last = np.full_like(p, np.inf)
    bars = np.zeros((0, 2), np.int64)
    for _ in range(MAXITER):
        if np.abs(p - last).max() > RETRIANGULATE * h:
            last = p.copy()
            triangles = Delaunay(p).simplices
            centroids = p[triangles].mean(axis=1)
            triangles = triangles[plane.values(centroids) < -geps]
            bars = _bars(triangles)
        vectors = p[bars[:, 0]] - p[bars[:, 1]]
        lengths = np.sqrt(np.einsum("ij,ij->i", vectors, vectors))
        natural = 1.2 * np.sqrt(np.mean(lengths**2)) if len(lengths) else h
        push = np.maximum(natural - lengths, 0.0) / np.where(lengths > 0, lengths, 1.0)
        bar_force = push[:, None] * vectors
        force = np.zeros_like(p)
        for k in range(2):
            force[:, k] = np.bincount(bars[:, 0], bar_force[:, k], len(p)) - np.bincount(bars[:, 1], bar_force[:, k], len(p))
        force[:n_fixed] = 0.0
        move = DELTA_T * force
        p += move
        values = plane.values(p[n_fixed:])
        outside = np.flatnonzero(values > 0) + n_fixed
        if outside.size:
            p[outside] = plane.project(p[outside])
        p[n_fixed:] = np.clip(p[n_fixed:], low, high)
        interior = values < -geps
        step = np.sqrt(np.einsum("ij,ij->i", move[n_fixed:], move[n_fixed:]))
        if not interior.any() or step[interior].max() < TOLERANCE * h:
            break
    free = p[n_fixed:]
    values = plane.values(free)
    rim = np.flatnonzero(values > -0.05 * h)
    if rim.size:
        free[rim] = plane.project(free[rim], iterations=20)
    keep = (plane.values(free) < 1e-9 * h) & ((free >= low - 1e-12) & (free <= high + 1e-12)).all(axis=1)
    free = free[keep]
    # points that met (the rim's tight bends): keep one of each close pair
    if len(free) > 1:
        pairs = cKDTree(free).query_pairs(0.2 * h, output_type="ndarray")
        if len(pairs):
            drop = np.zeros(len(free), bool)
            drop[np.unique(pairs.max(axis=1))] = True
            free = free[~drop]
    if n_fixed and len(free):
        distance, _ = cKDTree(fixed).query(free)
        free = free[distance > 0.2 * h]
    return free
