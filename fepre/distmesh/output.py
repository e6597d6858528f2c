"""The DistMesh result as a pyvista.UnstructuredGrid with its point, cell and field data."""

from __future__ import annotations

import numpy as np

from ..quality import tet_quality
from .topology import boundary_faces

__all__ = ["to_grid"]


def to_grid(points: np.ndarray, tets: np.ndarray, model, history: dict[str, np.ndarray]):
    """Build the output grid: VTK_TETRA cells, point data ``sdf`` and ``boundary`` (1 on the
    boundary surface), the quality cell arrays and the ``distmesh_*`` field data."""
    import pyvista as pv

    grid = pv.UnstructuredGrid({pv.CellType.TETRA: np.ascontiguousarray(tets, dtype=np.int64)}, points)
    grid.point_data["sdf"] = model(points)
    boundary = np.zeros(len(points), np.uint8)
    boundary[boundary_faces(tets).ravel()] = 1
    grid.point_data["boundary"] = boundary
    for name, values in tet_quality(points, tets).items():
        grid.cell_data[name] = values
    for name, values in history.items():
        grid.field_data[f"distmesh_{name}"] = np.atleast_1d(np.asarray(values))
    return grid
