"""The quality stage: sliver removal and shape improvement of tetrahedral meshes.

Raw DistMesh leaves slivers, flat tetrahedra with four well-spaced vertices, that Delaunay
keeps (BACKGROUND.md section 1). This stage removes them and raises the mean shape quality,
with vectorised operations that each check every new cell before accepting it. Cells are
ranked by one *score* (:class:`~fepre.distmesh.tet_shape.ShapeTargets`): the worst of their
smallest dihedral angle, largest dihedral angle and radius ratio, each mapped to degrees so
that a cell meets all three targets (default 25 deg, 150 deg, 0.25) exactly when its score
reaches ``min_dihedral``; every operation below raises the worst score, so it improves
whichever measure is worst:

1. *relaxation* (:func:`~fepre.distmesh.smoothing.relax_round`): every vertex moves towards the
   mean of the positions that would make each of its cells regular (boundary vertices slide on
   the model's zero set); moves that leave a cell scoring below ``min(its old score, target)``
   are undone. This lifts the mean radius ratio;
2. *shape flips* (:func:`~fepre.distmesh.flips.shape_flip_round`): 3-2 and 4-4 flips around
   the cells of radius ratio below 0.8 that raise the smallest radius ratio of the cells they
   replace. Relaxation alone stops at a fixed point of the connectivity it was given; a flip
   round frees it, so the two alternate while the mean radius ratio rises by ``SHAPE_GAIN`` a
   round (near a thin wall or a coarse boundary layer this is worth 0.01-0.03);
3. *flips* (:func:`~fepre.distmesh.flips.flip_round`): 2-3 face removal and n-to-(2n-4) edge
   removal (3-2, 4-4, ... up to rings of 6) around the bad cells, keeping a flip only if it
   raises the worst score of the cells it replaces;
4. *vertex smoothing* (:func:`~fepre.distmesh.smoothing.smooth_round`): the vertices of bad
   cells try a couple of dozen candidate positions each and take the best one if it raises
   the worst score of their star; a maximal set of vertices that share no cell moves at once,
   and of one bad cell's vertices the one that lifts its star most moves first;
5. *boundary cells* (:mod:`~fepre.distmesh.boundary_slivers`): flat cells lying on the boundary
   (two boundary faces, or one boundary face over a vertex just under the surface) are removed,
   with a boundary edge flip or the vertex projected onto the zero set;
6. *pit fills* (:mod:`~fepre.distmesh.pit_fill`): a bad cell's boundary vertex at the bottom of a
   pit of three faces (a crevice narrower than h just under the surface) is covered by a new
   cell over the pit and moves inside.

The worst slivers are flipped first, then relaxation and shape flips lift the mean shape; then
the stage works on the cells scoring below ``min_dihedral + 8`` degrees: flips, smoothing and boundary
removals alternate until none is left, or the target holds and the worst angle stops rising (or
twenty rounds have passed since it first held), or ``maxiter`` rounds. Flips never touch
the boundary surface; boundary vertices only move along the zero set (re-projected, checked to
within ``1e-4 h``), on their own surface patch, along paths near the surface and keeping their
faces on it (:class:`~fepre.distmesh.surface_guard.SurfaceGuard`), and a move whose faces cross
another boundary face is put back (:func:`~fepre.distmesh.surface_guard.folding_vertices`); fixed vertices never move; the end result is verified (positive cells,
closed manifold boundary, boundary vertices within ``1e-3 h`` of the zero set, volume within 2%
of the input's) and a violation raises :class:`fepre.MeshingError`.
"""

from __future__ import annotations

import time
from typing import Any, Callable

import numpy as np

from .._cell_kernels import corner_volumes
from ..arguments import finite_float, positive_float, positive_int, shown
from ..errors import ConvergenceWarning, MeshingError, warn_user
from .boundary_flips import boundary_edge_round
from .boundary_slivers import expose_shallow_vertices, remove_boundary_slivers
from .edge_collapse import collapse_round
from .flips import flip_round, shape_flip_round
from .pit_fill import fill_pits
from .smoothing import relax_round, smooth_round
from .surface_guard import SurfaceGuard
from .tet_shape import ShapeTargets, dihedral_extremes, radius_ratio
from .tet_topology import NonManifoldCells, edge_keys, face_keys, face_neighbours, faces_on_boundary, open_boundary_reason

