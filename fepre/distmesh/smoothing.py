"""Vertex smoothing that never inverts a cell: each move is accepted only if it helps its star.

For every movable vertex of a bad cell, a handful of candidate positions are evaluated at once
(the average of the positions that would make each cell of its star regular, the same for the
worst cell alone, at several step lengths, and small seeded random steps). Boundary vertices'
candidates are projected back onto the model's zero set and must pass the
:class:`~fepre.distmesh.surface_guard.SurfaceGuard` (own patch, path and faces on the surface).
A vertex moves to its best candidate when that raises the smallest score
(:class:`~fepre.distmesh.tet_shape.ShapeTargets`: the worst of the smallest and largest dihedral
angle and the radius ratio) of its star; vertices that share a cell never move in the same pass
(:func:`smooth_round`).

:func:`relax_round` moves every vertex at once towards the mean of its cells' ideal positions
and undoes the moves that make a cell worse than allowed (or that the guard refuses); it raises
the mean shape quality.
"""

from __future__ import annotations

import numpy as np

from .surface_guard import SurfaceGuard, boundary_faces_of_cells, folding_vertices
from .tet_shape import ShapeTargets, ideal_vertex_positions
from .tet_topology import FACE_OF_TET, face_keys, in_sorted, vertex_stars

__all__ = ["smooth_round", "relax_round"]

#: A move must raise the worst angle of the star by at least this (degrees).
MIN_GAIN = 1e-3
#: Step lengths towards the target positions.
STEPS = (1.0, 0.5, 0.25, 0.1)
#: Random step lengths, times h, and how many random directions per length.
RANDOM_STEPS = (0.03, 0.1, 0.2)
RANDOM_DIRECTIONS = 3
#: Largest number of passes that grow the set of vertices moving together.
INDEPENDENT_PASSES = 8


def _segment_ids(counts: np.ndarray) -> np.ndarray:
    return np.repeat(np.arange(counts.size), counts)


def _star_boundary_faces(tets, cells, local, segment, vertices, boundary_face_keys, n_points):
    """The boundary faces around each star's vertex.

    ``cells`` (S,) are the star cells grouped by vertex segment, ``local`` the vertex's position
    in each. Returns the faces (F, 3) (outward), the segment of each (F,), sorted, and the
    position (F,) of the segment's vertex in it.
    """
    rows = np.repeat(np.arange(cells.size), 3)
    opposite = ((local[:, None] + np.arange(1, 4)) % 4).ravel()  # faces opposite these hold the vertex
    faces = tets[cells[rows][:, None], FACE_OF_TET[opposite]]
    on_surface = in_sorted(face_keys(faces, n_points), boundary_face_keys)
    faces, rows = faces[on_surface], rows[on_surface]
    face_segment = segment[rows]
    position = np.argmax(faces == vertices[face_segment][:, None], axis=1)
    return faces, face_segment, position


def _guarded(points, vertices, candidates, pairs, guard, faces, face_segment, position):
    """Mask over ``pairs`` (candidate row, vertex index) of the boundary moves ``guard`` allows:
    the vertex stays on its patch and its boundary faces stay on the surface."""
    c, j = pairs
    allowed = guard.moves_allowed(vertices[j], points[vertices[j]], candidates[c, j])
    check = np.flatnonzero(allowed)
    if check.size == 0 or faces.shape[0] == 0:
        return allowed
    counts = np.bincount(face_segment, minlength=vertices.size)
    starts = np.cumsum(counts) - counts
    per_pair = counts[j[check]]
    pair_of_face = np.repeat(check, per_pair)
    offset = np.arange(pair_of_face.size) - np.repeat(np.cumsum(per_pair) - per_pair, per_pair)
    face = starts[j[pair_of_face]] + offset
    old = points[faces[face]]
    new = old.copy()
    new[np.arange(face.size), position[face]] = candidates[c[pair_of_face], j[pair_of_face]]
    refused = ~guard.faces_allowed(old, new)
    allowed[np.unique(pair_of_face[refused])] = False
    return allowed


