"""Node pairs of a periodic mesh: every node on an upper face of the cell and its partner.

A node on the upper face normal to x (or to several axes, on edges and corners) has a *master*:
the node at the same place with each upper coordinate replaced by the lower one, that is its
position minus ``shift @ period`` with ``shift`` in ``{0, 1}^3``. Constraints written against
masters (not against chains of partners) never make one node depend twice.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..errors import MeshingError
from .cell import AXES, PeriodicCell

__all__ = ["PeriodicNodes", "periodic_nodes", "match_faces"]


@dataclass(frozen=True)
class PeriodicNodes:
    """The periodic node pairs of a mesh of one cell.

    Attributes
    ----------
    cell : PeriodicCell
    slaves : (M,) int64
        Nodes on an upper face (x, y or z = the cell's upper bound).
    masters : (M,) int64
        Their partners on the lower faces: ``points[slaves] - shifts @ period == points[masters]``.
    shifts : (M, 3) int8
        Which periods separate each pair (1 where the slave is on the upper face of that axis).
    points : (N, 3) float64
        The mesh's nodes.
    """

    cell: PeriodicCell
    slaves: np.ndarray
    masters: np.ndarray
    shifts: np.ndarray
    points: np.ndarray
    unpaired: np.ndarray

    def __len__(self) -> int:
        return int(self.slaves.size)

    def pairs(self, axis: int | str) -> np.ndarray:
        """(K, 2) node pairs ``(lower face, upper face)`` across the faces normal to ``axis``
        (0, 1, 2 or "x", "y", "z"): the upper node is the lower one moved by one period along
        ``axis`` only (edge and corner nodes appear in the pairs of each of their axes)."""
        axis = AXES.index(axis) if isinstance(axis, str) else int(axis)
        if axis not in (0, 1, 2):
            raise ValueError(f"axis must be 0, 1, 2 or 'x', 'y', 'z'; got {axis!r}")
        from scipy.spatial import cKDTree

        upper = self.slaves[self.shifts[:, axis] == 1]
        if upper.size == 0:
            return np.zeros((0, 2), np.int64)
        partner = self.points[upper].copy()
        partner[:, axis] -= self.cell.period[axis]
        _, lower = cKDTree(self.points).query(partner)
        return np.column_stack([lower.astype(np.int64), upper])


def match_faces(points: np.ndarray, cell: PeriodicCell, tol: float, model=None, h: float = 0.0):
    """``(slaves, masters, shifts, unpaired)`` of the nodes on the cell's faces.

    ``unpaired`` are face nodes with no partner one period away. With a ``model``, they must lie
    on its zero set (within ``1e-3 h``: rim nodes whose cells the final mesh kept on one face
    only), else MeshingError names one (a fepre bug).
    """
    from scipy.spatial import cKDTree

    points = np.asarray(points, dtype=np.float64)
    low = np.abs(points - cell.lower) <= tol
    high = np.abs(points - cell.upper) <= tol
    candidates = np.flatnonzero(high.any(axis=1))
    shifts = high[candidates].astype(np.int8)
    tree = cKDTree(points)
    distance, masters = tree.query(points[candidates] - shifts * cell.period) if candidates.size else (np.zeros(0), np.zeros(0, np.int64))
    paired = distance <= tol
    slaves, masters, shifts = candidates[paired], masters[paired].astype(np.int64), shifts[paired]
    has_partner = np.zeros(points.shape[0], bool)
    has_partner[slaves] = True
    has_partner[masters] = True
    unpaired = np.flatnonzero((low | high).any(axis=1) & ~has_partner)
    if model is not None and unpaired.size:
        off = unpaired[np.abs(model(points[unpaired])) > 1e-3 * h]
        if off.size:
            node = int(off[0])
            raise MeshingError(
                f"the periodic mesh's faces do not match: node {node} at {np.round(points[node], 9).tolist()} has no "
                f"partner one period away ({off.size} such nodes off the surface); this is a bug in fepre, please report it"
            )
    return slaves.astype(np.int64), masters, shifts, unpaired.astype(np.int64)


def periodic_nodes(mesh) -> PeriodicNodes:
    """The node pairs of a periodic mesh made by ``fepre.distmesh(..., periodic=...)``.

    Parameters
    ----------
    mesh : pyvista.UnstructuredGrid
        A mesh with field data ``periodic_lower`` and ``periodic_period`` (fepre's periodic
        meshes, and their exports read back).

    Returns
    -------
    PeriodicNodes

    Examples
    --------
    >>> import fepre
    >>> from fepre import sdf
    >>> mesh = fepre.distmesh(sdf.gyroid(period=1.0, thickness=0.2), h=0.12, periodic=1.0)
    >>> nodes = fepre.periodic_nodes(mesh)
    >>> bool(abs(mesh.points[nodes.slaves] - nodes.shifts * 1.0 - mesh.points[nodes.masters]).max() < 1e-12)
    True
    """
    field = getattr(mesh, "field_data", {})
    if "periodic_lower" not in field or "periodic_period" not in field:
        raise ValueError(
            "mesh has no periodic cell (field data periodic_lower and periodic_period): make it with "
            "fepre.distmesh(model, h, periodic=(Lx, Ly, Lz))"
        )
    cell = PeriodicCell(np.asarray(field["periodic_lower"], dtype=np.float64).reshape(3),
                        np.asarray(field["periodic_period"], dtype=np.float64).reshape(3))
    points = np.asarray(mesh.points, dtype=np.float64)
    tol = 1e-9 * float(cell.period.max())
    slaves, masters, shifts, unpaired = match_faces(points, cell, tol)
    return PeriodicNodes(cell, slaves, masters, shifts, points, unpaired)
