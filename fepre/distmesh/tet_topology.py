"""Faces, edges and adjacency of a tetrahedral mesh, computed by sorting integer keys.

Everything here is vectorised: a mesh's faces are the 4 M sorted vertex triples of its
tetrahedra, encoded as one integer each so that one ``argsort`` groups the two copies of every
interior face.
"""

from __future__ import annotations

import numpy as np

__all__ = [
    "FACE_OF_TET",
    "EDGE_OF_TET",
    "face_keys",
    "faces_of_keys",
    "in_sorted",
    "MAX_PACKED_POINTS",
    "edge_keys",
    "face_neighbours",
    "vertex_stars",
    "cells_around",
    "faces_on_boundary",
    "open_boundary_reason",
]

#: Local vertex indices of the face opposite vertex i, ordered so that the face's right-hand
#: normal points out of a positively oriented tetrahedron.
FACE_OF_TET = np.array([[1, 2, 3], [0, 3, 2], [0, 1, 3], [0, 2, 1]])
#: Most points for which a face key packs into one int64 (``n**3 < 2**63``).
MAX_PACKED_POINTS = 2_097_151
#: Local vertex indices of the six edges.
EDGE_OF_TET = np.array([[0, 1], [0, 2], [0, 3], [1, 2], [1, 3], [2, 3]])


def face_keys(triples: np.ndarray, n_points: int) -> np.ndarray:
    """One key per (K, 3) vertex triple, independent of the order of the three vertices.

    An int64 ``(s0 n + s1) n + s2`` of the sorted triple while ``n_points**3`` fits in one
    (up to ``MAX_PACKED_POINTS``); above that, where it would wrap and two faces could share a
    key, a 16-byte void key holding the big-endian pair ``(s0 n + s1, s2)``, which sorts in the
    same order. Both kinds work with ``np.sort``, ``np.unique``, ``np.isin``, ``np.union1d``,
    ``np.setdiff1d``, ``np.searchsorted`` and ``==``; keys made with the same ``n_points``
    are of the same kind.

    Examples
    --------
    >>> import numpy as np
    >>> face_keys(np.array([[2, 0, 1], [1, 2, 0]]), 3).tolist()
    [5, 5]
    >>> big = face_keys(np.array([[3_000_000, 1, 2], [2, 1, 3_000_000]]), 4_000_000)
    >>> big.dtype.itemsize, bool(big[0] == big[1])
    (16, True)
    """
    s = np.sort(triples, axis=1).astype(np.int64)
    n = np.int64(n_points)
    if n_points <= MAX_PACKED_POINTS:
        return (s[:, 0] * n + s[:, 1]) * n + s[:, 2]
    pair = np.empty((s.shape[0], 2), dtype=">i8")
    pair[:, 0] = s[:, 0] * n + s[:, 1]
    pair[:, 1] = s[:, 2]
    return pair.view("V16").ravel()


