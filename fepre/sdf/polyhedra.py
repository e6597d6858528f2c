"""Regular convex polyhedra with exact distances: the tetrahedron and the octahedron.

Both fold space by their symmetries so that one face (and one of its edges) decides the
distance: a few dozen array operations per point instead of a loop over faces and edges.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from ..arguments import as_vector, positive_float
from .core import SDF

__all__ = ["tetrahedron", "octahedron"]


class Tetrahedron(SDF):
    """Regular tetrahedron with circumradius ``radius`` around ``center`` (exact).

    Inside, the value is the largest face height. Outside, the nearest point lies on the face
    of largest height (the dihedral angles are acute: a face not containing the nearest point is
    always lower). The symmetry that flips two coordinate signs maps that face onto the face
    ``x + y + z = -s`` opposite the vertex (s, s, s); that face is symmetric under coordinate
    permutations, so with sorted coordinates the nearest point is the foot of the perpendicular
    or lies on the one edge (a, -a, -s).
    """

    def __init__(self, radius: float, center: np.ndarray) -> None:
        self.radius, self.center = radius, center
        self._c = tuple(float(v) for v in center)
        self._s = radius / math.sqrt(3.0)  # vertices at center + s * (+-1, +-1, +-1), even signs
        directions = np.array([[1, 1, 1], [1, -1, -1], [-1, 1, -1], [-1, -1, 1]], dtype=float)
        self.vertices = center + self._s * directions
        super().__init__(bounds=(tuple(center - self._s), tuple(center + self._s)), exact=True)

    def _parameters(self) -> dict[str, Any]:
        return {"radius": self.radius, "center": self.center}

    def _label(self) -> str:
        return "tetrahedron"

    #: normals (times sqrt 3) of the faces g1..g4 of ``_values``: face i is ``n_i . p = s``
    _FACE_NORMALS = np.array([[-1, -1, -1], [-1, 1, 1], [1, -1, 1], [1, 1, -1]], dtype=float)

    @property
    def patch_count(self) -> int:
        return 4

    def _patch_labels(self, points):
        heights = (points - np.asarray(self._c)) @ self._FACE_NORMALS.T
        return self._values(*points.T), np.argmax(heights, axis=1)

    def _patch_values(self, labels, points):
        heights = np.einsum("ij,ij->i", points - np.asarray(self._c), self._FACE_NORMALS[labels])
        return (heights - self._s) / math.sqrt(3.0)

    def _values(self, x, y, z):
        s = self._s
        k = 1.0 / math.sqrt(3.0)
        x, y, z = (u - c for u, c in zip((x, y, z), self._c))
        # g_i = sqrt(3) * height_i + s for the face opposite the vertex in direction u_i.
        xy_plus, xy_minus = x + y, x - y
        g1 = -(xy_plus + z)
        g2 = z - xy_minus
        g3 = xy_minus + z
        g4 = xy_plus - z
        best = np.maximum(np.maximum(g1, g2), np.maximum(g3, g4))
        inside = (best - s) * k
        is4 = g4 == best
        is3 = (g3 == best) & ~is4
        is2 = (g2 == best) & ~is4 & ~is3
        fx = np.where(is4 | is3, -x, x)
        fy = np.where(is4 | is2, -y, y)
        fz = np.where(is3 | is2, -z, z)
        hi = np.maximum(np.maximum(fx, fy), fz)
        lo = np.minimum(np.minimum(fx, fy), fz)
        mid = (fx + fy + fz) - hi - lo
        height = -(hi + mid + lo + s) * k
        foot_inside = lo + height * k >= -s
        a = np.clip((hi - mid) * 0.5, -s, s)
        edge = np.sqrt((hi - a) ** 2 + (mid + a) ** 2 + (lo + s) ** 2)
        return np.where(inside > 0, np.where(foot_inside, height, edge), inside)


class Octahedron(SDF):
    """Regular octahedron ``|x| + |y| + |z| <= radius`` around ``center`` (exact).

    Reflected into the first octant, a point is nearest to the face plane unless its foot falls
    outside the face; then it is nearest to the edge of the face opposite the axis along which
    the point lies farthest beyond the face (the three cases below), clamped to that edge.
    """

    def __init__(self, radius: float, center: np.ndarray) -> None:
        self.radius, self.center = radius, center
        self._c = tuple(float(v) for v in center)
        self.vertices = center + radius * np.vstack([np.eye(3), -np.eye(3)])
        super().__init__(bounds=(tuple(center - radius), tuple(center + radius)), exact=True)

    def _parameters(self) -> dict[str, Any]:
        return {"radius": self.radius, "center": self.center}

    def _label(self) -> str:
        return "octahedron"

    @property
    def patch_count(self) -> int:
        return 8  # one face per octant: label 4 (x < 0) + 2 (y < 0) + (z < 0)

    def _patch_labels(self, points):
        negative = points < np.asarray(self._c)
        return self._values(*points.T), negative @ np.array([4, 2, 1])

    def _patch_values(self, labels, points):
        signs = 1.0 - 2.0 * np.column_stack([(labels >> 2) & 1, (labels >> 1) & 1, labels & 1])
        return (np.einsum("ij,ij->i", points - np.asarray(self._c), signs) - self.radius) / math.sqrt(3.0)

    def _values(self, x, y, z):
        s = self.radius
        px, py, pz = (np.abs(u - c) for u, c in zip((x, y, z), self._c))
        m = px + py + (pz - s)
        face = m * (1.0 / math.sqrt(3.0))
        # Candidate nearest edges: the edge of the face's triangle in the plane where the
        # first-listed coordinate would be zero, i.e. q = (px, py, pz), (py, pz, px), (pz, px, py).
        result = face
        chosen = np.zeros(np.shape(m), dtype=bool)
        for qx, qy, qz in ((px, py, pz), (py, pz, px), (pz, px, py)):
            case = (3.0 * qx < m) & ~chosen
            k = np.clip(0.5 * (qz - qy + s), 0.0, s)
            ey, ez = qy - s + k, qz - k
            edge = np.sqrt(qx * qx + ey * ey + ez * ez)
            result = np.where(case, edge, result)
            chosen |= case
        return result


def tetrahedron(radius: float = 1.0, center: Any = (0.0, 0.0, 0.0)) -> SDF:
    """Regular tetrahedron with circumradius ``radius`` (centre-to-vertex distance); exact.

    Its vertices lie in the directions (1, 1, 1), (1, -1, -1), (-1, 1, -1), (-1, -1, 1) from
    ``center``; its edge length is ``radius * sqrt(8 / 3)``.

    Examples
    --------
    >>> from fepre import sdf
    >>> tet = sdf.tetrahedron(3.0)
    >>> round(float(tet([0.0, 0.0, 0.0])), 12)  # inradius = circumradius / 3
    -1.0
    """
    return Tetrahedron(positive_float(radius, "radius"), as_vector(center, 3, "center"))


def octahedron(radius: float = 1.0, center: Any = (0.0, 0.0, 0.0)) -> SDF:
    """Regular octahedron with vertices at distance ``radius`` from ``center`` along the axes; exact.

    Examples
    --------
    >>> from fepre import sdf
    >>> octa = sdf.octahedron(1.0)
    >>> float(octa([2.0, 0.0, 0.0]))
    1.0
    """
    return Octahedron(positive_float(radius, "radius"), as_vector(center, 3, "center"))
