"""Distance from points to a triangle surface: the triangles whose centroids are nearest (a k-d
tree), then the exact closest point on each (Ericson, Real-Time Collision Detection, 5.1.5)."""

from __future__ import annotations

import numpy as np

__all__ = ["closest_on_triangles", "distance_to_surface"]

#: Triangles (nearest centroids) searched for each point.
NEIGHBOURS = 8
#: Points handled at once (bounds the temporary arrays).
CHUNK = 100_000


def closest_on_triangles(p: np.ndarray, a: np.ndarray, b: np.ndarray, c: np.ndarray) -> np.ndarray:
    """Closest points (..., 3) on triangles ``(a, b, c)`` to points ``p`` (all broadcast).

    Examples
    --------
    >>> import numpy as np
    >>> a, b, c = np.array([0.0, 0, 0]), np.array([1.0, 0, 0]), np.array([0.0, 1, 0])
    >>> closest_on_triangles(np.array([[0.25, 0.25, 1.0], [2.0, -1.0, 0.0]]), a, b, c).tolist()
    [[0.25, 0.25, 0.0], [1.0, 0.0, 0.0]]
    """
    ab, ac, ap = b - a, c - a, p - a
    dot = lambda u, v: np.einsum("...d,...d->...", u, v)  # noqa: E731
    d1, d2 = dot(ab, ap), dot(ac, ap)
    bp = p - b
    d3, d4 = dot(ab, bp), dot(ac, bp)
    cp = p - c
    d5, d6 = dot(ab, cp), dot(ac, cp)
    va, vb, vc = d3 * d6 - d5 * d4, d5 * d2 - d1 * d6, d1 * d4 - d3 * d2
    with np.errstate(divide="ignore", invalid="ignore"):
        on_ab = a + (d1 / (d1 - d3))[..., None] * ab
        on_ac = a + (d2 / (d2 - d6))[..., None] * ac
        on_bc = b + ((d4 - d3) / ((d4 - d3) + (d5 - d6)))[..., None] * (c - b)
        total = va + vb + vc
        inside = a + (vb / total)[..., None] * ab + (vc / total)[..., None] * ac
    regions = [
        (d1 <= 0) & (d2 <= 0),
        (d3 >= 0) & (d4 <= d3),
        (vc <= 0) & (d1 >= 0) & (d3 <= 0),
        (d6 >= 0) & (d5 <= d6),
        (vb <= 0) & (d2 >= 0) & (d6 <= 0),
        (va <= 0) & (d4 - d3 >= 0) & (d5 - d6 >= 0),
    ]
    shape = np.broadcast_shapes(p.shape, a.shape)
    choices = [np.broadcast_to(x, shape) for x in (a, b, on_ab, c, on_ac, on_bc)]
    out = np.broadcast_to(inside, shape).copy()
    for region, point in zip(reversed(regions), reversed(choices)):  # the first region wins
        out = np.where(region[..., None], point, out)
    return out


def distance_to_surface(points: np.ndarray, vertices: np.ndarray, triangles: np.ndarray) -> np.ndarray:
    """Distance (N,) from each point to the triangle surface ``(vertices, triangles)``.

    Exact when the closest triangle is among the ``NEIGHBOURS`` whose centroids are nearest
    (always, for a point near a surface of well-shaped triangles); otherwise an upper bound.

    Examples
    --------
    >>> import numpy as np
    >>> v = np.array([[0.0, 0, 0], [1, 0, 0], [0, 1, 0], [1, 1, 0]])
    >>> distance_to_surface(np.array([[0.5, 0.5, 0.3]]), v, np.array([[0, 1, 2], [1, 3, 2]])).round(9).tolist()
    [0.3]
    """
    from scipy.spatial import cKDTree

    points = np.asarray(points, dtype=np.float64)
    vertices = np.asarray(vertices, dtype=np.float64)
    triangles = np.asarray(triangles, dtype=np.int64)
    corners = vertices[triangles]  # (T, 3, 3)
    tree = cKDTree(corners.mean(axis=1))
    k = min(NEIGHBOURS, len(triangles))
    result = np.empty(len(points))
    for start in range(0, len(points), CHUNK):
        chunk = points[start : start + CHUNK]
        _, nearest = tree.query(chunk, k=k)
        near = corners[nearest.reshape(len(chunk), k)]  # (n, k, 3, 3)
        closest = closest_on_triangles(chunk[:, None, :], near[:, :, 0], near[:, :, 1], near[:, :, 2])
        result[start : start + CHUNK] = np.linalg.norm(closest - chunk[:, None, :], axis=-1).min(axis=1)
    return result
