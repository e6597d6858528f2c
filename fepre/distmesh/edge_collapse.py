"""Edge collapse: a vertex crowding its neighbour on the surface removed.

Two boundary vertices far closer than h (0.2 h on a faceted model, where two pieces of the
surface meet at a crease that the mesh does not keep, or where the loop left a pair) make every
cell on their short edge flat, and no flip or move repairs it: the vertices are where the
surface needs vertices, one too many. :func:`collapse_round` removes one of them: the vertex
``v`` of a short boundary edge ``uv`` of a bad cell joins ``u``; the cells holding both go, the
others take ``u`` for ``v``. A collapse is kept only when

* ``v`` may be removed (not a fixed point or feature node, not locked) and every changed cell
  stays positively oriented;
* it raises the worst score of the cells it changes or removes;
* the mesh stays a solid around ``u``: no face of ``u``'s new cells is used more than twice,
  no two of them are the same cell, the boundary surface keeps the link condition (``u`` and
  ``v`` share exactly the two surface neighbours of the faces on ``uv``) and every boundary face
  that changes stays on the surface
  (:meth:`~fepre.distmesh.surface_guard.SurfaceGuard.faces_allowed`).

A *flap* is removed first, whatever its edges' lengths: a bad cell with three boundary faces,
whose common vertex (the apex) is in no other cell. Its faces fold the surface over itself where
the part is thinner than h (teapot.obj's spout tip at D/50, under a flat hole fill 0.4-0.8 h from
the wall: flaps of 3.0-4.6 deg with edges 0.5-0.8 of their longest and the apex pinned as a crease
node, its folded faces' normals disagreeing). The apex goes with the cell and the face under it
becomes a boundary face again (:func:`_remove_star`: the surface guard judges the one new face
against the three it replaces), even when the apex is pinned on a crease: no vertex moves onto
or along the crease.

The collapses of a round are tried one after the other, so each sees the mesh the previous one
left; a round holds as many as there are flaps and bad cells with a short boundary edge (a handful).
"""

from __future__ import annotations

import numpy as np

from .surface_guard import SurfaceGuard
from .tet_shape import ShapeTargets, signed_volume
from .tet_topology import EDGE_OF_TET, FACE_OF_TET, cells_around, edge_keys, face_keys, in_sorted, vertex_stars
from .topology import nonmanifold_items

__all__ = ["collapse_round", "SHORT_EDGE"]

#: A boundary edge shorter than this fraction of its bad cell's longest edge may be collapsed.
SHORT_EDGE = 0.4
#: The same in the second series of insertions, with inner collapses (fertility at (D/50, D/12) in one
#: order of ties: a boundary face's apex 0.45 of its cell's longest edge from one end, on the line of the others)
SHORT_EDGE_RESHAPING = 0.5
#: A collapse must raise the worst score of the cells it touches by at least this (degrees).
MIN_GAIN = 1e-3
#: The local faces of a cell, each opposite the vertex of the same index.
_OPPOSITE = np.array([[1, 2, 3], [0, 2, 3], [0, 1, 3], [0, 1, 2]])


def _short_edges(points, tets, quality, threshold, on_boundary, inner: bool) -> np.ndarray:
    """The short edges (K, 2) of the bad cells, shortest relative edge first: between two
    boundary vertices, and with ``inner`` those with an inner vertex at one end at least."""
    bad = np.flatnonzero(quality < threshold)
    if bad.size == 0:
        return np.zeros((0, 2), dtype=np.int64)
    pairs = tets[bad][:, EDGE_OF_TET]  # (B, 6, 2)
    length = np.linalg.norm(points[pairs[..., 0]] - points[pairs[..., 1]], axis=2)
    relative = length / length.max(axis=1, keepdims=True)
    # a boundary edge of a cell with only two boundary vertices is an inner cell's: left alone
    both = on_boundary[pairs].all(axis=2) & (on_boundary[tets[bad]].sum(axis=1) >= 2)[:, None]
    limit = SHORT_EDGE_RESHAPING if inner else SHORT_EDGE
    short = (relative < limit) & (both | (inner & ~on_boundary[pairs].all(axis=2)))
    edges, relative = np.sort(pairs[short], axis=1), relative[short]
    edges, first = np.unique(edges, axis=0, return_index=True)
    return edges[np.argsort(relative[first], kind="stable")]