def _independent_moves(n_cells, cells, segment, seg_starts, improving, current, best):
    """Mask of the improving vertices that move together: no two share a cell.

    Worst stars first, and among the vertices of one bad cell (equal ``current``) the one
    reaching the best star; a vertex is taken when it has the highest priority on every cell
    of its star among the vertices still free, in passes until none is left (a maximal set).
    """
    rank = np.full(improving.size, np.iinfo(np.int64).max)
    order = np.flatnonzero(improving)[np.lexsort((-best[improving], current[improving]))]
    rank[order] = np.arange(order.size)
    free = improving.copy()
    selected = np.zeros_like(improving)
    for _ in range(INDEPENDENT_PASSES):
        holder = np.full(n_cells, np.iinfo(np.int64).max)
        entries = free[segment]
        np.minimum.at(holder, cells[entries], rank[segment[entries]])
        owns = holder[cells] == rank[segment]
        taken = free & np.logical_and.reduceat(owns, seg_starts)
        if not taken.any():
            break
        selected |= taken
        blocked = np.zeros(n_cells, dtype=bool)
        blocked[cells[taken[segment]]] = True
        free &= ~np.logical_or.reduceat(blocked[cells], seg_starts)
        if not free.any():
            break
    return selected


def smooth_round(
    points: np.ndarray,
    tets: np.ndarray,
    quality: np.ndarray,
    threshold: float,
    movable: np.ndarray,
    on_boundary: np.ndarray,
    model,
    h: float,
    rng: np.random.Generator,
    surface_tol: float,
    active: np.ndarray | None = None,
    *,
    targets: ShapeTargets | None = None,
    guard: SurfaceGuard | None = None,
    boundary_face_keys: np.ndarray | None = None,
) -> tuple[np.ndarray, np.ndarray, int, np.ndarray]:
    """Move the movable vertices of cells scoring below ``threshold`` to better positions.

    Parameters
    ----------
    points, tets, quality : the mesh and each cell's score (``targets.score``, degrees)
    threshold : cells below this score are improved
    movable : (N,) bool, vertices allowed to move
    on_boundary : (N,) bool, vertices that must stay on the model's zero set
    model : the SDF, used to project boundary candidates
    h : target edge length (scales the random steps)
    rng : random generator for the random candidates
    surface_tol : largest ``|model|`` accepted at a moved boundary vertex
    active : (N,) bool, optional
        Only bad cells with an active vertex are tried; all bad cells when None.
    targets : ShapeTargets, optional
        The score (default targets).
    guard : SurfaceGuard, optional
        Checks boundary moves (with ``boundary_face_keys``, the sorted keys of the boundary
        faces); without it boundary vertices only have to stay on the zero set.

    Returns
    -------
    points, quality : updated copies
    moved : number of vertices moved
    touched : (N,) bool, the moved vertices
    """
    targets = ShapeTargets() if targets is None else targets
    touched = np.zeros(points.shape[0], dtype=bool)
    bad = np.flatnonzero(quality < threshold)
    if active is not None:
        bad = bad[active[tets[bad]].any(axis=1)]
    if bad.size == 0:
        return points, quality, 0, touched
    vertices = np.unique(tets[bad])
    vertices = vertices[movable[vertices]]
    if vertices.size == 0:
        return points, quality, 0, touched
    selected_vertex = np.zeros(points.shape[0], dtype=bool)
    selected_vertex[vertices] = True
    region = np.flatnonzero(selected_vertex[tets].any(axis=1))
    offsets, star_cells = vertex_stars(tets[region], points.shape[0])
    star_cells = region[star_cells]
    counts = offsets[vertices + 1] - offsets[vertices]
    segment = _segment_ids(counts)
    starts = np.repeat(offsets[vertices], counts)
    position_in_segment = np.arange(segment.size) - np.repeat(np.cumsum(counts) - counts, counts)
    cells = star_cells[starts + position_in_segment]  # (S,) star cells, grouped by vertex
    cell_vertices = tets[cells]
    local = np.argmax(cell_vertices == vertices[segment][:, None], axis=1)
    seg_starts = np.cumsum(counts) - counts
    current = np.minimum.reduceat(quality[cells], seg_starts)

    x = points[vertices]
    ideal = ideal_vertex_positions(points, cell_vertices)[local, :, np.arange(local.size)]  # (S, 3)
    mean_ideal = np.stack([np.bincount(segment, ideal[:, k], minlength=x.shape[0]) for k in range(3)], 1)
    mean_ideal /= counts[:, None]
    # The ideal position for the worst cell of each star.
    worst_in_star = np.lexsort((quality[cells], segment))[seg_starts]
    worst_ideal = ideal[worst_in_star]
    candidates = [x + step * (mean_ideal - x) for step in STEPS]
    candidates += [x + step * (worst_ideal - x) for step in STEPS]
    for length in RANDOM_STEPS:
        direction = rng.normal(size=(RANDOM_DIRECTIONS, vertices.size, 3))
        direction /= np.linalg.norm(direction, axis=2, keepdims=True)
        candidates += list(x + length * h * direction)
    candidates = np.stack(candidates)  # (C, V, 3)
    boundary = on_boundary[vertices]
    feasible = np.ones(candidates.shape[:2], dtype=bool)
    if boundary.any():
        flat = candidates[:, boundary].reshape(-1, 3)
        projected = model.project(flat, iterations=4, warn=False)
        candidates[:, boundary] = projected.reshape(candidates.shape[0], -1, 3)
        off = np.abs(model(projected)).reshape(candidates.shape[0], -1) > surface_tol
        feasible[:, boundary] = ~off

    corners = points[cell_vertices]  # (S, 4, 3)
    trial = np.broadcast_to(corners, (candidates.shape[0],) + corners.shape).copy()
    trial[:, np.arange(segment.size), local] = candidates[:, segment]
    trial_quality = targets.score(trial)  # (C, S)
    star_worst = np.minimum.reduceat(trial_quality, seg_starts, axis=1)  # (C, V)
    star_worst = np.where(feasible, star_worst, -2.0)
    if guard is not None and boundary.any():
        pairs = np.nonzero((star_worst > current + MIN_GAIN) & boundary)
        if pairs[0].size:
            faces = _star_boundary_faces(tets, cells, local, segment, vertices, boundary_face_keys, points.shape[0])
            allowed = _guarded(points, vertices, candidates, pairs, guard, *faces)
            star_worst[pairs[0][~allowed], pairs[1][~allowed]] = -2.0
    choice = np.argmax(star_worst, axis=0)
    best = star_worst[choice, np.arange(vertices.size)]
    improving = best > current + MIN_GAIN
    if not improving.any():
        return points, quality, 0, touched

    selected = _independent_moves(tets.shape[0], cells, segment, seg_starts, improving, current, best)
    old_points, points, quality = points, points.copy(), quality.copy()
    points[vertices[selected]] = candidates[choice[selected], np.flatnonzero(selected)]
    entries = selected[segment]
    quality[cells[entries]] = trial_quality[choice[segment[entries]], np.flatnonzero(entries)]
    keys = None if guard is None else boundary_face_keys
    moved = _undo_folds(old_points, points, quality, tets, vertices[selected], on_boundary, keys, targets)
    touched[moved] = True
    return points, quality, int(moved.size), touched


