"""Coincident vertices and the triangles they collapse, as grid nodes on the level set make them.

A grid node whose value equals the level is where every crossing on its edges lands: marching
cubes, flying edges, marching tetrahedra and surface nets then give several vertices at the same
place and triangles between them of zero area (2,568 on a flange whose faces lie on grid planes).
A reader of the written file (an STL has no vertex ids) sees one vertex there; :func:`weld`
merges exactly coincident vertices the same way and drops the triangles that collapse, which
leaves the surface closed and manifold where the level set is (two sheets that meet at a node
stay joined there, as in the file). Zero-area triangles whose corners are distinct but
collinear (marching tetrahedra, dual contouring along a crease) are flipped away afterwards
(:mod:`fepre.surface.zero_area`).
"""

from __future__ import annotations

import numpy as np

__all__ = ["weld", "drop_unused"]


def weld(points: np.ndarray, triangles: np.ndarray, tolerance: float = 0.0) -> tuple[np.ndarray, np.ndarray]:
    """Merge coincident ``points`` (within ``tolerance``; exactly equal for 0); drop the
    ``triangles`` that then repeat a vertex.

    Returns the used points (in their first order) and the triangles renumbered. A tolerance of
    a millionth of the grid spacing absorbs float32 rounding of the vertices (VTK's flying edges
    computes them in the grid's precision).

    Examples
    --------
    >>> import numpy as np
    >>> points = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [1, 0, 1e-9]])
    >>> p, t = weld(points, np.array([[0, 1, 2], [1, 3, 2]]), tolerance=1e-6)
    >>> len(p), t.tolist()
    (3, [[0, 1, 2]])
    """
    if len(points) == 0:
        return points, triangles
    if tolerance > 0:
        from scipy.sparse import coo_matrix
        from scipy.sparse.csgraph import connected_components
        from scipy.spatial import cKDTree

        pairs = cKDTree(points).query_pairs(tolerance, output_type="ndarray")
        graph = coo_matrix((np.ones(len(pairs)), (pairs[:, 0], pairs[:, 1])), shape=(len(points), len(points)))
        _, label = connected_components(graph, directed=False)
        first = np.full(label.max() + 1, len(points), dtype=np.int64)
        np.minimum.at(first, label, np.arange(len(points)))
        representative = first[label]
    else:
        # coincident points share any key made from their coordinates: sort by one such key
        # (grid vertices often share an x, rarely this) and compare the ties fully (usually none)
        key = points @ np.array([1.0, 0.7548776662466927, 0.5698402909980532])
        by_x = np.argsort(key, kind="stable")
        x = key[by_x]
        tied = np.zeros(len(points), dtype=bool)
        same = x[1:] == x[:-1]
        tied[1:] |= same
        tied[:-1] |= same
        representative = np.arange(len(points), dtype=np.int64)
        candidates = by_x[tied]
        if candidates.size:
            sub = points[candidates]
            order = candidates[np.lexsort((sub[:, 2], sub[:, 1], sub[:, 0]))]
            ordered = points[order]
            new_run = np.r_[True, np.any(ordered[1:] != ordered[:-1], axis=1)]
            representative[order] = order[np.flatnonzero(new_run)[np.cumsum(new_run) - 1]]
    merged = representative[triangles]
    keep = (merged[:, 0] != merged[:, 1]) & (merged[:, 1] != merged[:, 2]) & (merged[:, 0] != merged[:, 2])
    used, renumbered = drop_unused(len(points), merged[keep])
    return points[used], renumbered


def drop_unused(count: int, triangles: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The vertices (of ``count``) that ``triangles`` use, in order, and the triangles renumbered.

    Examples
    --------
    >>> used, triangles = drop_unused(4, np.array([[0, 2, 3]]))
    >>> used.tolist(), triangles.tolist()
    ([0, 2, 3], [[0, 1, 2]])
    """
    used = np.flatnonzero(np.bincount(triangles.ravel(), minlength=count))  # sorted, O(n)
    index = np.full(count, -1, dtype=np.int64)
    index[used] = np.arange(used.size)
    return used, index[triangles]