def _flap_apexes(points, corners, keys) -> np.ndarray:
    """The flaps among cells ``corners`` (C, 4): cells with three boundary faces, whose common
    vertex (the apex, opposite the one inner face) is in no other cell on a manifold boundary.
    Returns (K, 2): each flap's apex and its nearest corner (the collapse that removes the apex
    with its cell, :func:`_remove_star`)."""
    n = points.shape[0]
    on = np.stack([in_sorted(face_keys(corners[:, _OPPOSITE[k]], n), keys) for k in range(4)], axis=1)
    flap = np.flatnonzero(on.sum(axis=1) == 3)
    if flap.size == 0:
        return np.zeros((0, 2), dtype=np.int64)
    cells = corners[flap]
    rows = np.arange(flap.size)
    apex_local = np.argmin(on[flap], axis=1)
    apex = cells[rows, apex_local]
    length = np.linalg.norm(points[cells] - points[apex][:, None], axis=2)
    length[rows, apex_local] = np.inf
    return np.stack([apex, cells[rows, np.argmin(length, axis=1)]], axis=1)


class _CellsOf:
    """The cells holding given vertices, sorted (the cells' corners sorted by vertex once): the
    stars of a round's candidate collapses without a scan of every cell per candidate (28,200
    candidates on teapot.obj at D/50 scanned 50k cells each: 38 s of a 82 s mesh)."""

    def __init__(self, tets: np.ndarray, n: int) -> None:
        self.starts, self.cells = vertex_stars(tets, n)

    def __call__(self, vertices) -> np.ndarray:
        return np.unique(cells_around(self.starts, self.cells, vertices)[0])


def _gates_passed(points, tets, quality, pairs: np.ndarray, targets: ShapeTargets, cells_of: _CellsOf) -> np.ndarray:
    """(K,) bool: whether collapsing ``pairs[k, 1]`` into ``pairs[k, 0]`` passes the first two
    gates of :func:`_try_collapse` (every changed cell positive, the worst score raised by
    ``MIN_GAIN``), for all pairs at once; True where every cell of the removed vertex holds the
    kept one too (the star's removal, judged by its own tests). Most candidates of a round fail
    these gates, round after round on the same cells: tried one by one, they were 15 of the
    60 s octagonal_pocket.stl takes at D/25 (27,800 tries, 24,000 failing here).
    """
    if len(pairs) == 0:
        return np.zeros(0, dtype=bool)
    keep, gone = pairs[:, 0], pairs[:, 1]
    star, owner = cells_around(cells_of.starts, cells_of.cells, gone)
    candidate = np.repeat(np.arange(len(pairs)), np.diff(cells_of.starts)[gone])
    holds_keep = (tets[star] == keep[candidate][:, None]).any(axis=1)
    passed = np.ones(len(pairs), dtype=bool)
    changed = ~holds_keep
    if not changed.any():
        return passed
    new = tets[star[changed]]
    new = np.where(new == owner[changed][:, None], keep[candidate[changed]][:, None], new)
    which = candidate[changed]
    # the worst score of the removed vertex's cells, per candidate
    before = np.full(len(pairs), np.inf)
    np.minimum.at(before, candidate, quality[star])
    flat = np.zeros(len(pairs), dtype=bool)
    flat[which[signed_volume(points[new]) <= 0]] = True
    after = np.full(len(pairs), np.inf)
    np.minimum.at(after, which, targets.score(points[new]))
    has_changed = np.zeros(len(pairs), dtype=bool)
    has_changed[which] = True
    passed[has_changed] = ~flat[has_changed] & (after[has_changed] > before[has_changed] + MIN_GAIN)
    return passed