def _undo_folds(old_points, points, quality, tets, moved, on_boundary, boundary_face_keys, targets) -> np.ndarray:
    """Put back (in ``points`` and ``quality``, in place) the moved boundary vertices whose
    faces cross another boundary face (:func:`~fepre.distmesh.surface_guard.folding_vertices`),
    until none does; returns the vertices still moved (all of them without ``boundary_face_keys``)."""
    while boundary_face_keys is not None:
        folds = folding_vertices(old_points, points, boundary_face_keys, moved[on_boundary[moved]])
        if folds.size == 0:
            return moved
        points[folds] = old_points[folds]
        back = np.zeros(points.shape[0], dtype=bool)
        back[folds] = True
        cells = np.flatnonzero(back[tets].any(axis=1))
        quality[cells] = targets.score(points[tets[cells]])
        moved = moved[~back[moved]]
    return moved


def relax_round(
    points: np.ndarray,
    tets: np.ndarray,
    quality: np.ndarray,
    floor: float,
    movable: np.ndarray,
    on_boundary: np.ndarray,
    model,
    surface_tol: float,
    step: float = 1.0,
    *,
    targets: ShapeTargets | None = None,
    guard: SurfaceGuard | None = None,
    boundary_face_keys: np.ndarray | None = None,
) -> tuple[np.ndarray, np.ndarray, int]:
    """Move every movable vertex towards the mean of its cells' ideal positions at once.

    This raises the mean shape quality of the whole mesh. All vertices move together; then
    every cell whose score (``targets.score``) fell below ``min(old score, floor)`` gets its
    vertices put back, until no such cell remains, so no cell ever inverts and no cell below
    ``floor`` gets worse. With a ``guard`` (and ``boundary_face_keys``), boundary moves it
    refuses are put back too, and so are the vertices of boundary faces it refuses and the
    moved boundary vertices of faces that cross another boundary face.

    Returns
    -------
    points, quality : updated copies
    moved : number of vertices moved
    """
    targets = ShapeTargets() if targets is None else targets
    n = points.shape[0]
    ideal = ideal_vertex_positions(points, tets)  # (4, 3, M)
    owner = tets.T.ravel()
    target = np.stack([np.bincount(owner, ideal[:, axis].ravel(), minlength=n) for axis in range(3)], 1)
    count = np.bincount(tets.ravel(), minlength=n)
    target /= np.maximum(count, 1)[:, None]
    moving = movable & (count > 0)
    new_points = points.copy()
    new_points[moving] += step * (target[moving] - points[moving])
    boundary = np.flatnonzero(moving & on_boundary)
    if boundary.size:
        new_points[boundary] = model.project(new_points[boundary], iterations=4, warn=False)
        off = np.abs(model(new_points[boundary])) > surface_tol
        if guard is not None:
            off[~off] = ~guard.moves_allowed(boundary[~off], points[boundary[~off]], new_points[boundary[~off]])
        new_points[boundary[off]] = points[boundary[off]]
    allowed = np.minimum(quality, floor)
    changed = np.any(new_points != points, axis=1)
    check = np.flatnonzero(changed[tets].any(axis=1))
    new_quality = quality.copy()
    while check.size:
        q = targets.score(new_points[tets[check]])
        new_quality[check] = q
        worse = q < allowed[check] - 1e-12
        revert = np.unique(tets[check[worse]])
        if guard is not None:
            faces, _ = boundary_faces_of_cells(tets, check, boundary_face_keys, n, on_boundary)
            faces = faces[changed[faces].any(axis=1)]
            refused = ~guard.faces_allowed(points[faces], new_points[faces])
            revert = np.union1d(revert, faces[refused].ravel())
            if boundary.size and not revert.size:  # the boundary must not fold over itself
                revert = folding_vertices(points, new_points, boundary_face_keys, boundary[changed[boundary]])
        revert = revert[changed[revert]]
        if revert.size == 0:
            break
        new_points[revert] = points[revert]
        changed[revert] = False
        touched = np.zeros(n, dtype=bool)
        touched[revert] = True
        check = np.flatnonzero(touched[tets].any(axis=1))
    return new_points, new_quality, int(changed.sum())
