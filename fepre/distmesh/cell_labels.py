"""Cell labels (a region mesh's regions) carried through a local refinement of the cells."""

from __future__ import annotations

import numpy as np

__all__ = ["refined_labels"]

#: Removed cells tried for each new cell (the cells nearest its centroid).
CANDIDATES = 12


def _row_view(tets: np.ndarray) -> np.ndarray:
    return np.ascontiguousarray(tets, dtype=np.int64).view(np.dtype((np.void, 32))).ravel()


def refined_labels(points: np.ndarray, before: np.ndarray, labels: np.ndarray, after: np.ndarray) -> np.ndarray:
    """The labels of ``after``'s cells, where ``after`` is ``before`` with some cells replaced by
    cells inside them (edge splits, cavity re-coning: new vertices appended to ``points``).

    A cell of ``before`` keeps its label; a new cell takes the label of the removed cell that
    holds its centroid (the one whose smallest barycentric coordinate of it is largest, among
    the ``CANDIDATES`` removed cells with the nearest centroids). Splits that never cross a face
    between two labels (``locked`` in :func:`~fepre.distmesh.surface_refine.split_edges`) make
    each new cell part of one removed cell, or of a cavity of one label.

    Parameters
    ----------
    points : (N, 3) float array, the vertices of ``after`` (those of ``before`` first)
    before : (M, 4) int array
    labels : (M,) int array, the labels of ``before``'s cells
    after : (K, 4) int array

    Returns
    -------
    (K,) int array

    Examples
    --------
    A cell split in two at the midpoint of an edge keeps its label in both halves:

    >>> import numpy as np
    >>> points = np.array([[0.0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1], [0, 0, -1], [0.5, 0, 0]])
    >>> before = np.array([[0, 1, 2, 3], [0, 2, 1, 4]])
    >>> after = np.array([[0, 2, 1, 4], [0, 5, 2, 3], [5, 1, 2, 3]])
    >>> refined_labels(points, before, np.array([7, 3]), after).tolist()
    [3, 7, 7]
    """
    from scipy.spatial import cKDTree

    labels = np.asarray(labels)
    old, new = _row_view(before), _row_view(after)
    order = np.argsort(old, kind="stable")
    position = np.minimum(np.searchsorted(old[order], new), len(old) - 1)
    kept = old[order][position] == new
    result = np.empty(len(after), dtype=labels.dtype)
    result[kept] = labels[order[position[kept]]]
    if kept.all():
        return result
    removed = np.flatnonzero(~np.isin(old, new))
    centroids = points[after[~kept]].mean(axis=1)
    k = min(CANDIDATES, removed.size)
    _, nearest = cKDTree(points[before[removed]].mean(axis=1)).query(centroids, k=k)
    candidates = removed[np.asarray(nearest).reshape(len(centroids), k)]
    inside = _smallest_barycentric(points[before[candidates]], centroids)
    result[~kept] = labels[candidates[np.arange(len(centroids)), np.argmax(inside, axis=1)]]
    return result


def _smallest_barycentric(corners: np.ndarray, x: np.ndarray) -> np.ndarray:
    """The smallest barycentric coordinate of each ``x`` (P, 3) in each of its cells ``corners``
    (P, C, 4, 3): positive inside, (P, C)."""
    edges = corners[:, :, 1:] - corners[:, :, :1]  # (P, C, 3, 3)
    matrix = np.swapaxes(edges, -1, -2)
    offset = x[:, None, :] - corners[:, :, 0]
    determinant = np.linalg.det(matrix)
    usable = np.abs(determinant) > 1e-300
    safe = np.where(usable[..., None, None], matrix, np.eye(3))
    tail = np.linalg.solve(safe, offset[..., None])[..., 0]
    coordinates = np.concatenate([1.0 - tail.sum(axis=-1, keepdims=True), tail], axis=-1)
    return np.where(usable, coordinates.min(axis=-1), -np.inf)
