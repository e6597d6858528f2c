"""Nearest points on a set of segments and points (the feature curves and corners)."""

from __future__ import annotations

import numpy as np

__all__ = ["nearest_on_segments"]

#: Candidate segments per query point, by distance to their midpoints.
_CANDIDATES = 8


def nearest_on_segments(
    points: np.ndarray, segments: np.ndarray, corners: np.ndarray, *, with_index: bool = False
):
    """Distance (N,) and nearest point (N, 3) of ``points`` to segments (S, 2, 3) or corners (C, 3).

    Segments are candidates by the distance to their midpoints (the nearest few), then measured
    exactly; with segments of similar lengths, the nearest segment is always among them. With
    ``with_index``, also the index of the nearest segment (-1 where a corner is nearer).
    """
    from scipy.spatial import cKDTree

    count = len(points)
    best = np.full(count, np.inf)
    nearest = np.full((count, 3), np.nan)
    index_of = np.full(count, -1, dtype=np.int64)
    if len(corners):
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
    return (best, nearest, index_of) if with_index else (best, nearest)
