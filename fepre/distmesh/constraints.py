"""What the mesher's stages consult: constraints on the nodes, the moves and the cells.

A :class:`MeshConstraint` answers the stages of :mod:`fepre.distmesh.pipeline` (which nodes are
laid before the loop, which starting points go, how a node may move, how the final mesh and the
quality stage are made, what is checked and added to the grid); every hook has a no-op default,
so a constraint defines only what it changes. The stages never name a constraint: the user's
fixed points and the sharp features live here, periodic cells and conformal regions in their own
packages (:mod:`fepre.periodic.constraint`, :mod:`fepre.regions.constraint`), which import this
module and never the other way round.
"""

from __future__ import annotations

from typing import Any, Callable

import numpy as np

from ..arguments import as_points
from ..errors import FeatureWarning, warn_user
from .feature_protection import FeatureProtection
from .job import MeshingJob

__all__ = ["MeshConstraint", "FixedPoints", "FeatureNodes", "compose", "Push"]

#: ``push(points, movable) -> (moved indices, distances)``: moves points in place after each step
Push = Callable[[np.ndarray, np.ndarray], tuple[np.ndarray, np.ndarray]]


def compose(first: Push | None, second: Push | None) -> Push | None:
    """One ``protect`` hook that runs ``first`` (or nothing) then ``second``; the moved indices
    and distances of both are returned together (a point moved twice, once with the sum)."""
    if first is None:
        return second
    if second is None:
        return first

    def both(points: np.ndarray, movable: np.ndarray):
        a, da = first(points, movable)
        b, db = second(points, movable)
        index, where = np.unique(np.concatenate([a, b]), return_inverse=True)
        return index, np.bincount(where, np.concatenate([da, db]), index.size)

    return both


class MeshConstraint:
    """A constraint of a DistMesh run; the stages call each hook of every constraint in turn.

    The hooks in the order the stages call them (all no-ops here):

    - argument checks: :meth:`restrict_domain` (before the domain's box is fixed),
      :meth:`check_domain` (after), :meth:`check_fixed_points`;
    - initial points: :meth:`fixed_nodes` (nodes laid in front of the others'),
      :meth:`yielding_nodes` (nodes that give way to those, laid after them), :meth:`admits`
      (which of those yielding nodes this constraint lets in), :meth:`drop_starting`;
    - loop: :meth:`push` (where a node may move, composed in the constraints' order);
    - final mesh: :meth:`final_mesh` (a constraint that makes it itself);
    - quality stage: :meth:`pinned_nodes`, :meth:`locked_nodes`, :meth:`quality_stage` (a variant of the stage),
      :meth:`after_quality_stage`;
    - validation: :meth:`defects`;
    - checks and output: :meth:`check` (history entries, warnings, errors), :meth:`annotate`
      (the grid's data);
    - on a MeshingError of any stage: :meth:`failure_note`.
    """

    def restrict_domain(self, job: MeshingJob) -> None:
        """Change ``job.model`` or ``job.bounds`` before the domain's box is taken from them."""

    def check_domain(self, job: MeshingJob) -> None:
        """Check the arguments against the domain (``job.lower``, ``job.upper``); raise on error."""

    def check_fixed_points(self, job: MeshingJob, points: np.ndarray) -> None:
        """Refuse the user's fixed ``points`` (ValueError) where this constraint cannot keep them."""

    def fixed_nodes(self, job: MeshingJob, fixed: np.ndarray) -> np.ndarray:
        """(K, 3) nodes that never move, laid in front of ``fixed`` (those laid so far)."""
        return np.zeros((0, 3))

    def yielding_nodes(self, job: MeshingJob, fixed: np.ndarray) -> np.ndarray:
        """(K, 3) nodes that never move but give way to ``fixed``; laid after them."""
        return np.zeros((0, 3))

    def admits(self, job: MeshingJob, nodes: np.ndarray) -> np.ndarray | None:
        """(K,) bool: which of another constraint's yielding ``nodes`` may stay (None: all)."""
        return None

    def drop_starting(self, job: MeshingJob, points: np.ndarray) -> np.ndarray | None:
        """(N,) bool: starting points to drop (only free ones are); None drops nothing."""
        return None

    def push(self, job: MeshingJob) -> Push | None:
        """The loop's hook moving free points after each step (see :data:`Push`), or None."""
        return None

    def final_mesh(self, job: MeshingJob) -> bool:
        """Make the final mesh (``job.points``, ``job.tets``, ``job.fixed_mask``) from the
        loop's points; False leaves it to the default :func:`~fepre.distmesh.finalize.final_mesh`."""
        return False

    def pinned_nodes(self, job: MeshingJob) -> np.ndarray | None:
        """(N,) bool: nodes the quality stage must not move, besides the user's fixed points and
        the fixed nodes on the boundary (:func:`~fepre.distmesh.improve_mesh.stage_pins`), or None."""
        return None

    def locked_nodes(self, job: MeshingJob) -> np.ndarray | None:
        """(N,) bool: nodes whose boundary faces the quality stage must keep, or None."""
        return None

    def quality_stage(self, job: MeshingJob, pinned: np.ndarray, locked: np.ndarray | None) -> bool:
        """Run a variant of the quality stage on ``job``; False runs the default one."""
        return False

    def after_quality_stage(self, job: MeshingJob, pinned: np.ndarray, locked: np.ndarray | None) -> None:
        """Further passes after the quality stage (``slivers=True`` only)."""

    def defects(self, job: MeshingJob) -> list:
        """Further defects of the mesh this constraint knows of
        (:class:`~fepre.distmesh.validate.Defect`; the validation stage refuses a mesh with any)."""
        return []

    def cell_models(self, job: MeshingJob) -> list | None:
        """``[(model, cells), ...]``: the model each group of final cells fills (``cells`` an (M,)
        bool mask), for the checks that measure where a cell lies (a region's own thickness), or
        None: every cell fills ``job.model``."""
        return None

    def check(self, job: MeshingJob) -> None:
        """Check the final mesh; add entries to ``job.history``; warn or raise MeshingError."""

    def annotate(self, job: MeshingJob, grid) -> None:
        """Add this constraint's point, cell or field data to the output ``grid``."""

    def failure_note(self, job: MeshingJob) -> str | None:
        """A sentence added to a MeshingError of the run (what in this constraint's input may
        be the cause, and what to change), or None."""
        return None


