"""Nearest points on a set of segments and points (the feature curves and corners)."""

from __future__ import annotations

import numpy as np

__all__ = ["nearest_on_segments"]

#: Candidate segments per query point, by distance to their midpoints.
_CANDIDATES = 8


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
        candidates = candidates.reshape(count, k)
        sa, sb = a[candidates], b[candidates]  # (N, k, 3)
        edge = sb - sa
        t = np.einsum("nkd,nkd->nk", points[:, None, :] - sa, edge) / np.maximum(np.einsum("nkd,nkd->nk", edge, edge), 1e-300)
        foot = sa + np.clip(t, 0.0, 1.0)[:, :, None] * edge
        distance = np.linalg.norm(points[:, None, :] - foot, axis=2)
        pick = np.argmin(distance, axis=1)
        closest = distance[np.arange(count), pick]
        closer = closest < best
        best = np.where(closer, closest, best)
        nearest[closer] = foot[np.arange(count), pick][closer]
        index_of[closer] = candidates[np.arange(count), pick][closer]
    best_all[near], nearest_all[near], index_all[near] = best, nearest, index_of
    return (best_all, nearest_all, index_all) if with_index else (best_all, nearest_all)
