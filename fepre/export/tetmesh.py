"""The linear tetrahedral mesh an export starts from: checked arrays of nodes and cells."""

from __future__ import annotations

from typing import Any

import numpy as np

from ..quality import signed_volumes

__all__ = ["tetra_arrays"]

VTK_TETRA = 10


def tetra_arrays(mesh: Any, name: str = "mesh") -> tuple[np.ndarray, np.ndarray]:
    """Return ``(points (N, 3) float64, cells (M, 4) int64)`` of a linear tetrahedral mesh.

    Refuses anything but a ``pv.UnstructuredGrid`` of ``VTK_TETRA`` cells, all of positive volume.

    Examples
    --------
    >>> import pyvista as pv, numpy as np
    >>> grid = pv.UnstructuredGrid({pv.CellType.TETRA: np.array([[0, 1, 2, 3]])},
    ...                            np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1.0]]))
    >>> points, cells = tetra_arrays(grid)
    >>> cells.tolist()
    [[0, 1, 2, 3]]
    """
    import pyvista as pv

    if not isinstance(mesh, pv.UnstructuredGrid):
        raise TypeError(
            f"{name} must be a pyvista.UnstructuredGrid of linear tetrahedra (VTK_TETRA); "
            f"got {type(mesh).__name__}"
        )
    if mesh.n_cells == 0:
        raise ValueError(f"{name} has no cells; a tetrahedral mesh is needed")
    types = np.asarray(mesh.celltypes)
    other = types != VTK_TETRA
    if other.any():
        kinds = sorted({pv.CellType(int(t)).name for t in np.unique(types[other])})
        raise ValueError(
            f"{name} must contain only linear tetrahedra (VTK_TETRA); {int(other.sum())} of "
            f"{types.size} cells are {', '.join(kinds)} (first: cell {int(np.argmax(other))}). "
            f"Use order=2 for quadratic tetrahedra; extract tetrahedra first for mixed meshes"
        )
    cells = np.asarray(mesh.cells_dict[VTK_TETRA], dtype=np.int64)
    points = np.asarray(mesh.points, dtype=np.float64)
    if not np.isfinite(points).all():
        raise ValueError(f"{name} has NaN or infinite point coordinates")
    volumes = signed_volumes(points, cells)
    bad = volumes <= 0
    if bad.any():
        worst = int(np.argmin(volumes))
        raise ValueError(
            f"{name} has {int(bad.sum())} inverted or degenerate tetrahedra (volume <= 0) of "
            f"{cells.shape[0]}; the worst is cell {worst} with volume {volumes[worst]:.6g}. "
            f"Solvers reject such elements; fix the mesh (e.g. fepre.improve) before exporting"
        )
    return points, cells
