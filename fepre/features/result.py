"""The :class:`Features` of a model: corners and feature curves, to look at and to mesh with."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np

from .curves import FeatureCurve

__all__ = ["Features"]


@dataclass(frozen=True)
class Features:
    """Sharp corners and feature curves of a model, sampled for a mesh of edge length ``h``.

    Attributes
    ----------
    corners : (C, 3) float array
        Points where three or more patches meet (and singular points such as a cone's apex).
    curves : tuple of FeatureCurve
        Curves where two patches meet at more than ``angle`` degrees, with nodes about ``h`` apart.
    h : float
        Edge length the curves are sampled for.
    angle : float
        Crease threshold in degrees: patches meeting at a smaller angle between their normals
        are one smooth surface.
    spacing : float
        Spacing of the fine grid the features were found on.
    skipped : tuple of str
        What was found but not kept (features closer together than ``h/2``), in words.
    creases : fepre.features.detect.Creases or None
        The crease search they were built from; :func:`fepre.features` takes it (``creases=``)
        instead of searching again when the model, grid and angle are the same.

    Examples
    --------
    >>> import fepre
    >>> from fepre import sdf
    >>> found = fepre.features(sdf.box(1.0), h=0.25)
    >>> len(found.corners), len(found.curves)
    (8, 12)
    """

    corners: np.ndarray
    curves: tuple[FeatureCurve, ...]
    h: float
    angle: float
    spacing: float
    skipped: tuple[str, ...] = field(default=())
    creases: Any = field(default=None, repr=False, compare=False)

    def __bool__(self) -> bool:
        return len(self.corners) > 0 or len(self.curves) > 0

    @property
    def nodes(self) -> np.ndarray:
        """Every feature node once: the corners, then the curves' nodes that are not corners, (N, 3)."""
        curve_points = [c.points for c in self.curves]
        if not curve_points:
            return self.corners.copy()
        points = np.concatenate([self.corners] + curve_points)
        # the same point reached along two curves can differ: where a hole's rim touches a
        # slot's edge tangentially, Newton's method finds it only to ~1e-9 h. Nodes within 1e-6 h
        # are one node to any mesh (as two, they made cells of zero quality)
        from scipy.spatial import cKDTree

        pairs = cKDTree(points).query_pairs(1e-6 * max(self.h, 1e-300), output_type="ndarray")
        keep = np.ones(len(points), dtype=bool)
        keep[pairs.max(axis=1)] = False
        return points[keep]

    @property
    def segments(self) -> np.ndarray:
        """End points (S, 2, 3) of the straight pieces between consecutive curve nodes."""
        pieces = [c.points[c.segments] for c in self.curves if len(c.points) > 1]
        return np.concatenate(pieces) if pieces else np.zeros((0, 2, 3))

    def distance(self, points) -> tuple[np.ndarray, np.ndarray]:
        """Distance (N,) from each point to the nearest feature (segment or corner) and that
        nearest feature point (N, 3). Infinite when there are no features.

        Examples
        --------
        >>> import fepre
        >>> from fepre import sdf
        >>> found = fepre.features(sdf.box(2.0), h=0.5)
        >>> distance, nearest = found.distance([[1.2, 1.2, 0.1]])
        >>> round(float(distance[0]), 6), np.round(nearest[0], 6).tolist()
        (0.282843, [1.0, 1.0, 0.1])
        """
        from ..arguments import as_points
        from .geometry import nearest_on_segments

        array, _ = as_points(points, 3)
        return nearest_on_segments(array, self.segments, self.corners)

    def to_polydata(self):
        """The features as a :class:`pyvista.PolyData`: curves as lines, corners as vertices.

        Point data ``"corner"`` (1 at corners); cell data ``"curve"`` (curve index, -1 for a
        corner vertex) and ``"angle"`` (the curve's crease angle).
        """
        import pyvista as pv

        blocks = [self.corners] + [c.points for c in self.curves]
        points = np.concatenate(blocks) if blocks else np.zeros((0, 3))
        if len(points) == 0:
            return pv.PolyData()
        offsets = np.cumsum([0] + [len(b) for b in blocks])
        lines, curve_ids, angles = [], [], []
        for index, curve in enumerate(self.curves):
            ids = offsets[index + 1] + np.arange(len(curve.points))
            if curve.closed and len(ids) > 2:
                ids = np.append(ids, ids[0])
            lines.append(np.concatenate([[len(ids)], ids]))
            curve_ids.append(index)
            angles.append(curve.angle)
        mesh = pv.PolyData()
        mesh.points = points
        if len(self.corners):
            mesh.verts = np.column_stack([np.ones(len(self.corners), np.int64), np.arange(len(self.corners))]).ravel()
        if lines:
            mesh.lines = np.concatenate(lines)
        n_verts = len(self.corners)
        mesh.cell_data["curve"] = np.concatenate([np.full(n_verts, -1), np.asarray(curve_ids, dtype=np.int64)])
        mesh.cell_data["angle"] = np.concatenate([np.full(n_verts, np.nan), np.asarray(angles, dtype=float)])
        corner = np.zeros(len(points), dtype=np.int8)
        corner[: len(self.corners)] = 1
        mesh.point_data["corner"] = corner
        return mesh

    def __str__(self) -> str:
        lines = [
            f"Features (h={self.h:g}, crease angle > {self.angle:g} deg, found on a grid of spacing {self.spacing:.4g})",
            f"  corners          {len(self.corners)}",
            f"  curves           {len(self.curves)} ({sum(c.closed for c in self.curves)} closed)",
            f"  curve nodes      {sum(len(c.points) for c in self.curves)}",
            f"  total length     {sum(c.length for c in self.curves):.4g}",
        ]
        if self.curves:
            angles = [c.angle for c in self.curves]
            lines.append(f"  crease angles    {min(angles):.1f} .. {max(angles):.1f} deg")
        for message in self.skipped:
            lines.append(f"  skipped: {message}")
        return "\n".join(lines)
