"""Pairs of triangles that cross each other: an edge of one passes through the other.

Used on a mesh's boundary (a fold of the quality stage, :mod:`fepre.distmesh.validate`) and on
an input surface (a closed triangle mesh whose parts pass through one another,
:mod:`fepre.sdf.meshmodel.repair`). The segment-triangle tests are compiled with numba over the
candidate pairs of k-d trees of the triangles' bounding spheres.
"""

from __future__ import annotations

import numpy as np
from numba import njit, prange

from .kernel_threads import kernel_threads

__all__ = ["crossing_faces", "pairs_cross", "orientation", "segment_crosses_triangle", "FLAT"]

#: orientation tests within this share of the pair's size cubed are zero
FLAT = 1e-10


@njit(cache=True, inline="always")
def orientation(a, b, c, d):  # pragma: no cover - compiled
    """Six times the signed volume of the tetrahedron (a, b, c, d) (compiled)."""
    ax, ay, az = a[0] - d[0], a[1] - d[1], a[2] - d[2]
    bx, by, bz = b[0] - d[0], b[1] - d[1], b[2] - d[2]
    cx, cy, cz = c[0] - d[0], c[1] - d[1], c[2] - d[2]
    return ax * (by * cz - bz * cy) + ay * (bz * cx - bx * cz) + az * (bx * cy - by * cx)


@njit(cache=True, inline="always")
def segment_crosses_triangle(p, q, a, b, c, tol):  # pragma: no cover - compiled
    """Whether the segment pq passes strictly through the triangle abc (orientations within
    ``tol`` of zero are zero) (compiled)."""
    sp, sq = orientation(a, b, c, p), orientation(a, b, c, q)
    if not ((sp > tol and sq < -tol) or (sp < -tol and sq > tol)):
        return False
    t1, t2, t3 = orientation(p, q, a, b), orientation(p, q, b, c), orientation(p, q, c, a)
    return (t1 > tol and t2 > tol and t3 > tol) or (t1 < -tol and t2 < -tol and t3 < -tol)


@njit(cache=True, parallel=True)
def _crossing_pairs(points, faces, first, second, tolerance, out):  # pragma: no cover - compiled
    for k in prange(first.shape[0]):
        f, g = faces[first[k]], faces[second[k]]
        tol = tolerance[k]
        hit = False
        for side in range(2):
            s, t = (f, g) if side == 0 else (g, f)
            a, b, c = points[t[0]], points[t[1]], points[t[2]]
            for e in range(3):
                if segment_crosses_triangle(points[s[e]], points[s[(e + 1) % 3]], a, b, c, tol):
                    hit = True
        out[k] = hit


def pairs_cross(points: np.ndarray, faces: np.ndarray, pairs: np.ndarray) -> np.ndarray:
    """Mask (K,) of the ``pairs`` (K, 2) of ``faces`` (indices; the two faces share no vertex)
    that cross each other, by the test of :func:`crossing_faces` (the same tolerance).

    Examples
    --------
    >>> points = np.array([[0, 0, 0], [2, 0, 0], [0, 2, 0], [0.5, 0.5, -1], [0.5, 0.5, 1], [3, 3, 0]], float)
    >>> pairs_cross(points, np.array([[0, 1, 2], [3, 4, 5]]), np.array([[0, 1]])).tolist()
    [True]
    """
    pairs = np.ascontiguousarray(pairs, np.int64).reshape(-1, 2)
    hit = np.zeros(len(pairs), np.bool_)
    if len(pairs) == 0:
        return hit
    corners = points[faces[pairs]]  # (K, 2, 3, 3)
    radii = np.linalg.norm(corners - corners.mean(axis=2, keepdims=True), axis=3).max(axis=2)
    tolerance = FLAT * radii.sum(axis=1) ** 3
    with kernel_threads(len(pairs), 5e-8):
        _crossing_pairs(np.ascontiguousarray(points, np.float64), np.ascontiguousarray(faces, np.int64),
                        np.ascontiguousarray(pairs[:, 0]), np.ascontiguousarray(pairs[:, 1]), tolerance, hit)
    return hit


def crossing_faces(points: np.ndarray, faces: np.ndarray) -> np.ndarray:
    """(K, 2) pairs of ``faces`` (indices) that share no vertex and cross each other: an edge of
    one passes through the other, strictly (orientations within ``1e-10`` of the pair's size
    cubed are taken for zero, so two faces in one plane never cross: a fold that lays a face
    exactly flat onto another is not found).

    Candidates are pairs whose bounding spheres (about the centroid) overlap, found with a
    k-d tree per class of radii (a factor 2 apart), so graded meshes cost no more than uniform.

    Parameters
    ----------
    points : (N, 3) float array
    faces : (F, 3) int array
        Triangles, e.g. a mesh's boundary faces.

    Returns
    -------
    (K, 2) int array
        Indices into ``faces`` of the crossing pairs, each once.

    Examples
    --------
    >>> points = np.array([[0, 0, 0], [2, 0, 0], [0, 2, 0], [0.5, 0.5, -1], [0.5, 0.5, 1], [3, 3, 0]], float)
    >>> crossing_faces(points, np.array([[0, 1, 2], [3, 4, 5]])).tolist()
    [[0, 1]]
    """
    from scipy.spatial import cKDTree

    if len(faces) < 2:
        return np.zeros((0, 2), np.int64)
    corners = points[faces]
    centres = corners.mean(axis=1)
    radii = np.linalg.norm(corners - centres[:, None], axis=2).max(axis=1)
    grade = np.floor(np.log2(np.maximum(radii, 1e-300) / max(float(radii.min()), 1e-300))).astype(np.int64)
    classes = [np.flatnonzero(grade == g) for g in np.unique(grade)]
    trees = [cKDTree(centres[c]) for c in classes]
    found = []
    for i, (ci, ti) in enumerate(zip(classes, trees)):
        for j in range(i, len(classes)):
            cj, tj = classes[j], trees[j]
            reach = float(radii[ci].max() + radii[cj].max())
            if i == j:
                pairs = ti.query_pairs(reach, output_type="ndarray")
            else:
                pairs = ti.sparse_distance_matrix(tj, reach, output_type="ndarray")
                pairs = np.column_stack([pairs["i"], pairs["j"]]) if len(pairs) else np.zeros((0, 2), np.int64)
            if len(pairs):
                found.append(np.column_stack([ci[pairs[:, 0]], cj[pairs[:, 1]]]))
    if not found:
        return np.zeros((0, 2), np.int64)
    pairs = np.concatenate(found).astype(np.int64)
    near = np.linalg.norm(centres[pairs[:, 0]] - centres[pairs[:, 1]], axis=1) <= radii[pairs[:, 0]] + radii[pairs[:, 1]]
    pairs = pairs[near]
    apart = ~(faces[pairs[:, 0]][:, :, None] == faces[pairs[:, 1]][:, None, :]).any(axis=(1, 2))
    pairs = pairs[apart]
    # orientations within rounding of zero (1e-10 of the pair's size cubed) count as zero:
    # faces in one plane (a flat side's) touch at most, and are not taken for crossing
    return pairs[pairs_cross(points, faces, pairs)]