__all__ = [
    "improve_arrays",
    "DEFAULT_MIN_DIHEDRAL",
    "DEFAULT_MAX_DIHEDRAL",
    "DEFAULT_MIN_RADIUS_RATIO",
    "DEFAULT_MAXITER",
]

#: Default target for the worst (smallest) dihedral angle (degrees).
DEFAULT_MIN_DIHEDRAL = 25.0
#: Default target for the largest dihedral angle (degrees).
DEFAULT_MAX_DIHEDRAL = 150.0
#: Default target for the smallest radius ratio.
DEFAULT_MIN_RADIUS_RATIO = 0.25
#: Default number of flip-and-smooth rounds.
DEFAULT_MAXITER = 40
#: Cells up to this many degrees above the target are improved too, for a safety margin.
MARGIN = 8.0
#: Relaxation passes over the whole mesh before the first shape round.
RELAX_ROUNDS = 1
#: Shape rounds (radius-ratio flips on the cells below ``SHAPE_RATIO``, then a relaxation pass):
#: at most ``SHAPE_ROUNDS``, until a round raises the mean radius ratio by less than ``SHAPE_GAIN``.
SHAPE_ROUNDS = 8
SHAPE_RATIO = 0.8
SHAPE_GAIN = 0.002
#: Once the target is met, stop when the worst angle has not risen by ``PROGRESS`` degrees for
#: this many rounds.
PATIENCE = 8
PROGRESS = 0.1
#: Once the target is met, at most this many further rounds lift the cells below the margin.
POLISH_ROUNDS = 20
#: While the target is not met, stop when for this many rounds the worst angle has not risen by
#: ``PROGRESS`` degrees and no cell has come up to the target.
UNMET_PATIENCE = 8
#: A regular tetrahedron's dihedral angle: no mesh can have a larger worst angle.
REGULAR_DIHEDRAL = float(np.degrees(np.arccos(1.0 / 3.0)))
#: Boundary vertices further than this (times h) from the zero set mean the model is not the
#: mesh's model.
MODEL_MISMATCH = 0.5
#: Boundary vertices stay within this (times h) of the zero set after each move.
SURFACE_TOL = 1e-4


def _boundary_edge_keys(faces: np.ndarray, n_points: int) -> np.ndarray:
    return np.unique(edge_keys(faces[:, [0, 1, 1, 2, 2, 0]].reshape(-1, 2), n_points))


def _check_arrays(points: Any, tets: Any, h: Any, fixed_mask: Any) -> tuple[np.ndarray, np.ndarray, float, np.ndarray]:
    points = np.asarray(points, dtype=np.float64)
    if points.ndim != 2 or points.shape[1] != 3 or points.shape[0] < 4:
        raise ValueError(f"points must have shape (N, 3) with N >= 4; got {points.shape}")
    if not np.isfinite(points).all():
        raise ValueError("points must be finite; got NaN or infinite coordinates")
    tets = np.asarray(tets)
    if tets.ndim != 2 or tets.shape[1] != 4 or tets.dtype.kind not in "iu" or tets.shape[0] == 0:
        raise ValueError(f"tets must be a non-empty integer array of shape (M, 4); got {tets.shape} {tets.dtype}")
    if tets.min() < 0 or tets.max() >= points.shape[0]:
        raise ValueError(f"tets must index points 0..{points.shape[0] - 1}; got {tets.min()}..{tets.max()}")
    h = positive_float(h, "h")
    if fixed_mask is None:
        fixed_mask = np.zeros(points.shape[0], dtype=bool)
    else:
        fixed_mask = np.asarray(fixed_mask)
        if fixed_mask.shape != (points.shape[0],) or fixed_mask.dtype != bool:
            raise ValueError(f"fixed_mask must be a bool array of shape ({points.shape[0]},); got {fixed_mask.shape} {fixed_mask.dtype}")
    return points.copy(), tets.astype(np.int64), h, fixed_mask


