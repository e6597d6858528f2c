"""Splitting the quads of a dual surface into two triangles each, along the better diagonal.

The order of preference: no zero-area triangle when the other split has none; no triangle
facing against the summed Hermite normals of the quad's cells (a quad folded over itself by
vertices moved onto a crease has exactly one good split); the diagonal joining two crease
vertices (the surface then folds along the crease, not across it); the larger smallest triangle
quality ``4 sqrt(3) area / sum of squared sides`` (1 for an equilateral triangle).
"""

from __future__ import annotations

import numpy as np

__all__ = ["better_diagonal"]

#: a triangle of smaller quality counts as degenerate
_DEGENERATE_QUALITY = 1e-6


def _cross(u: tuple, v: tuple) -> tuple:
    """Cross products of vectors given as (x, y, z) component arrays."""
    return (u[1] * v[2] - u[2] * v[1], u[2] * v[0] - u[0] * v[2], u[0] * v[1] - u[1] * v[0])


def _dot(u: tuple, v: tuple) -> np.ndarray:
    return u[0] * v[0] + u[1] * v[1] + u[2] * v[2]


def better_diagonal(points: np.ndarray, quads: np.ndarray, crease: np.ndarray, facing: np.ndarray) -> np.ndarray:
    """True where a quad (Q, 4) is better split along 0-2 than along 1-3.

    ``crease`` (C,) marks the crease and corner vertices, ``facing`` (C, 3) holds each cell's
    summed Hermite normals.

    Examples
    --------
    >>> import numpy as np
    >>> points = np.array([[0.0, 0, 0], [1, 0.8, 0], [2, 0, 0], [1, 1, 0]])  # a dart: 0-2 folds
    >>> facing = np.tile([0.0, 0.0, 1.0], (4, 1))
    >>> better_diagonal(points, np.array([[0, 1, 2, 3]]), np.zeros(4, bool), facing).tolist()
    [False]
    """
    corners = [tuple(points[quads[:, c], a] for a in range(3)) for c in range(4)]

    def minus(i: int, j: int) -> tuple:
        return tuple(corners[i][a] - corners[j][a] for a in range(3))

    e01, e12, e23, e30, e02, e13 = minus(1, 0), minus(2, 1), minus(3, 2), minus(0, 3), minus(2, 0), minus(3, 1)
    s01, s12, s23, s30, s02, s13 = (_dot(e, e) for e in (e01, e12, e23, e30, e02, e13))
    # twice the area vectors of the four triangles, oriented like the quad
    n012, n023 = _cross(e01, e02), _cross(e02, minus(3, 0))
    n013, n123 = _cross(e01, minus(3, 0)), _cross(e12, e13)
    quad_facing = tuple(facing[quads, a].sum(axis=1) for a in range(3))
    scale = 2 * np.sqrt(3)

    def quality(n: tuple, squares: np.ndarray) -> np.ndarray:
        return np.divide(scale * np.sqrt(_dot(n, n)), squares, out=np.zeros_like(squares), where=squares > 0)

    q02 = np.minimum(quality(n012, s01 + s12 + s02), quality(n023, s02 + s23 + s30))
    q13 = np.minimum(quality(n013, s01 + s13 + s30), quality(n123, s12 + s23 + s13))
    good02 = 2 * (q02 > _DEGENERATE_QUALITY) + ((_dot(n012, quad_facing) > 0) & (_dot(n023, quad_facing) > 0))
    good13 = 2 * (q13 > _DEGENERATE_QUALITY) + ((_dot(n013, quad_facing) > 0) & (_dot(n123, quad_facing) > 0))
    crease02 = crease[quads[:, 0]] & crease[quads[:, 2]]
    crease13 = crease[quads[:, 1]] & crease[quads[:, 3]]
    return np.where(good02 != good13, good02 > good13, np.where(crease02 != crease13, crease02, q02 >= q13))
