"""The state of one DistMesh run, handed from stage to stage (:mod:`fepre.distmesh.pipeline`)."""

from __future__ import annotations

import time
from dataclasses import dataclass, field
from typing import Any, Callable

import numpy as np

from ..sdf.core import SDF
from .estimate import StageLog
from .loop import DistMeshState, LoopResult
from .options import DistMeshOptions

__all__ = ["MeshingJob"]


def _no_trim():
    from .thin_trim import Trimmed

    return Trimmed.none()


def _no_fragments():
    from .pieces import Fragments

    return Fragments.none()


@dataclass
class MeshingJob:
    """The state the stages pass on: the run's arguments, the constraints, the mesh so far.

    Attributes
    ----------
    model : fepre.sdf.SDF
        The solid meshed (a periodic cell's cut of ``given_model``).
    given_model : fepre.sdf.SDF
        The model as the user gave it.
    h : float
        The smallest target edge length (the argument as given until the sizes are resolved).
    size : callable or None
        Relative sizes, or edge lengths when ``absolute`` (a size field); as given until resolved.
    keywords : dict
        The keyword arguments that constraints of other packages are made from (``periodic``,
        ``regions``; see :mod:`fepre.constraint_keywords`).
    constraints : list of fepre.distmesh.constraints.MeshConstraint
        Consulted by every stage, in this order.
    user_fixed : (M, 3) array or None
        The user's ``fixed=`` points, checked.
    features : fepre.Features or None
        The solid's sharp features once found (:meth:`detected_features`).
    bounds, lower, upper
        The box given (or None) and the domain's corners, (3,) arrays.
    fixed_count : int
        The first ``fixed_count`` of ``points`` are the fixed nodes, laid by the constraints.
    points, fixed_mask, tets
        The mesh so far; ``fixed_mask`` marks nodes that never moved.
    loop : LoopResult
        The loop's result; ``previous`` its last triangulation, for the final mesh to reuse.
    unimproved : tuple or None
        ``(points, tets, fixed_mask)`` before the quality stage, for the validation stage to
        fall back on when the stage made the mesh invalid.
    boundary : tuple or None
        ``(tets, boundary faces)`` as the validation stage found them; the output reuses the
        faces while ``tets`` is still the job's.
    history : dict
        Field data ``distmesh_<key>`` of the output.
    frame_offset : (3,) array
        The user's frame is the job's moved by this (:mod:`fepre.placement`: a part far from the
        origin is meshed near it); warnings that name a place add it.
    seconds : dict
        Stage times: ``features``, ``loop`` (everything up to the final mesh), ``slivers``.
    split_edges : int
        Long boundary edges split before the quality stage (new nodes on the surface).
    inserted_nodes : int
        Nodes inserted at the cells the quality stage left below its targets, before running again.
    trimmed : fepre.distmesh.thin_trim.Trimmed
        The cells in parts thinner than an element that the quality stage gave up.
    fragments : fepre.distmesh.pieces.Fragments
        The small pieces cut off from the rest that were dropped.
    """

    model: SDF
    given_model: SDF
    h: Any
    size: Any
    options: DistMeshOptions
    bounds: Any = None
    absolute: bool = False
    progress: bool = False
    callback: Callable[[DistMeshState], object] | None = None
    keywords: dict[str, Any] = field(default_factory=dict)
    constraints: list = field(default_factory=list)  # of fepre.distmesh.constraints.MeshConstraint
    user_fixed: np.ndarray | None = None
    lower: np.ndarray | None = None
    upper: np.ndarray | None = None
    features: Any = None
    feature_nodes: int = 0
    fixed_count: int = 0
    points: np.ndarray | None = None
    fixed_mask: np.ndarray | None = None
    tets: np.ndarray | None = None
    protect: Callable | None = None  # the loop's push hook, composed of the constraints'
    loop: LoopResult | None = None
    previous: np.ndarray | None = None
    unimproved: tuple | None = None  # (points, tets, fixed_mask) before the quality stage
    boundary: tuple | None = None  # (tets, their boundary faces) as the validation stage found them
    stage_log: StageLog | None = None
    history: dict[str, np.ndarray] = field(default_factory=dict)
    seconds: dict[str, float] = field(default_factory=dict)
    split_edges: int = 0  # long boundary edges the quality stage split
    crease_flips: int = 0  # boundary edges across a concave crease flipped onto it
    inserted_nodes: int = 0  # nodes inserted at the cells the quality stage left below its targets
    trimmed: Any = field(default_factory=lambda: _no_trim())
    fragments: Any = field(default_factory=lambda: _no_fragments())
    frame_offset: np.ndarray = field(default_factory=lambda: np.zeros(3))
    started: float = field(default_factory=time.perf_counter)

    def detected_features(self, model: SDF | None = None):
        """The sharp features of ``model`` (default: the solid meshed), found once."""
        from ..features import features as detect_features

        model = self.model if model is None else model
        if model is self.model and self.features is not None:
            return self.features
        o = self.options
        # the size field's crease search, taken when it was of this model at this spacing and
        # angle (hmin / 4, over the part's box with a margin): the features are found once. A
        # field whose smallest size is above hmin (no grid node at the floor) puts the mesher's
        # spacing at its own h / 4: searched again
        found = detect_features(model, self.h, angle=o.feature_angle, bounds=(self.lower, self.upper), size=self.size,
                                warn=False, creases=getattr(self.size, "creases", None))
        if model is self.model:
            self.features = found
        return found