def _check_targets(min_dihedral: Any, max_dihedral: Any, min_radius_ratio: Any) -> ShapeTargets:
    smallest = DEFAULT_MIN_DIHEDRAL if min_dihedral is None else finite_float(min_dihedral, "min_dihedral")
    if not 0.0 < smallest < REGULAR_DIHEDRAL:
        raise ValueError(
            f"min_dihedral must be in (0, {REGULAR_DIHEDRAL:.2f}) degrees (a regular tetrahedron's angle); got {shown(min_dihedral)}"
        )
    largest = DEFAULT_MAX_DIHEDRAL if max_dihedral is None else finite_float(max_dihedral, "max_dihedral")
    if not REGULAR_DIHEDRAL < largest < 180.0:
        raise ValueError(
            f"max_dihedral must be in ({REGULAR_DIHEDRAL:.2f}, 180) degrees (above a regular tetrahedron's angle); got {shown(max_dihedral)}"
        )
    ratio = DEFAULT_MIN_RADIUS_RATIO if min_radius_ratio is None else finite_float(min_radius_ratio, "min_radius_ratio")
    if not 0.0 < ratio < 1.0:
        raise ValueError(f"min_radius_ratio must be in (0, 1) (1 is a regular tetrahedron); got {shown(min_radius_ratio)}")
    return ShapeTargets(smallest, largest, ratio)


def _extremes(points: np.ndarray, tets: np.ndarray) -> dict[str, float]:
    smallest, largest, ratio = dihedral_extremes(points[tets])
    return {"min_dihedral": float(smallest.min()), "max_dihedral": float(largest.max()), "min_radius_ratio": float(ratio.min())}


