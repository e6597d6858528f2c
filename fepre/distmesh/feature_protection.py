"""Keep DistMesh points out of the feature curves' neighbourhoods.

Feature nodes (corners and curve nodes about ``h`` apart) are fixed points. For the straight
piece between two consecutive feature nodes to be an edge of every Delaunay triangulation, the
ball having that piece as diameter must hold no other point (the Gabriel property). Points that
come closer to a feature than ``RATIO`` times the nearest piece's length are pushed straight
away from it to that distance: a point on a face next to an edge moves within the face, a
point on a hole's wall next to its rim moves along the wall. The boundary faces next to a
feature then run along it, and the edge stays sharp.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit, prange

from ..features import Features
from ..features.geometry import nearest_on_segments
from ..kernel_threads import kernel_threads

__all__ = ["FeatureProtection", "RATIO"]

#: Points are kept at least this many times the nearest feature piece's length away from it.
RATIO = 0.55


class FeatureProtection:
    """Pushes points out of the protected neighbourhood of ``features``.

    Parameters
    ----------
    features : fepre.Features
    model : fepre.sdf.SDF
        Gives the push direction of a point lying on a feature itself (into the solid).
    h : float
        Protection radius of corners without curves.
    """

    def __init__(self, features: Features, model, h: float) -> None:
        self.model = model
        self.segments = features.segments
        self.corners = features.corners
        lengths = np.linalg.norm(self.segments[:, 1] - self.segments[:, 0], axis=1)
        self.radius_of_segment = RATIO * lengths
        self.corner_radius = RATIO * h
        self.reach = max(float(self.radius_of_segment.max()) if len(lengths) else 0.0, self.corner_radius)
        # a point is pushed only within its nearest feature's radius: within that radius (plus
        # half the piece) of the piece's midpoint, or of the corner
        self._near = _VoxelFilter(np.concatenate([self.corners, 0.5 * (self.segments[:, 0] + self.segments[:, 1])]),
                                  np.concatenate([np.full(len(self.corners), self.corner_radius),
                                                  self.radius_of_segment + 0.5 * lengths]))

    def radius(self, segment: np.ndarray) -> np.ndarray:
        """Protection radius of each nearest feature (segment index, or -1 for a corner)."""
        if len(self.radius_of_segment) == 0:
            return np.full(segment.shape, self.corner_radius)
        return np.where(segment >= 0, self.radius_of_segment[np.maximum(segment, 0)], self.corner_radius)

    def inside(self, points: np.ndarray) -> np.ndarray:
        """Mask of points within the protected neighbourhood."""
        mask = np.zeros(len(points), dtype=bool)
        near = np.flatnonzero(self._near(points))
        if near.size:
            distance, _, segment = nearest_on_segments(points[near], self.segments, self.corners, with_index=True,
                                                       within=self.reach)
            mask[near] = distance < self.radius(segment)
        return mask

    def push(self, points: np.ndarray, movable: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Move the movable points inside the neighbourhood to its edge, in place.

        Returns the indices of the moved points and how far each moved.
        """
        index = np.flatnonzero(movable)
        index = index[self._near(points[index])]  # most points are far from every feature
        if index.size == 0:
            return index, np.zeros(0)
        distance, foot, segment = nearest_on_segments(
            points[index], self.segments, self.corners, with_index=True, within=self.reach
        )
        radius = self.radius(segment)
        close = distance < radius
        index, distance, foot, radius = index[close], distance[close], foot[close], radius[close]
        if index.size == 0:
            return index, np.zeros(0)
        offset = points[index] - foot
        on_feature = distance < 1e-9 * radius
        if on_feature.any():  # no direction away from the feature: go into the solid
            gradient = self.model.gradient(points[index[on_feature]])
            offset[on_feature] = -gradient
        offset /= np.maximum(np.linalg.norm(offset, axis=1), 1e-300)[:, None]
        target = foot + radius[:, None] * offset
        moved = np.linalg.norm(target - points[index], axis=1)
        points[index] = target
        return index, moved


