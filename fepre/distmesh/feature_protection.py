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
        self._near = _VoxelFilter(np.concatenate([self.corners, 0.5 * (self.segments[:, 0] + self.segments[:, 1])]),
                                  self.reach + (0.5 * float(lengths.max()) if len(lengths) else 0.0))

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
    """Which points may lie within ``reach`` of some of ``anchors``: voxels of side ``reach``
    holding an anchor or next to one (a point within ``reach`` of an anchor is in such a voxel).
    A lookup per point instead of a k-d tree query of every point in every iteration."""

    def __init__(self, anchors: np.ndarray, reach: float) -> None:
        self.side = reach if reach > 0 else 1.0
        self.empty = len(anchors) == 0
        if self.empty:
            return
        self.origin = anchors.min(axis=0) - 2.0 * self.side
        cells = np.floor((anchors - self.origin) / self.side).astype(np.int64)
        self.shape = cells.max(axis=0) + 3
        around = np.stack(np.meshgrid(*[np.arange(-1, 2)] * 3, indexing="ij"), axis=-1).reshape(-1, 3)
        cells = (cells[:, None, :] + around[None]).reshape(-1, 3)
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
