"""``distmesh(..., regions=)``: conformal regions as a constraint of the mesher's stages.

The interface nodes are laid first (:func:`~fepre.regions.interface.interface_nodes`), free points
keep out of the interface triangles' diametral balls (dropped at the start, pushed out after each
move), the final mesh repairs cells crossing an interface
(:func:`~fepre.regions.conform.final_region_mesh`), the quality stage flips within one region
(:func:`~fepre.regions.conform.region_quality_stage`), the interfaces are checked at the end and the
grid gets ``region_id``, ``region_names`` and ``interface``.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from ..distmesh.constraints import MeshConstraint
from ..errors import MeshingError
from .conform import check_interfaces, final_region_mesh, region_quality_stage
from .interface import interface_node_mask, interface_nodes
from .partition import RegionSet, region_set
from .protection import InterfaceProtection, drop_protected

__all__ = ["RegionConstraint"]


class RegionConstraint(MeshConstraint):
    """A part made of several regions meshed as one, its interfaces made of faces of the mesh.

    Parameters
    ----------
    regions : dict name -> fepre.sdf.SDF
        The regions (``distmesh(..., regions=)``), checked against the domain by :meth:`check_domain`.
    """

    def __init__(self, regions: Any) -> None:
        self.regions = regions
        self.region_set: RegionSet | None = None
        self.on_interface = np.zeros((0, 3))
        self.guard: InterfaceProtection | None = None
        self.region_ids: np.ndarray | None = None
        self.interface_mask: np.ndarray | None = None
        self.dropped = 0

    @classmethod
    def from_keyword(cls, regions: Any, job) -> RegionConstraint:
        """The constraint of ``distmesh(..., regions=regions)``."""
        return cls(regions)

    def check_domain(self, job) -> None:
        self.region_set = region_set(self.regions, job.model, job.h, job.lower, job.upper)

    def fixed_nodes(self, job, fixed: np.ndarray) -> np.ndarray:
        found = job.detected_features() if job.options.features else None  # the part's features, laid on the interfaces too
        on_interface, triangles, inner = interface_nodes(
            job.model, self.region_set, job.h, (job.lower, job.upper), job.options, job.progress, part_features=found)
        if len(fixed) and len(on_interface):  # a fixed point on an interface stands for its node
            from scipy.spatial import cKDTree

            distance, _ = cKDTree(fixed).query(on_interface)
            on_interface = on_interface[distance > 1e-9 * job.h]
        self.on_interface = on_interface
        self.guard = InterfaceProtection(triangles, inner, self.region_set.region_of)
        return on_interface

    def drop_starting(self, job, points: np.ndarray) -> np.ndarray:
        return self.guard.inside(points)

    def push(self, job):
        return self.guard.push

    def final_mesh(self, job) -> bool:
        o, h = job.options, job.h
        loop_points, loop_fixed, dropped = drop_protected(job.model, job.loop.points, job.loop.fixed_mask, self.guard, h)
        kept = np.concatenate([self.on_interface] + ([] if job.user_fixed is None else [job.user_fixed]))
        job.points, job.tets, job.fixed_mask, self.region_ids, self.dropped, crossing = final_region_mesh(
            job.model, loop_points, loop_fixed, h, o.geps, o.delaunay, job.previous if dropped == 0 else None,
            self.region_set, kept=kept)
        if crossing.any():
            raise MeshingError(
                f"distmesh: {int(crossing.sum())} cell(s) cross an interface between regions after dropping "
                f"{self.dropped} node(s) near it (e.g. at {np.round(job.points[job.tets[crossing][0]].mean(axis=0), 6).tolist()}: "
                f"a gap or wedge of the part thinner than h next to an interface); the interfaces are not "
                f"resolved at h={h:g} (try a smaller h)"
            )
        self.interface_mask = interface_node_mask(job.tets, self.region_ids, len(job.points))
        return True

    def quality_stage(self, job, pinned: np.ndarray, locked: np.ndarray | None) -> bool:
        job.points, job.tets, self.region_ids = region_quality_stage(
            job.points, job.tets, self.region_ids, self.region_set, job.model, job.h, pinned, self.interface_mask,
            job.options.seed, job.size)
        return True

    def cell_models(self, job) -> list:
        return [(model, self.region_ids == k) for k, model in enumerate(self.region_set.models)]

    def check(self, job) -> None:
        faces, _ = check_interfaces(job.points, job.tets, self.region_ids, self.region_set, job.model, job.h)  # MeshingError
        job.history.update(interface_faces=np.array([len(faces)]), interface_nodes_dropped=np.array([self.dropped]))

    def annotate(self, job, grid) -> None:
        grid.cell_data["region_id"] = self.region_ids
        grid.field_data["region_names"] = np.array(self.region_set.names)
        grid.point_data["interface"] = interface_node_mask(job.tets, self.region_ids, len(job.points)).astype(np.uint8)
