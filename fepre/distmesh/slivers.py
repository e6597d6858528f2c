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
   with a boundary edge flip or the vertex projected onto the zero set.

The worst slivers are flipped first, then relaxation and shape flips lift the mean shape; then
the stage works on the cells scoring below ``min_dihedral + 8`` degrees: flips, smoothing and boundary
removals alternate until none is left, or the target holds and the worst angle stops rising (or
twenty rounds have passed since it first held), or ``maxiter`` rounds. Flips never touch
the boundary surface; boundary vertices only move along the zero set (re-projected, checked to
within ``1e-4 h``), on their own surface patch, along paths near the surface and keeping their
faces on it (:class:`~fepre.distmesh.surface_guard.SurfaceGuard`); fixed vertices never move; the end result is verified (positive cells,
closed manifold boundary, boundary vertices within ``1e-3 h`` of the zero set, volume within 2%
of the input's) and a violation raises :class:`fepre.MeshingError`.
"""

from __future__ import annotations

import time
from typing import Any, Callable

import numpy as np

from .._cell_kernels import corner_volumes
from ..arguments import finite_float, positive_float, positive_int
from ..errors import ConvergenceWarning, MeshingError, warn_user
from .boundary_slivers import expose_shallow_vertices, remove_boundary_slivers
from .flips import flip_round, shape_flip_round
from .smoothing import relax_round, smooth_round
from .surface_guard import SurfaceGuard
from .tet_shape import ShapeTargets, dihedral_extremes, radius_ratio
from .tet_topology import edge_keys, face_keys, face_neighbours, faces_on_boundary, open_boundary_reason

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
#: A regular tetrahedron's dihedral angle: no mesh can have a larger worst angle.
REGULAR_DIHEDRAL = float(np.degrees(np.arccos(1.0 / 3.0)))
#: Boundary vertices further than this (times h) from the zero set mean the model is not the
#: mesh's model.
MODEL_MISMATCH = 0.5


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
            f"min_dihedral must be in (0, {REGULAR_DIHEDRAL:.2f}) degrees (a regular tetrahedron's angle); got {min_dihedral!r}"
        )
    largest = DEFAULT_MAX_DIHEDRAL if max_dihedral is None else finite_float(max_dihedral, "max_dihedral")
    if not REGULAR_DIHEDRAL < largest < 180.0:
        raise ValueError(
            f"max_dihedral must be in ({REGULAR_DIHEDRAL:.2f}, 180) degrees (above a regular tetrahedron's angle); got {max_dihedral!r}"
        )
    ratio = DEFAULT_MIN_RADIUS_RATIO if min_radius_ratio is None else finite_float(min_radius_ratio, "min_radius_ratio")
    if not 0.0 < ratio < 1.0:
        raise ValueError(f"min_radius_ratio must be in (0, 1) (1 is a regular tetrahedron); got {min_radius_ratio!r}")
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

    Returns
    -------
    points, tets, info : the improved mesh (same points count and order; ``tets`` renewed) and a
        dict with ``seconds``, ``relax_seconds``, ``flip_seconds``, ``smooth_seconds``,
        ``rounds``, ``flips``, ``moves``, ``relaxed``, ``removed``, the worst figures before
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
    tagged = {} if labels is None else {"labels": labels}
    targets = _check_targets(min_dihedral, max_dihedral, min_radius_ratio)
    target = targets.min_dihedral  # the score of a cell that meets all three targets
    maxiter = DEFAULT_MAXITER if maxiter is None else positive_int(maxiter, "maxiter")
    deadline = None if deadline_seconds is None else positive_float(deadline_seconds, "deadline_seconds")
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
    surface_tol = 1e-4 * h
    if boundary_nodes.size:
        points[boundary_nodes] = model.project(points[boundary_nodes], iterations=20, tol=0.05 * surface_tol, warn=False)
    used = np.bincount(tets.ravel(), minlength=n) > 0
    movable = used & ~fixed_mask
    rng = np.random.default_rng(seed)
    boundary_edges = _boundary_edge_keys(faces, n)
    boundary_face_keys = np.unique(face_keys(faces, n))
    guard = SurfaceGuard(model, h, points, on_boundary)
    guard.regions = node_regions
    threshold = min(target + MARGIN, REGULAR_DIHEDRAL)
    volume_before = float(volumes.sum())

    quality = targets.score(points[tets])
    before = _extremes(points, tets)
    timings = {"relax": 0.0, "flip": 0.0, "smooth": 0.0}
    counts = {"flips": 0, "moves": 0, "relaxed": 0, "removed": 0}

    def timed(kind: str, function, *args, **kwargs):
        t0 = time.perf_counter()
        result = function(*args, **kwargs)
        timings[kind] += time.perf_counter() - t0
        return result

    def relax(quality):
        return timed(
            "relax", relax_round, points, tets, quality, target, movable, on_boundary, model, surface_tol,
            targets=targets, guard=guard, boundary_face_keys=boundary_face_keys,
        )

    def flip(*args, **kwargs):
        result = timed("flip", flip_round, *args, targets=targets, **tagged, **kwargs)
        if labels is not None:
            tagged["labels"] = result[-1]
        return result[:4]

    def removal(function, *args, **kwargs):
        result = timed("flip", function, *args, guard=guard, locked=locked, **kwargs)
        before, after = args[1], result[0 if function is remove_boundary_slivers else 1]
        if labels is not None and after.shape[0] != before.shape[0]:  # cells were removed, none added
            tagged["labels"] = tagged["labels"][_kept_rows(before, after)]
        return result

    # Flip the worst slivers away first: they pin their vertices during relaxation.
    tets, quality, flipped, _ = flip(points, tets, quality, threshold, boundary_edges)
    counts["flips"] += flipped
    for _ in range(RELAX_ROUNDS):
        points, quality, relaxed = relax(quality)
        counts["relaxed"] += relaxed

    # Shape rounds: flips that raise the radius ratio of the poorest cells free the relaxation,
    # which had stopped at a fixed point of the old connectivity; repeat while the mean rises.
    ratio = radius_ratio(points[tets])
    mean_ratio = float(ratio.mean())
    for _ in range(SHAPE_ROUNDS):
        result = timed(
            "flip", shape_flip_round, points, tets, quality, ratio, SHAPE_RATIO, threshold, boundary_edges,
            targets=targets, **tagged,
        )
        tets, quality, ratio, flipped = result[:4]
        if labels is not None:
            tagged["labels"] = result[4]
        counts["flips"] += flipped
        points, quality, relaxed = relax(quality)
        counts["relaxed"] += relaxed
        ratio = radius_ratio(points[tets])
        gain = float(ratio.mean()) - mean_ratio
        mean_ratio += gain
        if gain < SHAPE_GAIN:
            break

    rounds = 0
    best = float(quality.min())
    stalled = 0
    met_at = None  # the round in which the target was first met
    active = None  # flips try every bad cell in the first round, then those near a change
    while rounds < maxiter and quality.min() < threshold:
        if deadline is not None and time.perf_counter() - start > deadline:
            break
        rounds += 1
        tets, quality, flipped, touched = flip(points, tets, quality, threshold, boundary_edges, active)
        # Smoothing retries every bad cell: its random candidates differ from round to round.
        points, quality, moved, moved_vertices = timed(
            "smooth", smooth_round, points, tets, quality, threshold, movable, on_boundary, model, h, rng,
            surface_tol, targets=targets, guard=guard, boundary_face_keys=boundary_face_keys,
        )
        tets, quality, removed, boundary_face_keys, boundary_edges = removal(
            remove_boundary_slivers, points, tets, quality, threshold, on_boundary, boundary_face_keys,
            boundary_edges, model, h,
        )
        points, tets, quality, exposed, on_boundary, boundary_face_keys, boundary_edges = removal(
            expose_shallow_vertices, points, tets, quality, threshold, on_boundary, movable,
            boundary_face_keys, boundary_edges, model, h, surface_tol, targets=targets,
        )
        counts["flips"] += flipped
        counts["moves"] += moved
        counts["removed"] += removed + exposed
        if flipped == 0 and moved == 0 and removed == 0 and exposed == 0:
            if active is None:
                break
            active = None  # one more round over every bad cell before giving up
            continue
        active = touched | moved_vertices
        worst = float(quality.min())
        stalled = 0 if worst > best + PROGRESS else stalled + 1
        best = max(best, worst)
        if worst >= target:
            met_at = rounds if met_at is None else met_at
            if stalled >= PATIENCE or rounds - met_at >= POLISH_ROUNDS:
                break

    _verify(points, tets, quality, model, on_boundary, fixed_mask, h, volume_before, boundary_face_keys)
    after = _extremes(points, tets)
    converged = bool(quality.min() >= target)
    info = {
        "seconds": time.perf_counter() - start,
        "relax_seconds": timings["relax"],
        "flip_seconds": timings["flip"],
        "smooth_seconds": timings["smooth"],
        "rounds": rounds,
        **counts,
        **{f"{key}_before": value for key, value in before.items()},
        **{f"{key}_after": value for key, value in after.items()},
        "converged": converged,
        **tagged,
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
    return points, tets, info


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