def _surface_neighbours(faces: np.ndarray, vertex: int) -> set:
    return set(faces[(faces == vertex).any(axis=1)].ravel().tolist()) - {vertex}


def _boundary_faces_of(tets: np.ndarray, cells: np.ndarray, keys: np.ndarray, n: int) -> np.ndarray:
    """The boundary faces (outward) of ``cells``, given the sorted ``keys`` of the boundary faces."""
    faces = tets[cells][:, FACE_OF_TET].reshape(-1, 3)
    return faces[in_sorted(face_keys(faces, n), keys)]


def _try_collapse(points, tets, quality, u, v, keys, targets: ShapeTargets, guard: SurfaceGuard, cells_of: _CellsOf):
    """The cells after collapsing ``v`` into ``u``, their scores and the boundary faces before and
    after around them, or None when not allowed."""
    n = points.shape[0]
    star_v, star_u = cells_of(v), cells_of(u)
    both = (tets[star_v] == u).any(axis=1)
    removed, changed = star_v[both], star_v[~both]
    if changed.size == 0:  # every cell of v holds u: v goes with its cells
        faces = _boundary_faces_of(tets, np.union1d(star_u, star_v), keys, n)
        return _remove_star(points, tets, removed, v, faces, keys, guard, cells_of)
    new = tets[changed].copy()
    new[new == v] = u
    if (signed_volume(points[new]) <= 0).any():
        return None
    new_quality = targets.score(points[new])
    if new_quality.min() <= quality[star_v].min() + MIN_GAIN:
        return None
    faces = _boundary_faces_of(tets, np.union1d(star_u, star_v), keys, n)
    inner = not (faces == v).any()
    # the link condition on the surface: u and v share exactly the apexes of the two faces on uv
    on_uv = faces[((faces == u) | (faces == v)).sum(axis=1) == 2]
    if not inner and (on_uv.shape[0] != 2 or _surface_neighbours(faces, u) & _surface_neighbours(faces, v)
                      != set(on_uv.ravel().tolist()) - {u, v}):
        return None
    keep_u = np.setdiff1d(star_u, removed)
    around = np.concatenate([tets[keep_u], new])
    if np.unique(np.sort(around, axis=1), axis=0).shape[0] != around.shape[0]:
        return None
    codes, uses = np.unique(face_keys(around[:, FACE_OF_TET].reshape(-1, 3), n), return_counts=True)
    if uses.max() > 2:
        return None
    if inner:
        return _inner_collapse(tets, np.union1d(star_u, star_v), codes[uses == 1], removed, changed, new,
                               new_quality, n)
    # the boundary faces that move with v stay on the surface
    moved = faces[(faces == v).any(axis=1) & ~(faces == u).any(axis=1)]
    after = moved.copy()
    after[after == v] = u
    if moved.shape[0] and not guard.faces_allowed(points[moved], points[after]).all():
        return None
    gone = faces[(faces == v).any(axis=1)]
    if not _boundary_as_kept(tets, removed, changed, new, around, keys, gone, after, n, cells_of):
        return None
    return removed, changed, new, new_quality, gone, after


def _boundary_as_kept(tets, removed, changed, new, around, keys, gone, after, n: int, cells_of: _CellsOf) -> bool:
    """True when the faces of ``u``'s new cells that are used once (counted over every cell
    touching them) are exactly those the collapse's bookkeeping keeps as boundary faces. A boundary
    vertex with three surface neighbours joined into one of them can leave its last face inside
    (on camelhead at (D/50, D/12): the stage then refused its own result and returned DistMesh's
    0.5 deg mesh)."""
    ring = cells_of(np.unique(around))
    replaced = np.full(tets.shape[0], -1)
    replaced[changed] = np.arange(changed.size)
    ring = ring[~np.isin(ring, removed)]
    cells = np.where((replaced[ring] >= 0)[:, None], new[np.maximum(replaced[ring], 0)], tets[ring])
    codes, uses = np.unique(face_keys(cells[:, FACE_OF_TET].reshape(-1, 3), n), return_counts=True)
    mine = np.unique(face_keys(around[:, FACE_OF_TET].reshape(-1, 3), n))
    used_once = mine[uses[np.searchsorted(codes, mine)] == 1]
    kept = np.union1d(np.setdiff1d(keys, face_keys(gone, n)), face_keys(after, n))
    return np.array_equal(used_once, mine[in_sorted(mine, kept)])


