"""Exact distance to a triangle surface and its sign.

The closest point comes from libigl's axis-aligned bounding-box tree (exact point-triangle
distances in double precision). The sign comes from one of two rules:

* **pseudonormals** (Baerentzen and Aanaes 2005): the sign of ``(p - c) . n`` where ``n`` is the
  normal of the face, the edge (sum of its two faces' normals) or the vertex (angle-weighted sum
  of its faces' normals) that the closest point ``c`` lies on. Exact and cheap, but only on a
  closed, consistently oriented, edge-manifold surface;
* **the generalised winding number** (Jacobson et al. 2013): inside where it exceeds 1/2. Right
  on any surface that encloses its solid except for small holes, overlaps and stray triangles.
"""

from __future__ import annotations

import threading

import numpy as np

from .repair import edge_table, face_normals, winding_numbers

__all__ = ["TriangleDistance"]

#: Barycentric coordinates below this count as zero when placing the closest point on an edge
#: or a vertex of its triangle.
_ON_FEATURE = 1e-9


class TriangleDistance:
    """Distance queries to the triangles ``faces`` of ``vertices``.

    Parameters
    ----------
    vertices : (V, 3) float64
    faces : (F, 3) int64
    pseudonormal : bool
        Sign by pseudonormals (the surface must be closed, consistently oriented and
        edge-manifold); otherwise by the winding number.
    """

    def __init__(self, vertices: np.ndarray, faces: np.ndarray, *, pseudonormal: bool) -> None:
        self.vertices = np.ascontiguousarray(vertices, dtype=np.float64)
        self.faces = np.ascontiguousarray(faces, dtype=np.int64)
        self.pseudonormal = bool(pseudonormal)
        self.normals, self.areas = face_normals(self.vertices, self.faces)
        self._lock = threading.Lock()
        self._tree = None
        if self.pseudonormal:
            self._vertex_normals = _angle_weighted_normals(self.vertices, self.faces, self.normals)
            edges, self._face_edge, _ = edge_table(self.faces)
            edge_normals = np.zeros((len(edges), 3))
            np.add.at(edge_normals, self._face_edge.reshape(-1), np.repeat(self.normals, 3, axis=0))
            self._edge_normals = edge_normals

    def __getstate__(self) -> dict:
        state = self.__dict__.copy()
        state["_tree"] = None
        del state["_lock"]
        return state

    def __setstate__(self, state: dict) -> None:
        self.__dict__.update(state)
        self._lock = threading.Lock()

    @property
    def tree(self):
        """The libigl AABB tree, built on first use."""
        if self._tree is None:
            with self._lock:
                if self._tree is None:
                    import igl

                    tree = igl.AABB()
                    tree.init(self.vertices, self.faces)
                    self._tree = tree
        return self._tree

    def closest(self, points: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Unsigned distances (N,), closest triangles (N,) and closest points (N, 3)."""
        points = np.ascontiguousarray(points, dtype=np.float64)
        if len(points) == 0:
            return np.zeros(0), np.zeros(0, np.int64), np.zeros((0, 3))
        squared, face, closest = self.tree.squared_distance(self.vertices, self.faces, points)
        return np.sqrt(squared), np.asarray(face, dtype=np.int64), np.asarray(closest)

    def surface_normals(self, face: np.ndarray, closest: np.ndarray) -> np.ndarray:
        """Outward normals at closest points: the pseudonormal of the face, edge or vertex they
        lie on (with ``pseudonormal``), else the face's normal."""
        if not self.pseudonormal:
            return self.normals[face]
        corners = self.vertices[self.faces[face]]
        weights = _barycentric(corners, closest)
        zero = weights < _ON_FEATURE
        normal = self.normals[face].copy()
        on_edge = zero.sum(axis=1) == 1
        if on_edge.any():
            # the side opposite the vertex whose weight vanishes: side k joins corners k, k+1
            opposite = np.argmax(zero[on_edge], axis=1)
            side = (opposite + 1) % 3
            normal[on_edge] = self._edge_normals[self._face_edge[face[on_edge], side]]
        on_vertex = zero.sum(axis=1) >= 2
        if on_vertex.any():
            corner = np.argmax(weights[on_vertex], axis=1)
            normal[on_vertex] = self._vertex_normals[self.faces[face[on_vertex], corner]]
        return normal

    def signed(self, points: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """Signed distances (N,), closest triangles, closest points and outward unit directions
        (the gradient: ``(p - c) / |p - c|`` signed, the surface normal on the surface)."""
        distance, face, closest = self.closest(points)
        offset = points - closest
        normal = self.surface_normals(face, closest)
        if self.pseudonormal:
            inside = np.einsum("ij,ij->i", offset, normal) < 0
        else:
            inside = winding_numbers(self.vertices, self.faces, points) > 0.5
        sign = np.where(inside, -1.0, 1.0)
        scale = max(float(np.abs(self.vertices).max()), 1e-300)
        on_surface = distance <= 1e-12 * scale
        safe = np.where(on_surface, 1.0, distance)
        direction = np.where(on_surface[:, None], _unit(normal), offset * (sign / safe)[:, None])
        return sign * distance, face, closest, direction


def _unit(vectors: np.ndarray) -> np.ndarray:
    length = np.linalg.norm(vectors, axis=1, keepdims=True)
    return np.divide(vectors, length, out=np.zeros_like(vectors), where=length > 0)


def _barycentric(corners: np.ndarray, points: np.ndarray) -> np.ndarray:
    """Barycentric weights (N, 3) of points in the plane of triangles (N, 3, 3)."""
    a, b, c = corners[:, 0], corners[:, 1], corners[:, 2]
    v0, v1, v2 = b - a, c - a, points - a
    d00 = np.einsum("ij,ij->i", v0, v0)
    d01 = np.einsum("ij,ij->i", v0, v1)
    d11 = np.einsum("ij,ij->i", v1, v1)
    d20 = np.einsum("ij,ij->i", v2, v0)
    d21 = np.einsum("ij,ij->i", v2, v1)
    denominator = d00 * d11 - d01 * d01
    denominator = np.where(denominator > 0, denominator, 1.0)
    v = (d11 * d20 - d01 * d21) / denominator
    w = (d00 * d21 - d01 * d20) / denominator
    return np.stack([1.0 - v - w, v, w], axis=1)


def _angle_weighted_normals(vertices: np.ndarray, faces: np.ndarray, normals: np.ndarray) -> np.ndarray:
    """Vertex normals as the sum of their faces' normals weighted by the face's angle there."""
    result = np.zeros_like(vertices)
    for k in range(3):
        here = vertices[faces[:, k]]
        first = _unit(vertices[faces[:, (k + 1) % 3]] - here)
        second = _unit(vertices[faces[:, (k + 2) % 3]] - here)
        angle = np.arccos(np.clip(np.einsum("ij,ij->i", first, second), -1.0, 1.0))
        np.add.at(result, faces[:, k], normals * angle[:, None])
    return result
