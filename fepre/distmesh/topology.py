"""Faces, boundary and manifold checks of tetrahedral meshes (vectorised)."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

__all__ = ["tet_faces", "boundary_faces", "TopologyReport", "check_topology"]

# faces opposite vertex 0..3, oriented outward for a positively oriented tetrahedron
_FACES = np.array([[1, 2, 3], [0, 3, 2], [0, 1, 3], [0, 2, 1]])


def tet_faces(tets: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Unique faces of ``tets``: (sorted vertex triples (F, 3), use counts (F,), inverse (M*4,))."""
    oriented = tets[:, _FACES].reshape(-1, 3)
    keys = np.sort(oriented, axis=1).astype(np.int64)
    n = int(keys.max()) + 1 if len(keys) else 1
    if n < 2_000_000:  # n^3 fits in int64: one code per face, one sort
        codes = (keys[:, 0] * n + keys[:, 1]) * n + keys[:, 2]
        order = np.argsort(codes, kind="stable")
        sorted_codes = codes[order]
        starts = np.concatenate([[True], sorted_codes[1:] != sorted_codes[:-1]]) if len(codes) else np.zeros(0, bool)
        group = np.cumsum(starts) - 1
        inverse = np.empty(len(codes), np.int64)
        inverse[order] = group
        counts = np.bincount(group) if len(codes) else np.zeros(0, np.int64)
        unique = keys[order[starts]]
        return unique, counts, inverse
    unique, inverse, counts = np.unique(keys, axis=0, return_inverse=True, return_counts=True)
    return unique, counts, inverse.ravel()


def boundary_faces(tets: np.ndarray) -> np.ndarray:
    """Faces used by exactly one tetrahedron, (B, 3), oriented outward.

    Examples
    --------
    >>> boundary_faces(np.array([[0, 1, 2, 3]])).shape
    (4, 3)
    """
    oriented = tets[:, _FACES].reshape(-1, 3)
    _, counts, inverse = tet_faces(tets)
    return oriented[counts[inverse] == 1]


@dataclass(frozen=True)
class TopologyReport:
    """Result of :func:`check_topology`; ``ok`` is True for a valid closed manifold mesh."""

    overused_faces: int
    nonmanifold_edges: int
    pinched_vertices: int
    unused_points: int
    boundary_faces: np.ndarray = field(repr=False)

    @property
    def ok(self) -> bool:
        return not (self.overused_faces or self.nonmanifold_edges or self.pinched_vertices or self.unused_points)


def _boundary_edges(faces: np.ndarray, n_points: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Per face-edge: edge code, face index and position; edges opposite face vertex 2, 0, 1."""
    a, b = faces, np.roll(faces, -1, axis=1)
    lo, hi = np.minimum(a, b).astype(np.int64), np.maximum(a, b).astype(np.int64)
    codes = (lo * n_points + hi).ravel()
    face_index = np.repeat(np.arange(len(faces)), 3)
    return codes, face_index, np.stack([lo.ravel(), hi.ravel()], axis=1)


def nonmanifold_items(faces: np.ndarray, n_points: int) -> tuple[np.ndarray, np.ndarray]:
    """Boundary edges (E, 2) not shared by exactly two faces, and pinched vertices.

    A vertex is pinched when its boundary faces form more than one fan around it.
    """
    if len(faces) == 0:
        return np.zeros((0, 2), np.int64), np.zeros(0, np.int64)
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import connected_components

    codes, face_index, ends = _boundary_edges(faces, n_points)
    order = np.argsort(codes, kind="stable")
    sorted_codes = codes[order]
    unique, start, counts = np.unique(sorted_codes, return_index=True, return_counts=True)
    bad_edges = np.stack([unique[counts != 2] // n_points, unique[counts != 2] % n_points], axis=1)

    # corners (face, vertex) glued across each manifold edge; components per vertex = fans
    pair = start[counts == 2]
    f1, f2 = face_index[order[pair]], face_index[order[pair + 1]]
    e = ends[order[pair]]
    corner_vertex = faces.ravel()
    corner_face = np.repeat(np.arange(len(faces)), 3)
    key = corner_face.astype(np.int64) * n_points + corner_vertex
    key_order = np.argsort(key)
    sorted_keys = key[key_order]

    def corner(face: np.ndarray, vertex: np.ndarray) -> np.ndarray:
        return key_order[np.searchsorted(sorted_keys, face.astype(np.int64) * n_points + vertex)]

    rows = np.concatenate([corner(f1, e[:, 0]), corner(f1, e[:, 1])])
    cols = np.concatenate([corner(f2, e[:, 0]), corner(f2, e[:, 1])])
    n_corners = len(corner_vertex)
    graph = coo_matrix((np.ones(len(rows)), (rows, cols)), shape=(n_corners, n_corners))
    _, labels = connected_components(graph, directed=False)
    label_vertex = np.zeros(labels.max() + 1, np.int64)
    label_vertex[labels] = corner_vertex
    fans = np.bincount(label_vertex, minlength=n_points)
    return bad_edges, np.flatnonzero(fans > 1)


def check_topology(tets: np.ndarray, n_points: int) -> TopologyReport:
    """Check that ``tets`` form a valid solid: each face used by at most two cells, the boundary
    faces a closed 2-manifold (every edge in two faces, no pinched vertex), no unused points.

    Examples
    --------
    >>> check_topology(np.array([[0, 1, 2, 3]]), 4).ok
    True
    """
    _, counts, _ = tet_faces(tets)
    faces = boundary_faces(tets)
    edges, pinched = nonmanifold_items(faces, n_points)
    used = np.zeros(n_points, bool)
    used[tets.ravel()] = True
    return TopologyReport(
        overused_faces=int((counts > 2).sum()),
        nonmanifold_edges=len(edges),
        pinched_vertices=len(pinched),
        unused_points=int((~used).sum()),
        boundary_faces=faces,
    )
