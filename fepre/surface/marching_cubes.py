"""fepre's marching cubes: VTK's case table, vectorised over the active cells only.

The table (:mod:`fepre.surface.cube_cases`) is VTK's own, recovered from vtkFlyingEdges3D, and
the tie rule is VTK's (``value >= level`` is outside), so on the same grid this gives exactly
flying edges' vertices (one per crossing grid edge) and triangles.
"""

from __future__ import annotations

import numpy as np

from .case_derivation import EDGE_AXIS, EDGE_START
from .cube_cases import TRIANGLES
from .grid_scan import AXIS_DIRECTIONS
from .table_extraction import CaseTable, extract_with_table

__all__ = ["marching_cubes", "CUBE_TABLE"]

CUBE_TABLE = CaseTable(np.array(AXIS_DIRECTIONS), EDGE_START, EDGE_AXIS, TRIANGLES)


def marching_cubes(
    values: np.ndarray,
    level: float,
    origin: np.ndarray,
    spacing: np.ndarray,
    workers: int | None = None,
    *,
    first_node: np.ndarray | None = None,
    keys: bool = False,
):
    """Points and outward triangles of the ``level`` set of a (nz, ny, nx) array.

    Examples
    --------
    >>> import numpy as np
    >>> t = np.linspace(-1, 1, 9)
    >>> r = np.sqrt(t[None, None, :]**2 + t[None, :, None]**2 + t[:, None, None]**2) - 0.6
    >>> points, triangles = marching_cubes(r, 0.0, np.full(3, -1.0), np.full(3, 0.25))
    >>> triangles.shape[1]
    3
    """
    return extract_with_table(
        values, level, np.asarray(origin, float), np.asarray(spacing, float), CUBE_TABLE, workers,
        first_node=first_node, keys=keys,
    )