#: Largest neighbourhood of an anchor in :class:`_VoxelFilter`, in voxels along an axis.
MAX_RINGS = 4
#: Most voxels of :class:`_VoxelFilter`'s dense grid (one byte each); above it, sorted voxel codes.
_DENSE_VOXELS = 1 << 24


@njit(cache=True, parallel=True)
def _in_marked_voxels(points, origin, side, marked, out):  # pragma: no cover - compiled
    nx, ny, nz = marked.shape
    for i in prange(points.shape[0]):
        x = math.floor((points[i, 0] - origin[0]) / side)
        y = math.floor((points[i, 1] - origin[1]) / side)
        z = math.floor((points[i, 2] - origin[2]) / side)
        out[i] = 0 <= x < nx and 0 <= y < ny and 0 <= z < nz and marked[int(x), int(y), int(z)]


class _VoxelFilter:
    """Which points may lie within ``reach`` (one per anchor, or one for all) of some of
    ``anchors``: voxels holding an anchor or within its reach of one, in voxels (a point within
    ``r`` of an anchor is at most ``ceil(r / side)`` voxels from the anchor's along each axis).
    The side is the smallest reach, but at least ``1 / MAX_RINGS`` of the largest. A lookup per
    point instead of a k-d tree query of every point in every iteration; in a graded mesh the
    reach of a long feature piece does not spread over the short ones' neighbourhoods."""

    def __init__(self, anchors: np.ndarray, reach) -> None:
        reach = np.broadcast_to(np.asarray(reach, np.float64), (len(anchors),))
        largest = float(reach.max()) if len(reach) else 0.0
        self.side = max(float(reach.min()), largest / MAX_RINGS) if largest > 0 else 1.0
        self.empty = len(anchors) == 0
        if self.empty:
            return
        rings = np.maximum(np.ceil(reach / self.side - 1e-12).astype(np.int64), 1)
        self.origin = anchors.min(axis=0) - (int(rings.max()) + 1) * self.side
        cells = np.floor((anchors - self.origin) / self.side).astype(np.int64)
        self.shape = cells.max(axis=0) + int(rings.max()) + 2
        marked = []
        for ring in np.unique(rings):  # anchors of each neighbourhood size together
            steps = np.arange(-ring, ring + 1)
            around = np.stack(np.meshgrid(steps, steps, steps, indexing="ij"), axis=-1).reshape(-1, 3)
            marked.append((cells[rings == ring][:, None, :] + around[None]).reshape(-1, 3))
        cells = np.concatenate(marked)
        self.marked = self.codes = None
        if np.prod(self.shape) <= _DENSE_VOXELS:
            self.marked = np.zeros(tuple(self.shape), dtype=np.bool_)
            self.marked[cells[:, 0], cells[:, 1], cells[:, 2]] = True
        else:
            self.codes = np.unique(self._code(cells))

    def _code(self, cells: np.ndarray) -> np.ndarray:
        return (cells[:, 0] * self.shape[1] + cells[:, 1]) * self.shape[2] + cells[:, 2]

    def __call__(self, points: np.ndarray) -> np.ndarray:
        if self.empty or len(points) == 0:
            return np.zeros(len(points), dtype=bool)
        if self.marked is not None:
            mask = np.empty(len(points), dtype=np.bool_)
            with kernel_threads(len(points), 5e-9):
                _in_marked_voxels(np.ascontiguousarray(points, np.float64), self.origin, float(self.side), self.marked, mask)
            return mask
        cells = np.floor((points - self.origin) / self.side)
        inside = np.all((cells >= 0) & (cells < self.shape), axis=1)
        codes = self._code(cells[inside].astype(np.int64))
        position = np.minimum(np.searchsorted(self.codes, codes), len(self.codes) - 1)
        mask = np.zeros(len(points), dtype=bool)
        mask[inside] = self.codes[position] == codes
        return mask
