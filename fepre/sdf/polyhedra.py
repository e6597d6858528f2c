"""Regular convex polyhedra (tetrahedron, octahedron) with exact distances.

For a general convex polyhedron (:class:`ConvexPolyhedron`): inside, the distance to the
boundary is the distance to the nearest face plane, ``-max(plane values)``. Outside, it is the
distance to the nearest point of the surface: the smallest of the distances to the edges (as
segments) and, where the foot of the perpendicular lies inside a face, to that face's plane.
The octahedron has a cheaper closed form (:class:`Octahedron`).
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
from scipy.spatial import ConvexHull

from ..arguments import as_vector, positive_float
from .core import SDF

__all__ = ["tetrahedron", "octahedron"]


class ConvexPolyhedron(SDF):
    """Convex hull of ``vertices`` (exact); a handful of faces, so faces are looped over."""

    def __init__(self, vertices: np.ndarray, label: str, parameters: dict[str, Any]) -> None:
        self.vertices = vertices
        self._name = label
        self._shown = parameters
        hull = ConvexHull(vertices)
        self._planes = [tuple(float(v) for v in row) for row in hull.equations]  # n . p + d, outward n
        edges: set[tuple[int, int]] = set()
        self._faces = []
        for simplex, equation in zip(hull.simplices, hull.equations):
            a, b, c = (vertices[i] for i in simplex)
            normal = equation[:3]
            if np.dot(np.cross(b - a, c - a), normal) < 0:
                b, c = c, b
            corners = (a, b, c)
            # Inward edge normals n x e_i: the foot of the perpendicular lies in the face when
            # every (n x e_i) . (p - v_i) >= 0.
            sides = []
            for i in range(3):
                start, end = corners[i], corners[(i + 1) % 3]
                inward = np.cross(normal, end - start)
                sides.append((tuple(float(v) for v in inward), float(np.dot(inward, start))))
            self._faces.append((tuple(float(v) for v in equation), sides))
            for i in range(3):
                j, k = simplex[i], simplex[(i + 1) % 3]
                edges.add((min(j, k), max(j, k)))
        self._edges = [
            (tuple(float(v) for v in vertices[j]), tuple(float(v) for v in vertices[k] - vertices[j]),
             1.0 / float(np.dot(vertices[k] - vertices[j], vertices[k] - vertices[j])))
            for j, k in sorted(edges)
        ]
        super().__init__(bounds=(tuple(vertices.min(axis=0)), tuple(vertices.max(axis=0))), exact=True)

    def _parameters(self) -> dict[str, Any]:
        return dict(self._shown)

    def _label(self) -> str:
        return self._name

    @staticmethod
    def _affine(x, y, z, coefficients, constant):
        a, b, c = coefficients
        return x * a + y * b + (z * c + constant)

    def _values(self, x, y, z):
        inside = None
        for nx, ny, nz, d in self._planes:
            value = self._affine(x, y, z, (nx, ny, nz), d)
            inside = value if inside is None else np.maximum(inside, value)
        squared = None
        for (ax, ay, az), (ex, ey, ez), inverse in self._edges:
            wx, wy, wz = x - ax, y - ay, z - az
            t = np.clip((wx * ex + wy * ey + wz * ez) * inverse, 0.0, 1.0)
            ox, oy, oz = wx - ex * t, wy - ey * t, wz - ez * t
            edge = ox * ox + oy * oy + oz * oz
            squared = edge if squared is None else np.minimum(squared, edge)
        for (nx, ny, nz, d), sides in self._faces:
            height = self._affine(x, y, z, (nx, ny, nz), d)
            within = None
            for inward, offset in sides:
                test = self._affine(x, y, z, inward, -offset) >= 0
                within = test if within is None else within & test
            squared = np.where(within, np.minimum(squared, height * height), squared)
        return np.where(inside > 0, np.sqrt(squared), inside)


class Octahedron(SDF):
    """Regular octahedron ``|x| + |y| + |z| <= radius`` around ``center`` (exact).

    Reflected into the first octant, a point is nearest to the face plane unless its foot falls
    outside the face; then it is nearest to the edge of the face opposite the axis along which
    the point lies farthest beyond the face (the three cases below), clamped to that edge.
    """

    def __init__(self, radius: float, center: np.ndarray) -> None:
        self.radius, self.center = radius, center
        self._c = tuple(float(v) for v in center)
        super().__init__(bounds=(tuple(center - radius), tuple(center + radius)), exact=True)

    def _parameters(self) -> dict[str, Any]:
        return {"radius": self.radius, "center": self.center}

    def _label(self) -> str:
        return "octahedron"

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
    radius = positive_float(radius, "radius")
    center = as_vector(center, 3, "center")
    directions = np.array([[1, 1, 1], [1, -1, -1], [-1, 1, -1], [-1, -1, 1]], dtype=float) / np.sqrt(3.0)
    parameters = {"radius": radius, "center": center}
    return ConvexPolyhedron(center + radius * directions, "tetrahedron", parameters)


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
