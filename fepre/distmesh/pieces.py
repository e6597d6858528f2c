"""Pieces of a mesh: cells joined through shared faces.

A part thinner than ``h`` somewhere along a limb can leave the limb's tip as a piece of its own
(cow.obj's ear tips at D/50: pieces of 1 to 55 cells beside 27,000). A solver sees such a piece
as a body with nothing holding it (a singular stiffness matrix), so the mesher names them.
"""

from __future__ import annotations

import numpy as np

__all__ = ["mesh_pieces", "small_pieces_message", "SMALL_PIECE"]

#: Pieces with fewer than this fraction of the cells (beside a larger one) are named.
SMALL_PIECE = 0.01


def mesh_pieces(tets: np.ndarray, n_points: int) -> tuple[np.ndarray, np.ndarray]:
    """Label (M,) of each cell's piece and the (K,) cell counts of the pieces, largest first.

    Examples
    --------
    >>> labels, counts = mesh_pieces(np.array([[0, 1, 2, 3], [1, 2, 3, 4], [5, 6, 7, 8]]), 9)
    >>> labels.tolist(), counts.tolist()
    ([0, 0, 1], [2, 1])
    """
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import connected_components

    from .tet_topology import face_neighbours

    tets = np.asarray(tets, dtype=np.int64)
    if len(tets) == 0:
        return np.zeros(0, np.int64), np.zeros(0, np.int64)
    mate = face_neighbours(tets, n_points)
    cell = np.repeat(np.arange(len(tets)), 4)
    other = mate.reshape(-1)
    inner = other >= 0
    graph = coo_matrix((np.ones(int(inner.sum()), np.int8), (cell[inner], other[inner])), shape=(len(tets), len(tets)))
    count, labels = connected_components(graph, directed=False)
    sizes = np.bincount(labels, minlength=count)
    order = np.argsort(-sizes, kind="stable")
    rank = np.empty(count, np.int64)
    rank[order] = np.arange(count)
    return rank[labels], sizes[order]


def small_pieces_message(points: np.ndarray, tets: np.ndarray, labels: np.ndarray, counts: np.ndarray,
                         offset: np.ndarray | None = None) -> str | None:
    """A line naming the pieces with fewer than ``SMALL_PIECE`` of the cells, or None."""
    if len(counts) < 2:
        return None
    small = np.flatnonzero(counts < SMALL_PIECE * counts.sum())
    if len(small) == 0:
        return None
    shift = np.zeros(3) if offset is None else np.asarray(offset, np.float64)
    places = []
    for piece in small[:3]:
        centre = points[tets[labels == piece]].reshape(-1, 3).mean(axis=0) + shift
        places.append(f"{counts[piece]} cell(s) at ({', '.join(f'{v:.6g}' for v in centre)})")
    more = f" and {len(small) - 3} more" if len(small) > 3 else ""
    return (f"the mesh is in {len(counts)} pieces not joined through faces: beside the largest ({counts[0]:,} cells), "
            f"{len(small)} small one(s): {'; '.join(places)}{more}; where a part of the model thinner than the mesh's "
            "sizes cut them off, a smaller h (or hmin) keeps them joined; a solver needs every piece held")
