"""The DistMesh result as a pyvista.UnstructuredGrid with its point, cell and field data."""

from __future__ import annotations

import numpy as np

from ..quality import tet_quality
from .topology import boundary_faces

__all__ = ["to_grid"]


def feature_flags(points: np.ndarray, features) -> np.ndarray:
    """Per point: 2 at a corner of ``features``, 1 on a feature curve, 0 elsewhere (to 1e-9 h)."""
    from scipy.spatial import cKDTree

    from ..features.geometry import nearest_on_segments

    flags = np.zeros(len(points), np.uint8)
    if features is None or not features or len(points) == 0:
        return flags
    tol = 1e-9 * features.h
    distance, _ = nearest_on_segments(points, features.segments, features.corners, within=tol)
    flags[distance <= tol] = 1
    if len(features.corners):
        flags[cKDTree(features.corners).query(points, distance_upper_bound=tol)[0] <= tol] = 2
    return flags


def to_grid(points: np.ndarray, tets: np.ndarray, model, history: dict[str, np.ndarray], features=None,
            boundary: np.ndarray | None = None):
    """Build the output grid: VTK_TETRA cells, point data ``sdf``, ``boundary`` (1 on the
    boundary surface) and ``feature`` (1 on a feature curve, 2 at a corner of ``features``),
    the quality cell arrays and the ``distmesh_*`` field data. ``boundary``: the cells' boundary
    faces when already found (else found here)."""
    import pyvista as pv

    grid = pv.UnstructuredGrid({pv.CellType.TETRA: np.ascontiguousarray(tets, dtype=np.int64)}, points)
    grid.point_data["sdf"] = model(points)
    faces, boundary = boundary, np.zeros(len(points), np.uint8)
    boundary[(boundary_faces(tets) if faces is None else faces).ravel()] = 1
    grid.point_data["boundary"] = boundary
    grid.point_data["feature"] = feature_flags(points, features)
    for name, values in tet_quality(points, tets).items():
        grid.cell_data[name] = values
    for name, values in history.items():
        grid.field_data[f"distmesh_{name}"] = np.atleast_1d(np.asarray(values))
    return grid
