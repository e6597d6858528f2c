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

import numpy as np

from ..features import Features
from ..features.geometry import nearest_on_segments

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

    def radius(self, segment: np.ndarray) -> np.ndarray:
        """Protection radius of each nearest feature (segment index, or -1 for a corner)."""
        if len(self.radius_of_segment) == 0:
            return np.full(segment.shape, self.corner_radius)
        return np.where(segment >= 0, self.radius_of_segment[np.maximum(segment, 0)], self.corner_radius)

    def inside(self, points: np.ndarray) -> np.ndarray:
        """Mask of points within the protected neighbourhood."""
        if len(points) == 0:
            return np.zeros(0, dtype=bool)
        distance, _, segment = nearest_on_segments(points, self.segments, self.corners, with_index=True, within=self.reach)
        return distance < self.radius(segment)

    def push(self, points: np.ndarray, movable: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Move the movable points inside the neighbourhood to its edge, in place.

        Returns the indices of the moved points and how far each moved.
        """
        index = np.flatnonzero(movable)
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