def faces_of_keys(keys: np.ndarray, n_points: int) -> np.ndarray:
    """The sorted vertex triples (K, 3) of :func:`face_keys` ``keys`` made with ``n_points``.

    Examples
    --------
    >>> import numpy as np
    >>> faces_of_keys(face_keys(np.array([[2, 0, 1], [4, 3, 1]]), 5), 5).tolist()
    [[0, 1, 2], [1, 3, 4]]
    """
    n = np.int64(n_points)
    if keys.dtype.kind == "V":
        pair = keys.view(">i8").reshape(-1, 2).astype(np.int64)
        first, last = pair[:, 0], pair[:, 1]
    else:
        keys = keys.astype(np.int64)
        first, last = keys // n, keys % n
    return np.column_stack([first // n, first % n, last])


def in_sorted(values: np.ndarray, sorted_keys: np.ndarray) -> np.ndarray:
    """Mask of the ``values`` found in ``sorted_keys`` (sorted, as from ``np.unique``).

    ``np.isin`` without sorting the keys again on every call: the quality stage asks about a
    few faces or edges against the whole boundary many times a round.

    Examples
    --------
    >>> import numpy as np
    >>> in_sorted(np.array([[3, 4], [9, 0]]), np.array([0, 3, 7])).tolist()
    [[True, False], [False, True]]
    """
    if sorted_keys.size == 0:
        return np.zeros(np.shape(values), dtype=bool)
    index = np.minimum(np.searchsorted(sorted_keys, values), sorted_keys.size - 1)
    return sorted_keys[index] == values


def edge_keys(pairs: np.ndarray, n_points: int) -> np.ndarray:
    """One int64 per (K, 2) vertex pair, independent of the order of the two vertices."""
    lo = np.minimum(pairs[:, 0], pairs[:, 1]).astype(np.int64)
    hi = np.maximum(pairs[:, 0], pairs[:, 1]).astype(np.int64)
    return lo * np.int64(n_points) + hi


class NonManifoldCells(ValueError):
    """A face is shared by more than two cells (overlapping cells, not a manifold mesh)."""


def face_neighbours(tets: np.ndarray, n_points: int) -> np.ndarray:
    """(M, 4) index of the tetrahedron across the face opposite each vertex, -1 on the boundary.

    Raises
    ------
    NonManifoldCells
        (a ValueError) If a face is shared by more than two tetrahedra (not a manifold mesh).
    """
    from .._cell_kernels import face_uses

    mate, uses = face_uses(tets, n_points)
    if np.any(uses > 2):
        raise NonManifoldCells("tets must form a manifold mesh; a face is shared by more than two tetrahedra")
    return np.where(mate >= 0, mate // 4, -1).reshape(-1, 4)


def vertex_stars(tets: np.ndarray, n_points: int) -> tuple[np.ndarray, np.ndarray]:
    """CSR lists of the tetrahedra around each vertex: ``(offsets (N+1,), tet indices)``, each
    vertex's in increasing order."""
    from .._cell_kernels import cells_by_vertex

    return cells_by_vertex(tets, n_points)


def cells_around(starts: np.ndarray, cells: np.ndarray, vertices: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The cells around each of ``vertices`` in the CSR lists of :func:`vertex_stars`, vertex after
    vertex (a cell around two of them comes twice), and for each the vertex it is around.

    Examples
    --------
    >>> import numpy as np
    >>> starts, cells = vertex_stars(np.array([[0, 1, 2, 3], [1, 2, 3, 4]]), 5)
    >>> [part.tolist() for part in cells_around(starts, cells, np.array([4, 1]))]
    [[1, 0, 1], [4, 1, 1]]
    """
    vertices = np.atleast_1d(np.asarray(vertices, dtype=np.int64))
    counts = starts[vertices + 1] - starts[vertices]
    offsets = np.repeat(starts[vertices] - np.concatenate([[0], np.cumsum(counts)[:-1]]), counts)
    return cells[offsets + np.arange(counts.sum())], np.repeat(vertices, counts)


def faces_on_boundary(tets: np.ndarray, neighbours: np.ndarray) -> np.ndarray:
    """(F, 3) faces without a neighbouring cell (see :func:`face_neighbours`), oriented outwards."""
    cell, local = np.nonzero(neighbours < 0)
    return tets[cell[:, None], FACE_OF_TET[local]]


def open_boundary_reason(faces: np.ndarray, n_points: int) -> str:
    """Why boundary ``faces`` are not a closed, consistently oriented edge-manifold ("" if they are).

    Every boundary edge must be used by exactly two faces, once in each direction.
    """
    if faces.shape[0] == 0:
        return "the mesh has no boundary faces"
    directed = faces[:, [0, 1, 1, 2, 2, 0]].reshape(-1, 2).astype(np.int64)
    n = np.int64(n_points)
    forward = np.sort(directed[:, 0] * n + directed[:, 1])
    backward = directed[:, 1] * n + directed[:, 0]
    if np.any(forward[1:] == forward[:-1]):
        return "a boundary edge is used twice in the same direction (non-manifold or inconsistently oriented)"
    position = np.minimum(np.searchsorted(forward, backward), forward.size - 1)
    if np.any(forward[position] != backward):
        return "a boundary edge is used by one boundary face only (the boundary is open)"
    return ""