def improve_arrays(
    points: np.ndarray,
    tets: np.ndarray,
    model,
    h: float,
    *,
    fixed_mask: np.ndarray | None = None,
    size: Callable | None = None,
    min_dihedral: float | None = None,
    max_dihedral: float | None = None,
    min_radius_ratio: float | None = None,
    maxiter: int | None = None,
    seed: int = 0,
    deadline_seconds: float | None = None,
    locked: np.ndarray | None = None,
    labels: np.ndarray | None = None,
    node_regions: tuple | None = None,
    collapse: np.ndarray | None = None,
    local_size: Callable | None = None,
    bad_cells_only: bool = False,
    inner_collapses: bool = False,
) -> tuple[np.ndarray, np.ndarray, dict]:
    """Remove slivers and improve cell shapes of a tetrahedral mesh given as arrays.

    Parameters
    ----------
    points : (N, 3) float array
    tets : (M, 4) int array, every cell positively oriented in VTK's convention (flat cells
        are accepted and repaired; inverted ones are refused)
    model : fepre.sdf.SDF
        The model the mesh was made from; boundary vertices stay on its zero set, each on its
        own surface patch.
    h : float
        Target edge length (the smallest one for graded meshes); sets tolerances.
    fixed_mask : (N,) bool, optional
        Vertices that must not move.
    size : callable, optional
        The relative size function the mesh was made with. The stage measures local sizes from
        the mesh itself, so it only checks that ``size`` is callable.
    min_dihedral, max_dihedral : float, optional
        Targets for every cell's smallest and largest dihedral angle in degrees (default 25
        and 150).
    min_radius_ratio : float, optional
        Target for every cell's radius ratio ``3 r_in / R_circ`` (default 0.25).
        Unreachable targets warn with :class:`fepre.ConvergenceWarning` and return the best
        mesh reached.
    maxiter : int, optional
        Largest number of flip-and-smooth rounds (default 40).
    seed : int
        Seed of the random candidate moves; same input and seed give the same mesh.
    deadline_seconds : float, optional
        Stop starting new rounds after this many seconds (no warning).
    locked : (N,) bool, optional
        Boundary vertices whose faces must stay as they are (a periodic cell's face nodes): no
        boundary edge between four of them is flipped and no vertex is exposed through a face
        of three of them. They should be fixed too.
    labels : (M,) int array, optional
        A label of each cell (its material region): cells are only flipped with cells of the
        same label, so the faces between labels stay (their vertices should be fixed and
        locked). ``info["labels"]`` holds the labels of the returned cells.
    node_regions : (owner (N,) int, region_of callable), optional
        With ``labels``: each boundary vertex whose ``owner`` is a region (>= 0; -1 on an
        interface) only slides to positions where ``region_of`` gives that region, so it never
        crosses the rim of an interface along the part's surface.

    bad_cells_only : bool
        Only work on the cells under the targets, without the passes over the whole mesh (for
        a mesh the stage improved before that changed in a few places since).
    inner_collapses : bool
        With ``collapse``: also remove inner vertices crowding another (a bad cell's short edge).

    Returns
    -------
    points, tets, info : the improved mesh (same points count and order; ``tets`` renewed) and a
        dict with ``seconds``, ``relax_seconds``, ``flip_seconds``, ``smooth_seconds``,
        ``rounds``, ``flips``, ``moves``, ``relaxed``, ``removed``, ``collapses``, ``filled``, the worst figures before
        and after (``min_dihedral_before``, ``max_dihedral_before``,
        ``min_radius_ratio_before``, and the same ``_after``) and ``converged``.

    Examples
    --------
    >>> import numpy as np
    >>> from fepre import sdf
    >>> from fepre.distmesh.slivers import improve_arrays
    >>> ball = sdf.sphere(1.0)
    >>> r = 1 / np.sqrt(3)
    >>> points = np.array([[0.3, 0.2, 0.1], [r, r, r], [r, -r, -r], [-r, r, -r], [-r, -r, r]])
    >>> tets = np.array([[0, 1, 2, 3], [0, 1, 4, 2], [0, 1, 3, 4], [0, 2, 4, 3]])
    >>> new_points, new_tets, info = improve_arrays(points, tets, ball, h=1.0)
    >>> round(info["min_dihedral_before"], 1), round(info["min_dihedral_after"], 1)
    (7.7, 35.3)
    >>> round(info["max_dihedral_before"], 1), round(info["max_dihedral_after"], 1)
    (160.3, 120.0)
    >>> bool(np.abs(new_points[0]).max() < 1e-9)  # the inner vertex moved back to the centre
    True
    """
    start = time.perf_counter()
    points, tets, h, fixed_mask = _check_arrays(points, tets, h, fixed_mask)
    locked, labels = _check_masks(points, tets, size, locked, labels)
    targets = _check_targets(min_dihedral, max_dihedral, min_radius_ratio)
    maxiter = DEFAULT_MAXITER if maxiter is None else positive_int(maxiter, "maxiter")
    deadline = None if deadline_seconds is None else positive_float(deadline_seconds, "deadline_seconds")
    volumes, faces = _check_solid(points, tets, model, h, fixed_mask)

    stage = _SliverStage(points, tets, model, h, fixed_mask, faces, targets, locked, labels, seed, node_regions)
    if local_size is not None:
        if not callable(local_size):
            raise TypeError(f"local_size must be a callable (K, 3) -> (K,) or None; got {type(local_size).__name__}")
        stage.guard.local_size = local_size
    _set_collapses(stage, collapse, inner_collapses)
    volume_before = float(volumes.sum())
    before = _extremes(stage.points, stage.tets)
    rounds = _all_rounds(stage, bad_cells_only, maxiter, deadline, start)

    _verify(stage.points, stage.tets, stage.quality, model, stage.on_boundary, fixed_mask, h, volume_before,
            stage.boundary_face_keys)
    return stage.points, stage.tets, _report(stage, before, rounds, maxiter, start)


def _all_rounds(stage, bad_cells_only: bool, maxiter: int, deadline: float | None, start: float) -> int:
    """The stage's rounds; returns the target rounds run. A move that left cells overlapping
    (each positive, a face in three cells: cow.obj at (D/100, D/50) with its seam pieces joined
    met it in a flip round, raised as a ValueError) refuses the run with a MeshingError."""
    try:
        if not bad_cells_only:
            stage.first_flips_and_relaxation()
            stage.shape_rounds()
        return stage.target_rounds(maxiter, deadline, start)
    except NonManifoldCells as exc:
        raise MeshingError(f"the quality stage broke the mesh topology: {exc}") from None