def _inner_collapse(tets, stars, shell, removed, changed, new, new_quality, n: int):
    """The collapse of an inner vertex ``v`` (on no boundary face) into ``u``: allowed when the
    cells around ``u`` afterwards (their faces used once: ``shell``) fill exactly the region the
    ``stars`` of ``u`` and ``v`` filled, so the boundary and every other cell stay as they were."""
    codes, uses = np.unique(face_keys(tets[stars][:, FACE_OF_TET].reshape(-1, 3), n), return_counts=True)
    if not np.array_equal(codes[uses == 1], shell):
        return None
    empty = np.zeros((0, 3), dtype=tets.dtype)
    return removed, changed, new, new_quality, empty, empty


def _remove_star(points, tets, removed, v, faces, keys, guard: SurfaceGuard, cells_of: _CellsOf):
    """Removing the cells of ``v`` when each holds ``u`` too: allowed when the faces it exposes
    (those opposite ``v``) are inner faces now, lie on the surface, every edge of theirs ends up
    on exactly two boundary faces and no vertex of the cells is pinched."""
    n = points.shape[0]
    cells = tets[removed]
    local = np.argmax(cells == v, axis=1)
    exposed = cells[np.arange(cells.shape[0])[:, None], FACE_OF_TET[local]][:, ::-1]  # outward once the cells go
    exposed_keys = face_keys(exposed, n)
    if in_sorted(exposed_keys, keys).any() or np.unique(exposed_keys).size != exposed_keys.size:
        return None
    gone = faces[(faces == v).any(axis=1)]
    if not guard.replacements_allowed(points[gone][None], points[exposed][None])[0]:
        return None
    near = np.setdiff1d(cells_of(np.unique(cells)), removed)
    new_keys = np.union1d(np.setdiff1d(keys, face_keys(gone, n)), exposed_keys)
    surface = _boundary_faces_of(tets, near, new_keys, n)
    edges = np.sort(surface[:, [0, 1, 1, 2, 2, 0]].reshape(-1, 2), axis=1)
    codes, uses = np.unique(edges[:, 0] * n + edges[:, 1], return_counts=True)
    wanted = np.sort(exposed[:, [0, 1, 1, 2, 2, 0]].reshape(-1, 2), axis=1)
    wanted = wanted[:, 0] * n + wanted[:, 1]
    if not in_sorted(wanted, codes).all() or (uses[np.searchsorted(codes, wanted)] != 2).any():
        return None
    # no vertex of the removed cells is left with two fans of boundary faces (a pinch: on a 14
    # deg prism's knife edge, u took the fan of v on the other face of the knife)
    if np.isin(nonmanifold_items(surface, n)[1], cells).any():
        return None
    return removed, np.zeros(0, dtype=np.int64), np.zeros((0, 4), dtype=tets.dtype), np.zeros(0), gone, exposed


def _gate_verdicts(points, tets, quality, tries: list, targets: ShapeTargets, cells_of: _CellsOf) -> dict:
    """``{(keep, gone): passed}`` of :func:`_gates_passed` for every pair of ``tries``."""
    listed = np.array([pair for pairs in tries for pair in pairs], dtype=np.int64).reshape(-1, 2)
    return dict(zip(map(tuple, listed.tolist()), _gates_passed(points, tets, quality, listed, targets, cells_of)))


