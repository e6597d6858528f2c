"""Nearest points on a set of segments and points (the feature curves and corners)."""

from __future__ import annotations

import math

import numpy as np
from numba import njit

__all__ = ["nearest_on_segments"]

#: Candidate segments per query point, by distance to their midpoints.
_CANDIDATES = 8


@njit(cache=True)
def _nearest_candidates(points, a, b, candidates):  # pragma: no cover - compiled
    """Per point, the nearest of its candidate segments: distance, foot, segment index (the
    first of equal distances). The arithmetic is the array form's, term by term, so results
    are the same bit for bit: numpy's ``einsum`` over three terms adds the first and third
    before the second, and numba does not contract ``a + t e`` into a fused multiply-add."""
    n, k = candidates.shape
    best = np.empty(n)
    foot = np.empty((n, 3))
    index = np.empty(n, np.int64)
    here = np.empty(3)
    for i in range(n):
        best[i] = np.inf
        index[i] = candidates[i, 0]
        for c in range(k):
            s = candidates[i, c]
            e0, e1, e2 = b[s, 0] - a[s, 0], b[s, 1] - a[s, 1], b[s, 2] - a[s, 2]
            d0, d1, d2 = points[i, 0] - a[s, 0], points[i, 1] - a[s, 1], points[i, 2] - a[s, 2]
            t = ((d0 * e0 + d2 * e2) + d1 * e1) / max((e0 * e0 + e2 * e2) + e1 * e1, 1e-300)
            t = min(max(t, 0.0), 1.0)
            here[0], here[1], here[2] = a[s, 0] + t * e0, a[s, 1] + t * e1, a[s, 2] + t * e2
            r0, r1, r2 = points[i, 0] - here[0], points[i, 1] - here[1], points[i, 2] - here[2]
            distance = math.sqrt(r0 * r0 + r1 * r1 + r2 * r2)
            if distance < best[i]:
                best[i] = distance
                index[i] = s
                foot[i, 0], foot[i, 1], foot[i, 2] = here[0], here[1], here[2]
    return best, foot, index


def nearest_on_segments(
    points: np.ndarray,
    segments: np.ndarray,
    corners: np.ndarray,
    *,
    with_index: bool = False,
    within: float = np.inf,
):
    """Distance (N,) and nearest point (N, 3) of ``points`` to segments (S, 2, 3) or corners (C, 3).

    Segments are candidates by the distance to their midpoints (the nearest few), then measured
    exactly; with segments of similar lengths, the nearest segment is always among them. With
    ``with_index``, also the index of the nearest segment (-1 where a corner is nearer). Points
    farther than ``within`` from every feature may be reported at distance infinity (they are
    skipped early: most mesh points are far from every feature).
    """
    from scipy.spatial import cKDTree

    total = len(points)
    best_all = np.full(total, np.inf)
    nearest_all = np.full((total, 3), np.nan)
    index_all = np.full(total, -1, dtype=np.int64)
    near = np.arange(total)
    if np.isfinite(within) and total:
        half = 0.5 * float(np.linalg.norm(segments[:, 1] - segments[:, 0], axis=1).max()) if len(segments) else 0.0
        anchors = np.concatenate([corners, 0.5 * (segments[:, 0] + segments[:, 1])]) if len(segments) else corners
        if len(anchors) == 0:
            return (best_all, nearest_all, index_all) if with_index else (best_all, nearest_all)
        distance, _ = cKDTree(anchors).query(points, distance_upper_bound=within + half)
        near = np.flatnonzero(np.isfinite(distance))
    points = points[near]
    count = len(points)
    best = np.full(count, np.inf)
    nearest = np.full((count, 3), np.nan)
    index_of = np.full(count, -1, dtype=np.int64)
    if len(corners) and count:
        distance, index = cKDTree(corners).query(points)
        best, nearest = distance, corners[index]
    if len(segments) and count:
        a, b = segments[:, 0], segments[:, 1]
        k = min(_CANDIDATES, len(segments))
        _, candidates = cKDTree(0.5 * (a + b)).query(points, k=k)
        candidates = np.ascontiguousarray(candidates.reshape(count, k), dtype=np.int64)
        closest, foot, pick = _nearest_candidates(np.ascontiguousarray(points, np.float64),
                                                  np.ascontiguousarray(a, np.float64),
                                                  np.ascontiguousarray(b, np.float64), candidates)
        closer = closest < best
        best = np.where(closer, closest, best)
        nearest[closer] = foot[closer]
        index_of[closer] = pick[closer]
    best_all[near], nearest_all[near], index_all[near] = best, nearest, index_of
    return (best_all, nearest_all, index_all) if with_index else (best_all, nearest_all)