def _set_collapses(stage, collapse: Any, inner_collapses: bool) -> None:
    """The stage's removable vertices (``improve_arrays(collapse=...)``) checked and set."""
    if collapse is None:
        return
    stage.removable = np.asarray(collapse, dtype=bool).copy()
    if stage.removable.shape != (stage.points.shape[0],):
        raise ValueError(f"collapse must be a bool array of shape ({stage.points.shape[0]},); "
                         f"got {stage.removable.shape}")
    stage.inner_collapses = bool(inner_collapses)


def _check_masks(points: np.ndarray, tets: np.ndarray, size: Any, locked: Any, labels: Any):
    """``locked`` (N,) bool and ``labels`` (M,) int64 checked (None stays None); ``size`` callable."""
    if locked is not None:
        locked = np.asarray(locked)
        if locked.shape != (points.shape[0],) or locked.dtype != bool:
            raise ValueError(f"locked must be a bool array of shape ({points.shape[0]},); got {locked.shape} {locked.dtype}")
    if size is not None and not callable(size):
        raise TypeError(f"size must be a callable (N, 3) -> (N,) or None; got {type(size).__name__}")
    if labels is not None:
        labels = np.asarray(labels)
        if labels.shape != (tets.shape[0],) or labels.dtype.kind not in "iu":
            raise ValueError(f"labels must be an int array of shape ({tets.shape[0]},); got {labels.shape} {labels.dtype}")
        labels = labels.astype(np.int64)
    return locked, labels


def _check_solid(points: np.ndarray, tets: np.ndarray, model, h: float, fixed_mask: np.ndarray):
    """Refuse inverted cells, a boundary that is not closed and manifold, and a model whose zero
    set misses the boundary nodes; put the free boundary nodes on it (``points`` in place).
    Returns the corner volumes and the boundary faces."""
    n = points.shape[0]
    volumes = corner_volumes(points, tets)
    if np.any(volumes < 0):
        worst = int(np.argmin(volumes))
        raise ValueError(
            f"tets must be positively oriented (VTK convention); cell {worst} has volume {volumes[worst]:.3g}"
        )
    try:
        neighbours = face_neighbours(tets, n)
    except ValueError as exc:
        raise ValueError(f"tets must form a solid: {exc}") from None
    faces = faces_on_boundary(tets, neighbours)
    reason = open_boundary_reason(faces, n)
    if reason:
        raise ValueError(f"tets must form a solid with a closed manifold boundary; {reason}")
    on_boundary = np.zeros(n, dtype=bool)
    on_boundary[faces.ravel()] = True
    boundary_nodes = np.flatnonzero(on_boundary & ~fixed_mask)
    distance = np.abs(model(points[boundary_nodes])) if boundary_nodes.size else np.zeros(0)
    if distance.size and distance.max() > MODEL_MISMATCH * h:
        far = boundary_nodes[int(np.argmax(distance))]
        raise ValueError(
            f"model does not match the mesh: boundary node {far} at {points[far].tolist()} is "
            f"{distance.max():.3g} from the model's zero set (more than {MODEL_MISMATCH:g} h = {MODEL_MISMATCH * h:.3g})"
        )
    if boundary_nodes.size:
        points[boundary_nodes] = model.project(points[boundary_nodes], iterations=20, tol=0.05 * (SURFACE_TOL * h), warn=False)
    return volumes, faces


