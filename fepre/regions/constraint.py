"""``distmesh(..., regions=)``: conformal regions as a constraint of the mesher's stages.

The interface nodes are laid first (:func:`~fepre.regions.interface.interface_nodes`), free points
keep out of the interface triangles' diametral balls (dropped at the start, pushed out after each
move), the final mesh repairs cells crossing an interface
(:func:`~fepre.regions.conform.final_region_mesh`), the quality stage works within one region
(long boundary edges split, :func:`~fepre.regions.conform.region_quality_stage`, vertex
insertion), the interfaces are checked at the end and the
grid gets ``region_id``, ``region_names`` and ``interface``.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from ..distmesh.constraints import MeshConstraint
from ..errors import MeshingError
from .clearance import check_clearances
from .conform import check_interfaces, exposed_interface_faces, final_region_mesh, node_regions, region_quality_stage
from .interface import ON_INTERFACE, interface_node_mask, interface_nodes
from .partition import RegionSet, check_regions, region_set, surface_model
from .protection import InterfaceProtection, drop_protected

#: a face between two regions whose centroid lies farther than this (local sizes) from either
#: region's surface, inside a third region, crosses that region
CROSSED = 0.25

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
        self.clearances_checked = False
        self.on_interface = np.zeros((0, 3))
        self.guard: InterfaceProtection | None = None
        self.region_ids: np.ndarray | None = None
        self.interface_mask: np.ndarray | None = None
        self.dropped = 0

    @classmethod
    def from_keyword(cls, regions: Any, job) -> RegionConstraint:
        """The constraint of ``distmesh(..., regions=regions)``, its regions' types checked (before
        the size field, which takes each region's with ``h=(hmin, hmax)``)."""
        check_regions(regions)
        constraint = cls(regions)
        constraint.clearances_checked = constraint._early_clearances(job)
        return constraint

    def _early_clearances(self, job) -> bool:
        """The clearance check (:func:`~.clearance.check_clearances`) before the size fields,
        whose work takes a while, at the ``h`` given (``hmin`` of a pair) over the model's box;
        False (left to :meth:`check_domain`) while those are not valid yet: the argument
        checks then say why."""
        from ..arguments import domain_bounds

        try:
            h = float(np.asarray(job.h, dtype=object).reshape(-1)[0])
            lower, upper = (np.asarray(v, dtype=np.float64) for v in domain_bounds(job.model, job.bounds))
        except (TypeError, ValueError, IndexError):
            return False
        if not (np.isfinite(h) and h > 0.0):
            return False
        check_clearances(RegionSet(tuple(self.regions), tuple(self.regions.values())), job.model, lower, upper, h)
        return True

    def check_domain(self, job) -> None:
        self.region_set = region_set(self.regions, job.model, job.h, job.lower, job.upper)
        if not self.clearances_checked:  # before any meshing
            check_clearances(self.region_set, job.model, job.lower, job.upper, job.h)

    def fixed_nodes(self, job, fixed: np.ndarray) -> np.ndarray:
        found = job.detected_features() if job.options.features else None  # the part's features, laid on the interfaces too
        from ..distmesh.pipeline import relative_size

        on_interface, triangles, inner = interface_nodes(
            job.model, self.region_set, job.h, (job.lower, job.upper), job.options, job.progress, part_features=found,
            size=relative_size(job))
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

    def failure_note(self, job) -> str | None:
        if self.region_set is None:
            return None
        from .thickness import thin_regions_note

        return thin_regions_note(self.region_set, job.model, job.lower, job.upper, job.h, job.frame_offset)

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
        """The stage of a plain mesh within each region: long boundary edges split, the region
        mesh's stage (:func:`~fepre.regions.conform.region_quality_stage`), then vertex insertion
        at the cells it leaves under the targets; no face between two regions changes."""
        from ..distmesh.cell_labels import refined_labels
        from ..distmesh.improve_mesh import stage_pins
        from ..distmesh.insertion_stage import LabelledCells, stage_with_insertions
        from ..distmesh.pipeline import fill_surface_gaps, local_size, removable_nodes

        regions, h = self.region_set, job.h
        before = job.tets
        fill_surface_gaps(job, locked=self.interface_mask)
        if job.split_edges:
            self.region_ids = refined_labels(job.points, before, self.region_ids, job.tets)
            self.interface_mask = np.concatenate([self.interface_mask, np.zeros(job.split_edges, dtype=bool)])
            pinned = stage_pins(job.points, job.tets, job.fixed_mask, job.user_fixed, job.model, h)

        def meet(points, tets, region_ids) -> bool:  # the regions meet on faces on the interfaces only
            try:
                check_interfaces(points, tets, region_ids, regions, job.model, h)
            except MeshingError:
                return False
            return True

        labelled = LabelledCells(self.region_ids, self.interface_mask,
                                 lambda points: (node_regions(points, regions, h), regions.region_of), meet)

        def first_run():
            return region_quality_stage(job.points, job.tets, self.region_ids, regions, job.model, h, pinned,
                                        self.interface_mask, job.options.seed, job.size)

        self.region_ids = stage_with_insertions(job, pinned, removable_nodes, local_size(job), labelled, first_run)
        self.interface_mask = interface_node_mask(job.tets, self.region_ids, len(job.points))
        return True

    def cell_models(self, job) -> list:
        return [(model, self.region_ids == k) for k, model in enumerate(self.region_set.models)]

    def check(self, job) -> None:
        faces, pairs = check_interfaces(job.points, job.tets, self.region_ids, self.region_set, job.model, job.h)  # MeshingError
        self._warn_crossed_regions(job, faces, pairs)
        self._warn_thin_pieces(job)
        self._warn_region_volumes(job)
        job.history.update(interface_faces=np.array([len(faces)]), interface_nodes_dropped=np.array([self.dropped]))

    def _warn_crossed_regions(self, job, faces: np.ndarray, pairs: np.ndarray) -> None:
        """A ResolutionWarning for faces between two regions that lie off both regions' surfaces
        (farther than ``CROSSED`` local sizes) where a third region holds them or where no face of
        that pair lies on both surfaces (the regions do not touch): a layer thinner than the mesh
        resolves (a label image's coating around an implant) is punctured there, and the mesh
        joins regions that do not touch. A pair whose faces are merely far from a poorly resolved
        interface is left to the region volume check."""
        if not job.options.check_resolution or len(faces) == 0:
            return
        import warnings

        from ..distmesh.pipeline import local_size
        from ..errors import ResolutionWarning

        centroids = job.points[faces].mean(axis=1)
        values = self.region_set.values(centroids)
        rows = np.arange(len(faces))
        sizes = local_size(job)
        size = job.h if sizes is None else np.asarray(sizes(centroids), dtype=float)
        off = np.maximum(np.abs(values[rows, pairs[:, 0]]), np.abs(values[rows, pairs[:, 1]])) > CROSSED * size
        between = values.copy()
        between[rows, pairs[:, 0]] = between[rows, pairs[:, 1]] = np.inf
        inside_third = between.min(axis=1) < 0
        key = pairs[:, 0] * len(self.region_set.names) + pairs[:, 1]
        apart = np.zeros(len(faces), dtype=bool)
        for pair in np.unique(key):
            chosen = key == pair
            apart[chosen] = off[chosen].all()
        crossed = off & (inside_third | apart)
        if not crossed.any():
            return
        names, lines = self.region_set.names, []
        for pair in np.unique(key[crossed]):
            chosen = np.flatnonzero(crossed & (key == pair))
            a, b = pairs[chosen[0]]
            corners = job.points[faces[chosen]]
            area = 0.5 * float(np.linalg.norm(np.cross(corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0]), axis=1).sum())
            held = np.bincount(np.argmin(between[chosen], axis=1)[inside_third[chosen]], minlength=len(names))
            through = f" through {names[int(np.argmax(held))]!r}" if held.any() else ""
            where = ", ".join(f"{v:.4g}" for v in centroids[chosen].mean(axis=0) + job.frame_offset)
            lines.append(f"{len(chosen)} face(s) (area {area:.3g}) join {names[a]!r} and {names[b]!r}{through} near ({where}), "
                         f"{'where they do not touch in the model' if apart[chosen[0]] else 'off both their surfaces'}")
        size_name = "hmin" if job.size is not None else "h"
        warnings.warn(
            f"distmesh: {'; '.join(lines)}: a layer between regions thinner than the mesh resolves is punctured; mesh "
            f"with a smaller {size_name} (about half the layer's thickness) to keep it whole", ResolutionWarning, stacklevel=2)

    def _warn_thin_pieces(self, job) -> None:
        """A ResolutionWarning for pieces of regions thinner than :data:`~fepre.regions.conform.THIN_PIECE`
        h left unmeshed beyond an interface (the plain mesh loses parts thinner than h the same way)."""
        import warnings

        from ..errors import ResolutionWarning

        on = self.region_set.on_interface(job.points, ON_INTERFACE * job.h)
        exposed, depth = exposed_interface_faces(job.points, job.tets, job.model, job.h, on)
        if len(exposed):
            worst = int(np.argmax(depth))
            where = np.round(job.points[exposed[worst]].mean(axis=0) + job.frame_offset, 6).tolist()  # the user's frame
            warnings.warn(
                f"distmesh: {len(exposed)} face(s) on an interface lie on the mesh's surface: a piece of a region "
                f"beyond them, up to {depth[worst]:.3g} thick (at {where}), is thinner than h={job.h:g} and is not "
                f"meshed; h={depth[worst]:.2g} or smaller would mesh it", ResolutionWarning, stacklevel=2)

    def _warn_region_volumes(self, job) -> None:
        """A ResolutionWarning for each region whose cells' volume is more than
        ``VOLUME_TOLERANCE`` off its model's exact volume (a CAD solid's, a label's: their
        triangles'), with the h that would bring it to about ``VOLUME_AIM``. The part's volume
        can be right while a region's is not: a pin's chords give its section to the lugs around
        it (a clevis's pin -1.3% at h = (2, 10), the whole part -0.08%)."""
        if not job.options.check_resolution:
            return
        import warnings

        from ..distmesh.lost_material import VOLUME_AIM, VOLUME_TOLERANCE, finer_for_volume
        from ..errors import ResolutionWarning
        from ..quality import signed_volumes

        volumes = np.bincount(self.region_ids, weights=signed_volumes(job.points, job.tets), minlength=len(self.region_set.names))
        size = "hmin" if job.size is not None else "h"
        lines = []
        for name, region, meshed in zip(self.region_set.names, self.region_set.models, volumes):
            own = surface_model(region)  # a label inside the image has its volume whatever the others do
            exact = getattr(own, "volume", None) if (getattr(region, "within", None) is job.model
                                                     or getattr(own, "inside_image", False)) else None
            if not exact:
                continue
            error = meshed / abs(float(exact)) - 1.0
            if abs(error) > VOLUME_TOLERANCE:
                finer = finer_for_volume(job.h, error)
                lines.append(f"region {name!r} {100 * abs(error):.1f}% {'short of' if error < 0 else 'over'} its model "
                             f"({meshed:.4g} against {abs(float(exact)):.4g}; {size} <= {finer:.2g} comes within about "
                             f"{100 * VOLUME_AIM:g}%)")
        if lines:
            warnings.warn(
                f"distmesh: {'; '.join(lines)}: curved interfaces and surfaces lose their chords' sag, which a "
                f"neighbouring region may gain (the error falls about as {size} squared)", ResolutionWarning, stacklevel=2)

    def annotate(self, job, grid) -> None:
        grid.cell_data["region_id"] = self.region_ids
        grid.field_data["region_names"] = np.array(self.region_set.names)
        grid.point_data["interface"] = interface_node_mask(job.tets, self.region_ids, len(job.points)).astype(np.uint8)

