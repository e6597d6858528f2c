"""``distmesh(..., periodic=)``: the periodic cell as a constraint of the mesher's stages.

The cell's corner, edge and face nodes are laid first and copied across the period; free points
keep 0.45 h off the faces (dropped at the start, clamped back after each move); feature nodes on
the faces give way to the face nodes; the quality stage keeps the faces' triangles (``locked``)
and the face nodes then move with their images (:func:`~fepre.periodic.face_smoothing.smooth_face_nodes`);
every face node's partner is checked at the end.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from ..distmesh.constraints import MeshConstraint
from ..errors import MeshingError, ResolutionWarning, warn_user
from .cell import FACE_MARGIN, PeriodicCell, check_periodic_model, periodic_cell

__all__ = ["PeriodicConstraint"]


class PeriodicConstraint(MeshConstraint):
    """One cell of a periodic model; its faces carry the same nodes as their opposites.

    Parameters
    ----------
    periodic : float or (Lx, Ly, Lz)
        The periods (``distmesh(..., periodic=)``).
    """

    def __init__(self, periodic: Any) -> None:
        self.periodic = periodic
        self.cell: PeriodicCell | None = None
        self.face_node_count = 0

    @classmethod
    def from_keyword(cls, periodic: Any, job) -> PeriodicConstraint:
        """The constraint of ``distmesh(..., periodic=periodic)``; checks the arguments that
        cannot go with it and sets the cell as the default bounds."""
        if job.size is not None or isinstance(job.h, (tuple, list, np.ndarray)):
            raise ValueError("periodic meshes take one h (a number); size= and h=(hmin, hmax) are not supported with periodic=")
        if job.keywords.get("regions") is not None:
            raise ValueError("periodic= and regions= cannot be combined yet; mesh the periodic cell of one material")
        if job.bounds is None:
            job.bounds = (tuple(np.zeros(3)), tuple(np.broadcast_to(periodic_cell(periodic, None).period, 3)))
        return cls(periodic)

    def restrict_domain(self, job) -> None:
        self.cell = periodic_cell(self.periodic, job.bounds)
        check_periodic_model(job.model, self.cell, job.h)
        job.model = self.cell.solid(job.given_model)
        job.bounds = (tuple(self.cell.lower), tuple(self.cell.upper))

    def check_fixed_points(self, job, points: np.ndarray) -> None:
        if self.cell.on_planes(points, self.cell.tolerance(job.h)).any():
            raise ValueError("fixed points must not lie on the faces of the periodic cell (fepre lays the periodic face nodes itself)")

    def fixed_nodes(self, job, fixed: np.ndarray) -> np.ndarray:
        from .boundary_nodes import boundary_nodes

        face_nodes = boundary_nodes(job.given_model, self.cell, job.h, seed=job.options.seed)
        self.face_node_count = len(face_nodes)
        return face_nodes

    def admits(self, job, nodes: np.ndarray) -> np.ndarray:
        # the face nodes stand for the features on the cell's faces
        return ~self.cell.on_planes(nodes, 1e-3 * job.h).any(axis=1)

    def drop_starting(self, job, points: np.ndarray) -> np.ndarray:
        return (np.minimum(points - self.cell.lower, self.cell.upper - points) < FACE_MARGIN * job.h).any(axis=1)

    def push(self, job):
        return self.cell.keep_off_faces(FACE_MARGIN * job.h)

    def locked_nodes(self, job) -> np.ndarray:
        return self.cell.on_planes(job.points, self.cell.tolerance(job.h)).any(axis=1)

    def after_quality_stage(self, job, pinned: np.ndarray, locked: np.ndarray | None) -> None:
        from ..distmesh.slivers import improve_arrays
        from ..distmesh.tet_shape import ShapeTargets
        from .face_smoothing import smooth_face_nodes

        job.points, moves = smooth_face_nodes(job.points, job.tets, self.cell, job.given_model, job.h, ShapeTargets(),
                                              seed=job.options.seed)
        if moves:  # the cells around the moved face nodes may now be improved further
            try:
                job.points, job.tets, _ = improve_arrays(job.points, job.tets, job.model, job.h, fixed_mask=pinned,
                                                         size=job.size, seed=job.options.seed, locked=locked)
            except MeshingError:
                pass

    def check(self, job) -> None:
        from .nodes import match_faces

        *_, unpaired = match_faces(job.points, self.cell, self.cell.tolerance(job.h), job.model, job.h)  # MeshingError: a node off the surface
        if unpaired.size:
            warn_user(
                f"distmesh: {unpaired.size} node(s) on the rim of the periodic cell's faces have no partner on the "
                "opposite face (the mesh kept their cells on one face only); they are left unconstrained",
                ResolutionWarning,
            )
        job.history.update(periodic_nodes=np.array([self.face_node_count]), periodic_unpaired=np.array([unpaired.size]))

    def annotate(self, job, grid) -> None:
        grid.field_data["periodic_lower"] = self.cell.lower
        grid.field_data["periodic_period"] = self.cell.period
