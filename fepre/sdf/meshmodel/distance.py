"""Exact distance to a triangle surface and its sign.

The closest point comes from fepre's bounding-volume hierarchy (:mod:`.bvh`: exact
point-triangle distances in double precision). The sign comes from one of two rules:

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

from .bvh import REGION_FACE, TriangleTree
from .tables import BLOCK, edge_table, face_normals, manifold_pairs

__all__ = ["TriangleDistance", "NEAR_WINDING"]

#: Points closer to the surface than this times its radius (about its centre) take the side of
#: a point that far off it along the same normal: libigl's fast winding number is single
#: precision (float32's 6e-8 relative, times the coordinates).
NEAR_WINDING = 1e-5
#: points this close to the surface, times the largest coordinate, are on it: their gradient is
#: the surface's normal, not the direction to the closest point
ON_SURFACE = 1e-9


class TriangleDistance:
    """Distance queries to the triangles ``faces`` of ``vertices``.

    Parameters
    ----------
    vertices : (V, 3) float64
    faces : (F, 3) int64
    pseudonormal : bool
        Sign by pseudonormals (the surface must be closed, consistently oriented and
        edge-manifold); otherwise by the winding number.
    tree : TriangleTree, optional
        The triangles' hierarchy if one is already built (else built on the first query).
    face_sign : bool
        Without ``pseudonormal``: a point whose closest point lies inside a *clean* triangle
        takes the side of that triangle's normal instead of the winding number's (see
        :meth:`clean_faces`). Only for surfaces that bound their solid (winding number about 0
        outside and 1 inside), not for open sheets.
    """

    def __init__(self, vertices: np.ndarray, faces: np.ndarray, *, pseudonormal: bool, tree: TriangleTree | None = None,
                 face_sign: bool = False) -> None:
        self.vertices = np.ascontiguousarray(vertices, dtype=np.float64)
        self.faces = np.ascontiguousarray(faces, dtype=np.int64)
        self.pseudonormal = bool(pseudonormal)
        self.normals, self.areas = face_normals(self.vertices, self.faces)
        self._centre = 0.5 * (self.vertices.min(axis=0) + self.vertices.max(axis=0)) if len(self.vertices) else np.zeros(3)
        radius = float(np.abs(self.vertices - self._centre).max()) if len(self.vertices) else 0.0
        self._near = NEAR_WINDING * radius
        # what counts as on the surface, relative to the coordinates (taken once: on a surface of
        # millions of vertices the largest coordinate cost more than the query it scaled); the
        # closest point on a long thin facet is that far off in rounding alone (trimesh's
        # plate_holes.STL: 7.4e-10 off a 120-long facet of its top face at coordinates of 300,
        # whose direction made the gradient lie in the face and the size field name a knife edge
        # in the middle of a 12.7 plate)
        self._on_surface = ON_SURFACE * max(float(np.abs(self.vertices).max()) if len(self.vertices) else 0.0, 1e-300)
        self._lock = threading.Lock()
        self._tree = tree
        self._winding = None
        self.face_sign = bool(face_sign) and not self.pseudonormal
        self._clean = None
        if self.pseudonormal:
            self._vertex_normals = _angle_weighted_normals(self.vertices, self.faces, self.normals)
            edges, self._face_edge, _ = edge_table(self.faces)
            edge_normals = np.zeros((len(edges), 3))
            np.add.at(edge_normals, self._face_edge.reshape(-1), np.repeat(self.normals, 3, axis=0))
            self._edge_normals = edge_normals

    def __getstate__(self) -> dict:
        state = self.__dict__.copy()
        state["_tree"] = None
        state["_winding"] = None
        state["_clean"] = None
        del state["_lock"]
        return state

    def __setstate__(self, state: dict) -> None:
        self.__dict__.update(state)
        self._lock = threading.Lock()

    @property
    def tree(self) -> TriangleTree:
        """The bounding-volume hierarchy, built on first use."""
        if self._tree is None:
            with self._lock:
                if self._tree is None:
                    self._tree = TriangleTree(self.vertices, self.faces)
        return self._tree

    @property
    def winding_tree(self):
        """libigl's fast winding number hierarchy of the triangles, built on first use (once,
        not per query batch: rebuilding it costs about 1 us per triangle)."""
        if self._winding is None:
            with self._lock:
                if self._winding is None:
                    import igl

                    winding = igl.FastWindingNumberBVH()
                    winding.init(np.ascontiguousarray(self.vertices - self._centre), self.faces, 2)
                    self._winding = winding
        return self._winding

    @property
    def clean_faces(self) -> np.ndarray:
        """(F,) bool: triangles whose three sides are each shared with exactly one neighbour
        that traverses it the other way, and that cross no other triangle (built on first use).

        Just off the inside of such a triangle the surface is that triangle alone, so the
        winding number steps by one across it and a point whose closest point lies there is on
        the side its normal says. Sides are matched by their ends' positions
        (:func:`welded_faces`): a repair that united overlapping shells numbers each piece's
        vertices apart, and by number 96% of ur3_shoulder.stl's triangles had no neighbour, so
        that nearly every query took a winding number (275 of the 654 s of its mesh at
        h = (D/100, D/25)). Elsewhere (loose pieces, open
        edges, sides shared by more triangles, crossings) the winding number decides. A side
        or corner is not enough: on beast.obj a seam piece touching a clean side without
        sharing its vertices put points 0.004 D off it at a winding number of 0.999 where the
        side's pseudonormal said outside.
        """
        if self._clean is None:
            tree = self.tree  # outside the lock, which the tree's property takes too
            with self._lock:
                if self._clean is None:
                    from .self_crossing import crossing_triangles

                    faces = welded_faces(self.vertices, self.faces)
                    edges, face_edge, forward = edge_table(faces)
                    first, _, agree, counts = manifold_pairs(face_edge, forward, len(edges))
                    good = np.zeros(len(edges), bool)
                    good[np.flatnonzero(counts == 2)[agree]] = True
                    clean = good[face_edge].all(axis=1)
                    clean &= (faces[:, [0, 1, 2]] != faces[:, [1, 2, 0]]).all(axis=1)
                    clean[crossing_triangles(self.vertices, self.faces, tree, both=True)] = False
                    self._clean = clean
        return self._clean

    def winding_numbers(self, points: np.ndarray) -> np.ndarray:
        """Generalised winding numbers of the triangles at ``points`` (N,); libigl computes them
        in single precision, about the surface's centre."""
        points = np.ascontiguousarray(np.asarray(points, dtype=np.float64) - self._centre)
        if len(points) == 0 or len(self.faces) == 0:
            return np.zeros(len(points))
        return np.asarray(self.winding_tree.winding_number(points, 2.0))

    def _winding_inside(self, points: np.ndarray, offset: np.ndarray) -> np.ndarray:
        """Inside by the winding number, taken ``NEAR_WINDING`` surface radii off the surface
        for points closer than that (along ``offset = p - closest``, so on their own side): the
        single-precision winding number is noise there (on libigl's halftunnel.off, points 1e-8
        h inside read 0, and the gradient of 198 of 10k boundary faces' centroids pointed in)."""
        distance = np.linalg.norm(offset, axis=1)
        inside = np.zeros(len(points), bool)
        # on the surface the distance is 0 on either side: no winding number is asked there
        # (the quality stage's boundary nodes, 39% of the queries on ur3_base.stl at 10 us each)
        off = np.flatnonzero(distance > 0)
        points, offset, distance = points[off], offset[off], distance[off]  # copies
        near = distance < self._near
        if near.any():
            points[near] += offset[near] * ((self._near - distance[near]) / distance[near])[:, None]
        inside[off] = self.winding_numbers(points) > 0.5
        return inside

    def _query(self, points: np.ndarray):
        points = np.ascontiguousarray(points, dtype=np.float64)
        squared, face, closest, region = self.tree.query(points)
        return np.sqrt(squared), face, closest, region

    def closest(self, points: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Unsigned distances (N,), closest triangles (N,) and closest points (N, 3)."""
        distance, face, closest, _ = self._query(points)
        return distance, face, closest

    def surface_normals(self, face: np.ndarray, region: np.ndarray) -> np.ndarray:
        """Outward normals at closest points: the pseudonormal of the face, side or corner of
        triangle ``face`` that they lie on (``region``, see :data:`.bvh.REGION_FACE`) with
        ``pseudonormal``, else the face's normal."""
        normal = self.normals[face]
        if not self.pseudonormal:
            return normal
        corner = region < 3
        if corner.any():
            normal[corner] = self._vertex_normals[self.faces[face[corner], region[corner]]]
        side = (region >= 3) & (region < REGION_FACE)
        if side.any():
            normal[side] = self._edge_normals[self._face_edge[face[side], region[side] - 3]]
        return normal

    def _inside(self, points: np.ndarray, offset: np.ndarray, face: np.ndarray, region: np.ndarray,
                normal: np.ndarray | None = None) -> np.ndarray:
        """Which points (with ``offset = p - closest``) are inside, by the rule of this surface."""
        if not self.pseudonormal:
            if not self.face_sign:
                return self._winding_inside(points, offset)
            inside = np.empty(len(points), bool)
            # on the surface itself (offset 0) the normal says nothing: the winding number decides
            by_face = (region == REGION_FACE) & self.clean_faces[face] & (offset != 0).any(axis=1)
            inside[by_face] = np.einsum("ij,ij->i", offset[by_face], self.normals[face[by_face]]) < 0
            rest = ~by_face
            if rest.any():
                inside[rest] = self._winding_inside(points[rest], offset[rest])
            return inside
        if normal is None:
            normal = self.surface_normals(face, region)
        return np.einsum("ij,ij->i", offset, normal) < 0

    def values(self, points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Signed distances (N,) and closest triangles (N,), without the gradients of
        :meth:`signed` (a third less work)."""
        points = np.ascontiguousarray(points, dtype=np.float64)
        distance, face, closest, region = self._query(points)
        inside = self._inside(points, points - closest, face, region)
        return np.where(inside, -distance, distance), face

    def signed(self, points: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """Signed distances (N,), closest triangles, closest points and outward unit directions
        (the gradient: ``(p - c) / |p - c|`` signed, the surface normal on the surface)."""
        points = np.ascontiguousarray(points, dtype=np.float64)
        distance, face, closest, region = self._query(points)
        offset = points - closest
        normal = self.surface_normals(face, region)
        inside = self._inside(points, offset, face, region, normal)
        sign = np.where(inside, -1.0, 1.0)
        on_surface = distance <= self._on_surface
        safe = np.where(on_surface, 1.0, distance)
        direction = np.where(on_surface[:, None], _unit(normal), offset * (sign / safe)[:, None])
        return sign * distance, face, closest, direction


def welded_faces(vertices: np.ndarray, faces: np.ndarray) -> np.ndarray:
    """``faces`` (F, 3) with the vertices at one position numbered as one.

    A repaired surface whose shells were united keeps its pieces apart (their triangles share
    no vertices: ur3_shoulder.stl's 146,522 triangles have 425,794 vertices at 84,365
    positions); sides are shared by position.

    Examples
    --------
    >>> import numpy as np
    >>> vertices = np.array([[0.0, 0, 0], [1, 0, 0], [0, 1, 0], [1, 0, 0], [0, 1, 0], [1, 1, 0]])
    >>> welded_faces(vertices, np.array([[0, 1, 2], [3, 5, 4]])).tolist()
    [[0, 2, 1], [2, 3, 1]]
    """
    if len(vertices) == 0:
        return faces
    # sorted by x, then y, then z: np.unique(axis=0) took 4.6 times as long (2.3 s on those vertices)
    order = np.lexsort(vertices.T[::-1])
    ordered = vertices[order]
    first = np.ones(len(vertices), dtype=bool)
    first[1:] = (ordered[1:] != ordered[:-1]).any(axis=1)
    number = np.empty(len(vertices), dtype=np.int64)
    number[order] = np.cumsum(first) - 1
    return number[faces]


def _unit(vectors: np.ndarray) -> np.ndarray:
    length = np.linalg.norm(vectors, axis=1, keepdims=True)
    return np.divide(vectors, length, out=np.zeros_like(vectors), where=length > 0)


def _angle_weighted_normals(vertices: np.ndarray, faces: np.ndarray, normals: np.ndarray) -> np.ndarray:
    """Vertex normals as the sum of their faces' normals weighted by the face's angle there."""
    result = np.zeros_like(vertices)
    for k in range(3):
        for start in range(0, len(faces), BLOCK):  # in face order still: the same sums
            block, weights = faces[start:start + BLOCK], normals[start:start + BLOCK]
            here = vertices[block[:, k]]
            first = _unit(vertices[block[:, (k + 1) % 3]] - here)
            second = _unit(vertices[block[:, (k + 2) % 3]] - here)
            angle = np.arccos(np.clip(np.einsum("ij,ij->i", first, second), -1.0, 1.0))
            np.add.at(result, block[:, k], weights * angle[:, None])
    return result
