"""The nodes on the periodic cell's faces, edges and corners, laid out identically on each face
and its opposite (offset by the period).

Corners, edges and faces each form classes of boundary pieces that periodicity identifies: the
eight corners, the four edges along each axis, the two faces normal to each axis. Nodes are
made once per class, on the piece through the cell's lowest corner, and copied onto the others:
edge nodes spaced about ``h`` along the solid parts of the edge, ending at its crossings of the
zero set; face nodes from a 2D DistMesh (:func:`~fepre.periodic.face_points.face_points`) that
fits the face's four (class-shared) sides.
"""

from __future__ import annotations

import itertools

import numpy as np

from .cell import PeriodicCell
from .face_points import face_points

__all__ = ["boundary_nodes", "edge_parameters"]

#: samples per h when looking for the zero crossings along an edge
_EDGE_SAMPLES = 8
_BISECTIONS = 60


def _crossings(values_of, t: np.ndarray, f: np.ndarray) -> np.ndarray:
    """Zero crossings of ``f`` between consecutive samples, refined by bisection."""
    index = np.flatnonzero((f[:-1] < 0) != (f[1:] < 0))
    a, b = t[index].copy(), t[index + 1].copy()
    fa = f[index]
    for _ in range(_BISECTIONS):
        m = 0.5 * (a + b)
        fm = values_of(m)
        left = (fm < 0) == (fa < 0)
        a, fa = np.where(left, m, a), np.where(left, fm, fa)
        b = np.where(left, b, m)
    return 0.5 * (a + b)


def edge_parameters(model, cell: PeriodicCell, axis: int, h: float) -> np.ndarray:
    """Positions (along ``axis``) of the nodes inside the edge along ``axis`` through the cell's
    lowest corner, strictly between its two corners: about ``h`` apart on each solid stretch,
    including the stretch's ends where the edge crosses the zero set."""
    t0, t1 = float(cell.lower[axis]), float(cell.upper[axis])
    origin = cell.lower.copy()

    def values_of(t: np.ndarray) -> np.ndarray:
        points = np.repeat(origin[None, :], t.size, axis=0)
        points[:, axis] = t
        return model(points)

    t = np.linspace(t0, t1, int(np.ceil((t1 - t0) / h * _EDGE_SAMPLES)) + 1)
    f = values_of(t)
    cuts = _crossings(values_of, t, f)
    ends = np.concatenate([[t0], cuts, [t1]])
    nodes = []
    for a, b in zip(ends[:-1], ends[1:]):
        if b - a <= 1e-12 * (t1 - t0) or values_of(np.array([0.5 * (a + b)]))[0] >= 0:
            continue
        intervals = max(1, int(round((b - a) / h)))
        nodes.append(a + (b - a) * np.arange(intervals + 1) / intervals)
    if not nodes:
        return np.zeros(0)
    nodes = np.unique(np.concatenate(nodes))
    tol = 1e-9 * (t1 - t0)
    return nodes[(nodes > t0 + tol) & (nodes < t1 - tol)]


def boundary_nodes(model, cell: PeriodicCell, h: float, seed: int = 0) -> np.ndarray:
    """(K, 3) nodes on the faces, edges and corners of ``cell``, periodic by construction.

    ``model`` is the unbounded periodic model (not cut by the cell).
    """
    lower, upper = cell.lower, cell.upper
    levels = np.stack([lower, upper])  # levels[s, axis]
    corner_solid = bool(model(lower[None, :])[0] <= 0.0)
    edges = [edge_parameters(model, cell, axis, h) for axis in range(3)]
    pieces = []
    if corner_solid:
        pieces.append(np.array([[levels[s[0], 0], levels[s[1], 1], levels[s[2], 2]] for s in itertools.product((0, 1), repeat=3)]))
    for axis in range(3):
        others = [a for a in range(3) if a != axis]
        for s, r in itertools.product((0, 1), repeat=2):
            block = np.empty((edges[axis].size, 3))
            block[:, axis] = edges[axis]
            block[:, others[0]], block[:, others[1]] = levels[s, others[0]], levels[r, others[1]]
            pieces.append(block)
    for axis in range(3):
        u, v = [a for a in range(3) if a != axis]
        sides = [np.column_stack([edges[u], np.full(edges[u].size, levels[s, v])]) for s in (0, 1)]
        sides += [np.column_stack([np.full(edges[v].size, levels[s, u]), edges[v]]) for s in (0, 1)]
        if corner_solid:
            sides.append(np.array([[levels[s, u], levels[r, v]] for s, r in itertools.product((0, 1), repeat=2)]))
        fixed = np.vstack(sides)
        free = face_points(model, axis, float(lower[axis]), lower[[u, v]], upper[[u, v]], h, fixed, seed=seed + axis)
        for s in (0, 1):
            block = np.empty((len(free), 3))
            block[:, axis] = levels[s, axis]
            block[:, u], block[:, v] = free[:, 0], free[:, 1]
            pieces.append(block)
    return np.vstack(pieces) if pieces else np.zeros((0, 3))