def _boundary_after(face_keys_before, edges_before, old_faces, new_faces, gone: int, n: int):
    """The boundary's face and edge keys after a collapse replaced ``old_faces`` (each holding
    ``gone``) with ``new_faces``: the old faces' edges at ``gone`` go, the new faces' edges come."""
    faces = np.union1d(np.setdiff1d(face_keys_before, face_keys(old_faces, n)), face_keys(new_faces, n))
    old_edges = old_faces[:, [0, 1, 1, 2, 2, 0]].reshape(-1, 2)
    old_edges = old_edges[(old_edges == gone).any(axis=1)]
    edges = np.union1d(np.setdiff1d(edges_before, edge_keys(old_edges, n)),
                       edge_keys(new_faces[:, [0, 1, 1, 2, 2, 0]].reshape(-1, 2), n))
    return faces, edges


def _may_remove(keep: int, gone: int, flap: bool, on_boundary, movable, removable, locked, labels, cells_of) -> bool:
    """Whether ``gone`` may be collapsed into ``keep`` (see :func:`collapse_round`)."""
    if not removable[gone] or (locked is not None and locked[gone]):
        return False
    if on_boundary[gone] and not on_boundary[keep]:
        return False
    if flap and cells_of(gone).size != 1:  # a flap's apex goes with its one cell, nothing else
        return False
    if not flap and not movable[gone] and movable[keep]:  # a node pinned on a crease joins another one
        return False
    return labels is None or np.unique(labels[np.union1d(cells_of(gone), cells_of(keep))]).size == 1