class _SliverStage:
    """The quality stage's working mesh and its operations, each timed and counted."""

    def __init__(self, points, tets, model, h, fixed_mask, faces, targets: ShapeTargets, locked, labels, seed: int,
                 node_regions: tuple | None):
        n = points.shape[0]
        self.points, self.tets, self.model, self.h = points, tets, model, h
        self.targets, self.locked, self.labels = targets, locked, labels
        self.target = targets.min_dihedral  # the score of a cell that meets all three targets
        self.threshold = min(self.target + MARGIN, REGULAR_DIHEDRAL)
        self.surface_tol = SURFACE_TOL * h
        self.on_boundary = np.zeros(n, dtype=bool)
        self.on_boundary[faces.ravel()] = True
        used = np.bincount(tets.ravel(), minlength=n) > 0
        self.movable = used & ~fixed_mask
        self.rng = np.random.default_rng(seed)
        self.boundary_edges = _boundary_edge_keys(faces, n)
        self.boundary_face_keys = np.unique(face_keys(faces, n))
        self.guard = SurfaceGuard(model, h, points, self.on_boundary)
        self.guard.regions = node_regions
        self.tagged = {} if labels is None else {"labels": labels}
        self.quality = targets.score(points[tets])
        self.timings = {"relax": 0.0, "flip": 0.0, "smooth": 0.0}
        self.counts = {"flips": 0, "moves": 0, "relaxed": 0, "removed": 0, "collapses": 0, "filled": 0}
        self.filled = np.zeros(n, dtype=bool)  # pits' vertices made inner: never exposed again
        self.removable = None  # the vertices edge collapses may remove (improve_arrays(collapse=...))
        self.inner_collapses = False  # collapses may remove inner vertices too

    def timed(self, kind: str, function, *args, **kwargs):
        t0 = time.perf_counter()
        result = function(*args, **kwargs)
        self.timings[kind] += time.perf_counter() - t0
        return result

    def relax(self) -> None:
        self.points, self.quality, relaxed = self.timed(
            "relax", relax_round, self.points, self.tets, self.quality, self.target, self.movable, self.on_boundary,
            self.model, self.surface_tol, targets=self.targets, guard=self.guard, boundary_face_keys=self.boundary_face_keys,
        )
        self.counts["relaxed"] += relaxed

    def flip(self, active=None) -> tuple[int, np.ndarray]:
        """A flip round (of the cells near ``active`` vertices, or every bad cell); returns the
        flips made and the vertices they touched."""
        result = self.timed("flip", flip_round, self.points, self.tets, self.quality, self.threshold, self.boundary_edges,
                            active, targets=self.targets, **self.tagged)
        if self.labels is not None:
            self.tagged["labels"] = result[-1]
        self.tets, self.quality, flipped, touched = result[:4]
        return flipped, touched

    def removal(self, function, *args, **kwargs):
        result = self.timed("flip", function, *args, guard=self.guard, locked=self.locked, **kwargs)
        before, after = args[1], result[0 if function is remove_boundary_slivers else 1]
        if self.labels is not None and after.shape[0] != before.shape[0]:  # cells were removed, none added
            self.tagged["labels"] = self.tagged["labels"][_kept_rows(before, after)]
        return result

    def first_flips_and_relaxation(self) -> None:
        """Flip the worst slivers away and fill the pits first: they pin their vertices during
        relaxation (ur3_upperarm's crevice at D/50: 32.9 deg with its pit filled first, 20.2 when
        the fill waits for the rounds on the bad cells)."""
        flipped, _ = self.flip()
        self.counts["flips"] += flipped
        self.pit_fills()
        for _ in range(RELAX_ROUNDS):
            self.relax()

    def shape_rounds(self) -> None:
        """Flips that raise the radius ratio of the poorest cells free the relaxation, which had
        stopped at a fixed point of the old connectivity; repeated while the mean rises."""
        ratio = radius_ratio(self.points[self.tets])
        mean_ratio = float(ratio.mean())
        for _ in range(SHAPE_ROUNDS):
            result = self.timed(
                "flip", shape_flip_round, self.points, self.tets, self.quality, ratio, SHAPE_RATIO, self.threshold,
                self.boundary_edges, targets=self.targets, **self.tagged,
            )
            self.tets, self.quality, ratio, flipped = result[:4]
            if self.labels is not None:
                self.tagged["labels"] = result[4]
            self.counts["flips"] += flipped
            self.relax()
            ratio = radius_ratio(self.points[self.tets])
            gain = float(ratio.mean()) - mean_ratio
            mean_ratio += gain
            if gain < SHAPE_GAIN:
                break

    def target_round(self, active) -> tuple[int, np.ndarray | None]:
        """Flips, smoothing and boundary removals on the cells under the threshold; returns the
        number of changes and the vertices they touched."""
        flipped, touched = self.flip(active)
        # Smoothing retries every bad cell: its random candidates differ from round to round.
        self.points, self.quality, moved, moved_vertices = self.timed(
            "smooth", smooth_round, self.points, self.tets, self.quality, self.threshold, self.movable, self.on_boundary,
            self.model, self.h, self.rng, self.surface_tol, targets=self.targets, guard=self.guard,
            boundary_face_keys=self.boundary_face_keys,
        )
        self.tets, self.quality, removed, self.boundary_face_keys, self.boundary_edges = self.removal(
            remove_boundary_slivers, self.points, self.tets, self.quality, self.threshold, self.on_boundary,
            self.boundary_face_keys, self.boundary_edges, self.model, self.h,
        )
        surface_flips, flip_touched = self.boundary_flips()
        touched = touched | flip_touched
        (self.points, self.tets, self.quality, exposed, self.on_boundary, self.boundary_face_keys,
         self.boundary_edges) = self.removal(
            expose_shallow_vertices, self.points, self.tets, self.quality, self.threshold, self.on_boundary,
            self.movable & ~self.filled, self.boundary_face_keys, self.boundary_edges, self.model, self.h, self.surface_tol,
            targets=self.targets,
        )
        filled, fill_touched = self.pit_fills()
        self.counts["flips"] += flipped
        self.counts["moves"] += moved
        self.counts["removed"] += removed + exposed
        self.counts["flips"] += surface_flips
        return (flipped + moved + removed + exposed + surface_flips + filled,
                touched | moved_vertices | fill_touched)

    def pit_fills(self) -> tuple[int, np.ndarray]:
        """The pits at the bad cells filled (:func:`~fepre.distmesh.pit_fill.fill_pits`); returns
        the fills made and the vertices of the new cells."""
        result = self.timed(
            "flip", fill_pits, self.points, self.tets, self.quality, self.threshold, self.on_boundary, self.movable,
            self.boundary_face_keys, self.boundary_edges, targets=self.targets, guard=self.guard, locked=self.locked,
            **self.tagged)
        self.tets, self.quality, filled, self.boundary_face_keys, self.boundary_edges, touched = result[:6]
        if self.labels is not None:
            self.tagged["labels"] = result[6]
        self.filled |= filled
        count = int(filled.sum())
        self.counts["filled"] += count
        return count, touched

    def boundary_flips(self) -> tuple[int, np.ndarray]:
        """Boundary edge removals and collapses of short boundary edges around the bad cells
        (with labelled regions, each within one region: the faces between regions stay)."""
        result = self.timed(
            "flip", boundary_edge_round, self.points, self.tets, self.quality, self.threshold, self.on_boundary,
            self.boundary_face_keys, self.boundary_edges, targets=self.targets, guard=self.guard, locked=self.locked,
            **self.tagged)
        self.tets, self.quality, flips, self.boundary_face_keys, self.boundary_edges, touched = result[:6]
        if self.labels is not None:
            self.tagged["labels"] = result[6]
        if self.removable is None:
            return flips, touched
        result = self.timed(
            "flip", collapse_round, self.points, self.tets, self.quality, self.threshold, self.on_boundary,
            self.movable, self.removable, self.boundary_face_keys, self.boundary_edges, targets=self.targets,
            guard=self.guard, locked=self.locked, inner=self.inner_collapses, **self.tagged)
        self.tets, self.quality, collapses, self.boundary_face_keys, self.boundary_edges, collapsed = result[:6]
        if self.labels is not None:
            self.tagged["labels"] = result[6]
        self.counts["collapses"] += collapses
        return flips + collapses, touched | collapsed

    def target_rounds(self, maxiter: int, deadline: float | None, start: float) -> int:
        """Rounds until no cell is under the threshold, or the target holds and the worst angle
        stops rising (or ``POLISH_ROUNDS`` passed since it first held), or ``maxiter``; returns
        the rounds run."""
        rounds = 0
        best = float(self.quality.min())
        fewest = self._below_target()
        stalled = idle = 0
        met_at = None  # the round in which the target was first met
        active = None  # flips try every bad cell in the first round, then those near a change
        while rounds < maxiter and self.quality.min() < self.threshold:
            if deadline is not None and time.perf_counter() - start > deadline:
                break
            rounds += 1
            changes, touched = self.target_round(active)
            if changes == 0:
                if active is None:
                    break
                active = None  # one more round over every bad cell before giving up
                continue
            active = touched
            worst = float(self.quality.min())
            stalled = 0 if worst > best + PROGRESS else stalled + 1
            best = max(best, worst)
            if worst >= self.target:
                met_at = rounds if met_at is None else met_at
                if stalled >= PATIENCE or rounds - met_at >= POLISH_ROUNDS:
                    break
                continue
            below = self._below_target()
            idle = 0 if stalled == 0 or below < fewest else idle + 1
            fewest = min(fewest, below)
            if idle >= UNMET_PATIENCE:
                break
        return rounds

    def _below_target(self) -> int:
        return int(np.count_nonzero(self.quality < self.target))