class FixedPoints(MeshConstraint):
    """The user's ``fixed=`` points: nodes of the mesh that never move.

    Parameters
    ----------
    points : (M, 3) float array
        Checked points (:meth:`checked`).
    """

    def __init__(self, points: np.ndarray) -> None:
        self.points = points

    @classmethod
    def checked(cls, job: MeshingJob, fixed: Any, constraints: list[MeshConstraint]) -> FixedPoints | None:
        """The constraint of ``fixed`` (None for no points), refused where they cannot be kept:
        outside the solid, repeated, or where another of ``constraints`` refuses them."""
        if fixed is None:
            return None
        points, _ = as_points(fixed, 3, "fixed")
        values = job.model(points)
        outside = values > 1e-3 * job.h
        if outside.any():
            raise ValueError(
                f"fixed points must lie in the domain (sdf <= 1e-3 h); point {points[outside][0].tolist()} "
                f"has sdf {values[outside][0]:.4g}"
            )
        if len(np.unique(points, axis=0)) != len(points):
            raise ValueError("fixed must not contain duplicate points")
        for constraint in constraints:
            constraint.check_fixed_points(job, points)
        return cls(points)

    def fixed_nodes(self, job: MeshingJob, fixed: np.ndarray) -> np.ndarray:
        return self.points


class FeatureNodes(MeshConstraint):
    """The model's sharp features (``features=True``): their nodes never move, free points keep
    out of their neighbourhoods (:class:`~fepre.distmesh.feature_protection.FeatureProtection`).

    Feature nodes closer than ``h/2`` to a node laid by another constraint give way to it.
    """

    def __init__(self) -> None:
        self.protection: FeatureProtection | None = None

    def yielding_nodes(self, job: MeshingJob, fixed: np.ndarray) -> np.ndarray:
        found = job.detected_features()
        # a cut model (a periodic cell) has features of the cut: warn only of the model's own
        skipped = found.skipped if job.given_model is job.model else job.detected_features(job.given_model).skipped
        for message in skipped:
            warn_user(f"distmesh: {message}", FeatureWarning)
        if not found:
            return np.zeros((0, 3))
        nodes = found.nodes
        for constraint in job.constraints:
            admitted = constraint.admits(job, nodes)
            if admitted is not None:
                nodes = nodes[admitted]
        job.feature_nodes = len(nodes)
        if len(fixed) and len(nodes):
            from scipy.spatial import cKDTree

            distance, _ = cKDTree(fixed).query(nodes)
            nodes = nodes[distance >= 0.5 * job.h]
        self.protection = FeatureProtection(found, job.model, job.h)
        return nodes

    def drop_starting(self, job: MeshingJob, points: np.ndarray) -> np.ndarray | None:
        return None if self.protection is None else self.protection.inside(points)

    def push(self, job: MeshingJob) -> Push | None:
        return None if self.protection is None else self.protection.push