def collapse_round(
    points: np.ndarray,
    tets: np.ndarray,
    quality: np.ndarray,
    threshold: float,
    on_boundary: np.ndarray,
    movable: np.ndarray,
    removable: np.ndarray,
    boundary_face_keys: np.ndarray,
    boundary_edges: np.ndarray,
    *,
    targets: ShapeTargets,
    guard: SurfaceGuard,
    locked: np.ndarray | None = None,
    inner: bool = False,
    labels: np.ndarray | None = None,
) -> tuple:
    """One round of edge collapses: the bad flaps' apexes removed with their cells, then the short
    boundary edges of the bad cells.

    Parameters
    ----------
    points : (N, 3) float array; no vertex moves
    tets : (M, 4) int array, positively oriented, forming a solid with a closed boundary
    quality : (M,) the cells' scores (``targets.score``, degrees)
    threshold : cells scoring below this are improved
    on_boundary, movable : (N,) bool, the boundary vertices and those that may move; both are
        updated in place for the removed vertices
    removable : (N,) bool, the vertices that may be removed (not the user's fixed points nor the
        feature corners); a vertex that may not move (on a crease or a feature curve) is only
        removed into another such vertex, which keeps the crease (a flap's apex goes with its
        cell whatever its neighbours); updated in place
    targets : ShapeTargets
    guard : SurfaceGuard
    locked : (N,) bool, optional
        Vertices that are never removed.
    inner : bool
        Also collapse the short edges with an inner vertex at one end, removing the inner one
        (a vertex crowding another, which no move of the stage pushed away).
    labels : (M,) int array, optional
        A label of each cell (its region): a vertex is only removed into another when every
        cell at either holds one label (the faces between labels stay). It is returned last,
        updated.

    Returns
    -------
    tets, quality : the remaining cells and their scores
    collapses : the number of vertices removed (they stay in ``points``, in no cell)
    boundary_face_keys, boundary_edges : the updated keys
    touched : (N,) bool, the vertices that kept a collapsed vertex's cells
    labels : the remaining cells' labels (only when ``labels`` is given)

    Examples
    --------
    Eight cube corners and the centre of the unit sphere, with a ninth surface vertex crowding
    corner 1 (h = 4 for these coarse faces: the guard lets faces sit 0.4 under the sphere):

    >>> import numpy as np
    >>> from scipy.spatial import Delaunay
    >>> from fepre import sdf
    >>> from fepre.distmesh.surface_guard import SurfaceGuard
    >>> from fepre.distmesh.tet_shape import ShapeTargets, signed_volume
    >>> from fepre.distmesh.tet_topology import edge_keys, face_keys, face_neighbours, faces_on_boundary
    >>> corners = np.array([[1, 1, 1], [1, -1, -1], [-1, 1, -1], [-1, -1, 1], [-1, -1, -1], [1, 1, -1],
    ...                     [1, -1, 1], [-1, 1, 1]]) / np.sqrt(3)
    >>> near = corners[0] + [0.08, -0.06, 0.0]
    >>> points = np.vstack([[0.0, 0.0, 0.0], corners, near / np.linalg.norm(near)])
    >>> tets = Delaunay(points).simplices
    >>> flipped = signed_volume(points[tets]) < 0; tets[flipped] = tets[flipped][:, [1, 0, 2, 3]]
    >>> on = np.ones(10, dtype=bool); on[0] = False; free = on.copy(); removable = on.copy()
    >>> targets, ball = ShapeTargets(), sdf.sphere(1.0)
    >>> q = targets.score(points[tets])
    >>> faces = faces_on_boundary(tets, face_neighbours(tets, 10))
    >>> keys = np.sort(face_keys(faces, 10))
    >>> edges = np.unique(edge_keys(faces[:, [0, 1, 1, 2, 2, 0]].reshape(-1, 2), 10))
    >>> new, q2, done, keys, edges, _ = collapse_round(points, tets, q, 33.0, on, free, removable, keys, edges,
    ...                                                targets=targets, guard=SurfaceGuard(ball, 4.0, points, on))
    >>> done, len(keys), len(edges), round(float(q.min()), 1), round(float(q2.min()), 1)
    (1, 12, 18, 3.5, 45.0)
    """
    n = points.shape[0]
    touched = np.zeros(n, dtype=bool)
    done = 0
    cells_of = _CellsOf(tets, n)
    flaps = _flap_apexes(points, tets[quality < threshold], boundary_face_keys)
    shorts = _short_edges(points, tets, quality, threshold, on_boundary, inner)
    tries = [((u, v),) for v, u in flaps] + [((u, v), (v, u)) for u, v in shorts]
    gated = _gate_verdicts(points, tets, quality, tries, targets, cells_of)
    stale = np.zeros(n, dtype=bool)  # a verdict holds until a collapse changes a cell at the removed vertex
    for k, pairs in enumerate(tries):
        flap = k < len(flaps)
        for keep, gone in pairs:
            if not stale[gone] and not gated[(int(keep), int(gone))]:
                continue
            if not _may_remove(keep, gone, flap, on_boundary, movable, removable, locked, labels, cells_of):
                continue
            result = _try_collapse(points, tets, quality, keep, gone, boundary_face_keys, targets, guard, cells_of)
            if result is None:
                continue
            removed, changed, new, new_quality, old_faces, new_faces = result
            stale[tets[np.concatenate([removed, changed])].ravel()] = True
            stale[keep] = True
            if done == 0:  # the caller's arrays stay as they were
                tets, quality = tets.copy(), quality.copy()
            tets[changed], quality[changed] = new, new_quality
            alive = np.ones(tets.shape[0], dtype=bool)
            alive[removed] = False
            tets, quality = tets[alive], quality[alive]
            if labels is not None:
                labels = labels[alive]
            cells_of = _CellsOf(tets, n)
            boundary_face_keys, boundary_edges = _boundary_after(boundary_face_keys, boundary_edges, old_faces,
                                                                 new_faces, gone, n)
            on_boundary[gone] = movable[gone] = removable[gone] = False
            touched[new.ravel()] = True
            touched[keep] = True
            done += 1
            break
    return (tets, quality, done, boundary_face_keys, boundary_edges, touched) + (() if labels is None else (labels,))