def _report(stage: _SliverStage, before: dict[str, float], rounds: int, maxiter: int, start: float) -> dict:
    """The stage's ``info`` dict; warns when the targets were not met."""
    after = _extremes(stage.points, stage.tets)
    targets = stage.targets
    converged = bool(stage.quality.min() >= stage.target)
    info = {
        "seconds": time.perf_counter() - start,
        "relax_seconds": stage.timings["relax"],
        "flip_seconds": stage.timings["flip"],
        "smooth_seconds": stage.timings["smooth"],
        "rounds": rounds,
        **stage.counts,
        **{f"{key}_before": value for key, value in before.items()},
        **{f"{key}_after": value for key, value in after.items()},
        "converged": converged,
        **stage.tagged,
    }
    if not converged:
        warn_user(
            f"the quality stage reached a worst dihedral angle of {after['min_dihedral']:.2f} deg, a largest of "
            f"{after['max_dihedral']:.2f} deg and a smallest radius ratio of {after['min_radius_ratio']:.3f}, short of "
            f"min_dihedral={targets.min_dihedral:g} deg, max_dihedral={targets.max_dihedral:g} deg, "
            f"min_radius_ratio={targets.min_radius_ratio:g}, after {rounds} rounds (maxiter={maxiter}); "
            "returning the best mesh reached",
            ConvergenceWarning,
        )
    return info


