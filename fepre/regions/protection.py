"""Keep DistMesh points out of the interface triangles' diametral balls.

The interface between two regions is laid out before meshing as a surface triangulation (the
interface triangles of one region's own DistMesh). A triangle whose diametral ball (the smallest
sphere through its three nodes) holds no other point is a face of every Delaunay triangulation
of the points (it is a Gabriel face), so no cell of the final mesh crosses it. Points coming
closer than ``RATIO`` times a triangle's circumradius to its circumcentre are pushed straight
away from the centre to that distance (off its plane, to their own side, when they sit on it).
"""

from __future__ import annotations

import numpy as np

__all__ = ["InterfaceProtection", "RATIO", "drop_protected"]

#: Points stay this many times a triangle's circumradius from its circumcentre.
RATIO = 1.02
#: Free points closer than this (times h) to a fixed node are dropped before the final mesh.
NEAR_NODE = 0.4
#: Nearest triangle centres looked at per point, and pushes per call (neighbouring balls overlap).
_NEAREST = 8
_ROUNDS = 3


def circumcircles(triangles: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Circumcentres (K, 3), circumradii (K,) and unit normals (K, 3) of (K, 3, 3) triangles."""
    a = triangles[:, 0]
    u, v = triangles[:, 1] - a, triangles[:, 2] - a
    normal = np.cross(u, v)
    area2 = np.maximum((normal**2).sum(axis=1), 1e-300)
    offset = (np.cross(v, normal) * (u**2).sum(axis=1)[:, None] + np.cross(normal, u) * (v**2).sum(axis=1)[:, None]) / (2 * area2[:, None])
    centre = a + offset
    radius = np.linalg.norm(offset, axis=1)
    return centre, radius, normal / np.sqrt(area2)[:, None]


class InterfaceProtection:
    """Pushes points out of the diametral balls of interface ``triangles`` (K, 3, 3).

    Parameters
    ----------
    triangles : (K, 3, 3) float array
        Oriented out of region ``inner`` (their right-hand normal points away from it).
    inner : (K,) int array
        The region each triangle bounds.
    owner : callable
        ``owner(points) -> (N,)`` region of each point: a point on a triangle's plane is pushed
        to its own side.
    """

    def __init__(self, triangles: np.ndarray, inner: np.ndarray, owner) -> None:
        from scipy.spatial import cKDTree

        self.centre, self.radius, self.normal = circumcircles(np.asarray(triangles, dtype=np.float64))
        self.reach = RATIO * float(self.radius.max()) if len(self.radius) else 0.0
        self.tree = cKDTree(self.centre) if len(self.radius) else None
        self.inner = np.asarray(inner)
        self.owner = owner

    def inside(self, points: np.ndarray) -> np.ndarray:
        """Mask of points inside some triangle's protected ball."""
        if self.tree is None or len(points) == 0:
            return np.zeros(len(points), dtype=bool)
        depth, _ = self._deepest(points)
        return depth > 0

    def _deepest(self, points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        k = min(_NEAREST, len(self.radius))
        distance, index = self.tree.query(points, k=k, distance_upper_bound=self.reach)
        distance, index = distance.reshape(len(points), k), index.reshape(len(points), k)
        valid = index < len(self.radius)
        safe = np.where(valid, index, 0)
        depth = np.where(valid, RATIO * self.radius[safe] - distance, -np.inf)
        best = np.argmax(depth, axis=1)
        rows = np.arange(len(points))
        return depth[rows, best], safe[rows, best]

    def push(self, points: np.ndarray, movable: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Move the movable points inside a protected ball to its surface, in place.

        Returns the indices of the moved points and how far each moved in all.
        """
        active = np.flatnonzero(movable)
        if self.tree is None or active.size == 0:
            return np.zeros(0, dtype=np.int64), np.zeros(0)
        touched, origins = [], []
        for _ in range(_ROUNDS):  # after the first round only the pushed points can be inside a ball
            depth, ball = self._deepest(points[active])
            close = depth > 0
            if not close.any():
                break
            rows, ball = active[close], ball[close]
            touched.append(rows)
            origins.append(points[rows].copy())
            offset = points[rows] - self.centre[ball]
            length = np.linalg.norm(offset, axis=1)
            along_normal = np.einsum("ij,ij->i", offset, self.normal[ball])
            flat = np.abs(along_normal) < 1e-3 * self.radius[ball]
            if flat.any():  # on the triangle's plane: leave it to the point's own side
                sign = np.where(self.owner(points[rows[flat]]) == self.inner[ball[flat]], -1.0, 1.0)
                offset[flat] += sign[:, None] * self.normal[ball[flat]] * (0.1 * self.radius[ball[flat]])[:, None]
                length = np.linalg.norm(offset, axis=1)
            points[rows] = self.centre[ball] + offset * (RATIO * self.radius[ball] / np.maximum(length, 1e-300))[:, None]
            active = rows
        if not touched:
            return np.zeros(0, dtype=np.int64), np.zeros(0)
        rows, first = np.unique(np.concatenate(touched), return_index=True)  # first: the original position
        return rows, np.linalg.norm(points[rows] - np.concatenate(origins)[first], axis=1)


def drop_protected(model, points: np.ndarray, fixed: np.ndarray, protection: InterfaceProtection, h: float):
    """The loop's points for the final triangulation, without the free ones that the surface
    projection puts back inside a protected ball.

    Near the curve where an interface meets the part's surface (a small interface island on a
    lattice's strut, say), the protection pushes a surface point off the surface and the
    projection brings it back; the final mesh projects it once more. A point left inside a
    ball after that projection would join cells across the interface: it is dropped.

    A free point pushed onto a ball's sphere next to one of its triangle's nodes (which lie on
    that sphere) and left closer than ``NEAR_NODE h`` to a fixed node is dropped too: it would
    make a cell of almost no volume there.

    Returns ``points, fixed, dropped`` (a copy when some were dropped).
    """
    from scipy.spatial import cKDTree

    values = np.asarray(model(points))
    outside = np.flatnonzero((values > 0) & ~fixed)
    projected = points.copy()
    if outside.size:
        projected[outside] = model.project(points[outside], iterations=30, tol=1e-4 * h, warn=False)
    drop = protection.inside(projected) & ~fixed
    if fixed.any() and (~fixed).any():
        distance, _ = cKDTree(points[fixed]).query(projected[~fixed], distance_upper_bound=NEAR_NODE * h)
        drop[np.flatnonzero(~fixed)[distance < NEAR_NODE * h]] = True
    if not drop.any():
        return points, fixed, 0
    keep = ~drop
    return points[keep], fixed[keep], int(drop.sum())