def _kept_rows(before: np.ndarray, after: np.ndarray) -> np.ndarray:
    """(M,) bool: the rows of ``before`` still in ``after`` (``after`` is ``before`` with rows removed)."""
    rows = np.dtype((np.void, 4 * before.dtype.itemsize))
    return np.isin(np.ascontiguousarray(before).view(rows).ravel(), np.ascontiguousarray(after).view(rows).ravel())


def _verify(points, tets, quality, model, on_boundary, fixed_mask, h, volume_before, boundary_face_keys) -> None:
    """Check the stage's guarantees; a failure here is a bug, reported as MeshingError."""
    n = points.shape[0]
    volumes = corner_volumes(points, tets)
    if np.any(volumes <= 0) or np.any(quality <= 0):
        raise MeshingError(
            f"the quality stage produced {int(((volumes <= 0) | (quality <= 0)).sum())} cells of zero quality "
            f"({int((volumes <= 0).sum())} of them of non-positive volume)"
        )
    try:
        new_faces = faces_on_boundary(tets, face_neighbours(tets, n))
    except ValueError as exc:
        raise MeshingError(f"the quality stage broke the mesh topology: {exc}") from None
    if not np.array_equal(np.sort(face_keys(new_faces, n)), boundary_face_keys):
        raise MeshingError("the boundary surface's faces are not the expected ones")
    reason = open_boundary_reason(new_faces, n)
    if reason:
        raise MeshingError(f"the quality stage opened the boundary: {reason}")
    moved_boundary = np.flatnonzero(on_boundary & ~fixed_mask)
    if moved_boundary.size:
        off = np.abs(model(points[moved_boundary])).max()
        if off > 1e-3 * h:
            raise MeshingError(f"the quality stage left a boundary node {off:.3g} off the zero set (> 1e-3 h)")
    change = abs(float(volumes.sum()) - volume_before) / volume_before
    if change > 0.02:
        raise MeshingError(f"the quality stage changed the volume by {100 * change:.2f}% (> 2%)")
