"""Boundary edge removal: flipping an edge of the boundary surface together with its open ring of cells.

A boundary face whose three vertices are nearly collinear (a *cap* on the surface, left where
the surface sampling has a gap) makes every cell on it flat, whatever its fourth vertex: no
vertex move inside the part and no interior flip can repair it, because the face itself is
degenerate. The repair is to flip the face's long edge ``ab`` on the surface: ``ab`` is shared
by the cap ``abw`` and the face ``abx`` on the other side, and the cells around ``ab`` form an
*open* ring ``w = r0, r1, ..., rn = x``. Removing ``ab`` replaces those ``n`` cells by the
``2 (n - 1)`` cells that a triangulation of the polygon ``r0 ... rn`` makes with ``a`` and with
``b``; the boundary faces ``abw`` and ``abx`` become ``awx`` and ``bxw`` (a surface edge flip).

:func:`boundary_edge_round` tries every triangulation of each ring (rings of up to
``MAX_OPEN_RING`` cells; one cell is :func:`~fepre.distmesh.boundary_slivers.remove_boundary_slivers`'
case) around the boundary edges of the bad cells and keeps a flip only when

* it raises the worst score of the cells it replaces;
* the two boundary faces are nearly coplanar (normals within ``CREASE_ANGLE``): an edge on a
  crease of the part is never flipped;
* the new boundary faces lie on the surface (:meth:`~fepre.distmesh.surface_guard.SurfaceGuard.faces_allowed`,
  no worse than the old ones) and the new surface edge ``wx`` is not an edge of the mesh yet.

No vertex moves. The volume changes by the sliver between the old and new boundary faces, which
the surface checks keep within ``FACE_DEPTH * h`` of the surface.
"""

from __future__ import annotations

import numpy as np

from .boundary_slivers import CREASE_ANGLE, _unit_normals
from .flips import MIN_GAIN, RING_OF_EDGE, _apply, _region, _ring_tables
from .surface_guard import SurfaceGuard
from .tet_shape import ShapeTargets
from .tet_topology import EDGE_OF_TET, edge_keys, face_keys, in_sorted

__all__ = ["boundary_edge_round", "best_ring_flips", "MAX_OPEN_RING"]

#: Largest open ring (cells around a boundary edge) that boundary edge removal tries.
MAX_OPEN_RING = 5
#: The new faces may lie this many times as far from the surface as the old ones (when beyond
#: ``FACE_DEPTH h``): a cap's long chord and the flipped one sag alike on a curved surface.
DEPTH_SLACK = 1.25


def _outward(points: np.ndarray, faces: np.ndarray, inside: np.ndarray) -> np.ndarray:
    """``faces`` (K, 3) reordered so that their right-hand normals point away from ``inside`` (K,)."""
    return _along(points, faces, points[faces].mean(axis=1) - points[inside])


def _along(points: np.ndarray, faces: np.ndarray, direction: np.ndarray) -> np.ndarray:
    """``faces`` (K, 3) reordered so that their right-hand normals point along ``direction`` (K, 3)."""
    tri = points[faces]
    normal = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
    flip = np.einsum("ij,ij->i", normal, direction) < 0
    return np.where(flip[:, None], faces[:, ::-1], faces)


def _open_rings(tets: np.ndarray, wanted: np.ndarray, n_points: int):
    """The open rings of cells around the boundary edges ``wanted`` (keys), grouped by size.

    Yields ``n``, ``cells`` (E, n) and ``ring`` (E, n + 1): the polygon ``r0 ... rn`` around
    each edge ``a -> b`` (``a``, ``b`` (E,)), ordered so that ``(a, b, r_i, r_i+1)`` is
    positively oriented, as in :func:`~fepre.distmesh.flips._edge_candidates`.
    """
    all_keys = edge_keys(tets[:, EDGE_OF_TET].reshape(-1, 2), n_points)
    order = np.argsort(all_keys, kind="stable")
    sorted_keys = all_keys[order]
    start = np.searchsorted(sorted_keys, wanted, side="left")
    count = np.searchsorted(sorted_keys, wanted, side="right") - start
    for n in range(2, MAX_OPEN_RING + 1):
        pick = count == n
        if not pick.any():
            continue
        slots = order[start[pick][:, None] + np.arange(n)]
        cells, local_edge = slots // 6, slots % 6
        key = wanted[pick]
        a, b = key // n_points, key % n_points
        tv = tets[cells]
        ring_local = RING_OF_EDGE[local_edge]
        from_v = np.take_along_axis(tv, ring_local[..., 0:1], axis=2)[..., 0]
        to_v = np.take_along_axis(tv, ring_local[..., 1:2], axis=2)[..., 0]
        first_local = EDGE_OF_TET[local_edge][..., 0]
        reversed_edge = np.take_along_axis(tv, first_local[..., None], axis=2)[..., 0] != a[:, None]
        from_v, to_v = np.where(reversed_edge, to_v, from_v), np.where(reversed_edge, from_v, to_v)
        # the ring starts at the one vertex that no cell leads to
        starts = (from_v[:, :, None] != to_v[:, None, :]).all(axis=2)
        ok = starts.sum(axis=1) == 1
        rows = np.arange(key.size)
        ring = np.empty((key.size, n + 1), dtype=np.int64)
        ring[:, 0] = from_v[rows, np.argmax(starts, axis=1)]
        chain = np.empty_like(cells)
        for step in range(n):
            match = from_v == ring[:, step : step + 1]
            ok &= match.sum(axis=1) == 1
            column = np.argmax(match, axis=1)
            chain[:, step] = cells[rows, column]
            ring[:, step + 1] = to_v[rows, column]
        if ok.any():
            yield n, chain[ok], ring[ok], a[ok], b[ok]


def boundary_edge_round(
    points: np.ndarray,
    tets: np.ndarray,
    quality: np.ndarray,
    threshold: float,
    on_boundary: np.ndarray,
    boundary_face_keys: np.ndarray,
    boundary_edges: np.ndarray,
    *,
    targets: ShapeTargets,
    guard: SurfaceGuard,
    locked: np.ndarray | None = None,
    labels: np.ndarray | None = None,
) -> tuple:
    """One round of boundary edge removals around the bad cells (score below ``threshold``).

    Parameters
    ----------
    points : (N, 3) float array
    tets : (M, 4) int array, positively oriented
    quality : (M,) the cells' scores (``targets.score``, degrees)
    threshold : cells scoring below this are improved
    on_boundary : (N,) bool, the boundary vertices
    boundary_face_keys, boundary_edges : sorted keys (:func:`face_keys`, :func:`edge_keys`) of
        the boundary surface's faces and edges
    targets : ShapeTargets
        The score.
    guard : SurfaceGuard
        Checks that the new boundary faces lie on the surface.
    locked : (N,) bool, optional
        Vertices whose boundary faces must stay: no edge with a locked end is flipped.
    labels : (M,) int array, optional
        A label of each cell (its region): only edges whose cells all hold one label are
        flipped, and the new cells take it. It is returned last, updated.

    Returns
    -------
    tets, quality : the new cells and their scores
    flips : the number of boundary edges removed
    boundary_face_keys, boundary_edges : the updated keys
    touched : (N,) bool, the vertices of the new cells
    labels : the new cells' labels (only when ``labels`` is given)

    Examples
    --------
    Two cells on a flat face, one of them on a cap ``a w b`` (``w`` almost on ``ab``), lose
    the cap when ``ab`` is flipped to ``w x``:

    >>> import numpy as np
    >>> from fepre import sdf
    >>> from fepre.distmesh.surface_guard import SurfaceGuard
    >>> from fepre.distmesh.tet_shape import ShapeTargets
    >>> from fepre.distmesh.tet_topology import edge_keys, face_keys
    >>> half = sdf.plane((0, 0, 1))  # the solid z < 0
    >>> p = np.array([[-1, 0, 0], [1, 0, 0], [0, -0.05, 0], [0, 1, 0], [0, 0.2, -1.0]], float)
    >>> tets = np.array([[0, 1, 2, 4], [1, 0, 3, 4]])
    >>> faces = np.array([[0, 2, 1], [0, 1, 3]])
    >>> n = len(p); on = np.array([True, True, True, True, False])
    >>> targets = ShapeTargets()
    >>> q = targets.score(p[tets])
    >>> new, q2, flips, *_ = boundary_edge_round(
    ...     p, tets, q, 33.0, on, np.sort(face_keys(faces, n)),
    ...     np.unique(edge_keys(np.array([[0, 1], [1, 2], [0, 2], [1, 3], [0, 3]]), n)),
    ...     targets=targets, guard=SurfaceGuard(half, 1.0, p, on))
    >>> flips, bool(q2.min() > q.min())
    (1, True)
    """
    n_points = points.shape[0]
    touched = np.zeros(n_points, dtype=bool)
    unchanged = (tets, quality, 0, boundary_face_keys, boundary_edges, touched) + (() if labels is None else (labels,))
    bad = np.flatnonzero(quality < threshold)
    bad = bad[on_boundary[tets[bad]].sum(axis=1) >= 3]
    if bad.size == 0:
        return unchanged
    wanted = np.unique(edge_keys(tets[bad][:, EDGE_OF_TET].reshape(-1, 2), n_points))
    wanted = wanted[in_sorted(wanted, boundary_edges)]
    if wanted.size == 0:
        return unchanged
    region, sub, _ = _region(n_points, tets, bad)  # the rings of the bad cells' edges lie here
    # the edges at the ring ends' vertices: a flip must not make an edge that exists
    ends = np.zeros(n_points, dtype=bool)
    ends[sub.ravel()] = True
    near = tets[ends[tets].any(axis=1)]
    existing = np.unique(edge_keys(near[:, EDGE_OF_TET].reshape(-1, 2), n_points))
    candidates, surface_changes = [], []
    for n, cells, ring, a, b in _open_rings(sub, wanted, n_points):
        cells = region[cells]
        allowed = _flip_allowed(points, cells, ring, a, b, existing, boundary_face_keys, guard, locked, n_points, labels)
        if not allowed.any():
            continue
        cells, ring, a, b = cells[allowed], ring[allowed], a[allowed], b[allowed]
        new_cells, scores, worst = best_ring_flips(points, ring, a, b, targets)
        good = worst > quality[cells].min(axis=1) + MIN_GAIN
        if not good.any():
            continue
        values = (scores[good],) + (() if labels is None else (np.broadcast_to(labels[cells[good][:, :1]], scores[good].shape),))
        candidates.append((cells[good], new_cells[good], worst[good], values))
        surface_changes.append((cells[good], a[good], b[good], ring[good][:, 0], ring[good][:, -1]))
    if not candidates:
        return unchanged
    chosen: list[np.ndarray] = []
    tets, values, applied, new_vertices = _apply(tets, candidates, [quality] + ([] if labels is None else [labels]), chosen)
    boundary_face_keys, boundary_edges = _surface_after(
        [tuple(item[mask] for item in change) for change, mask in zip(surface_changes, chosen)],
        boundary_face_keys, boundary_edges, n_points)
    touched[new_vertices] = True
    return (tets, values[0], applied, boundary_face_keys, boundary_edges, touched) + tuple(values[1:])


def best_ring_flips(points: np.ndarray, ring: np.ndarray, a: np.ndarray, b: np.ndarray, targets: ShapeTargets):
    """For each boundary edge ``a b`` (E,) with its open ring ``ring`` (E, n + 1), the cells that
    replace its ring when it is flipped (the ring's triangulation, joined to ``a`` and to ``b``,
    whose worst cell scores best): cells (E, 2 n - 2, 4), their scores and that worst score (E,)."""
    triangles, table = _ring_tables(ring.shape[1])
    tri = ring[:, triangles]
    shape = tri.shape[:2] + (1,)
    up = np.concatenate([tri, np.broadcast_to(b[:, None, None], shape)], 2)
    down = np.concatenate([tri[..., [0, 2, 1]], np.broadcast_to(a[:, None, None], shape)], 2)
    new_cells = np.concatenate([up, down], 1)
    scores = targets.score(points[new_cells])
    worst = scores[:, table].min(axis=2)
    choice = np.argmax(worst, axis=1)
    rows = np.arange(ring.shape[0])
    best = table[choice]
    return new_cells[rows[:, None], best], scores[rows[:, None], best], worst[rows, choice]


def _flip_allowed(points, cells, ring, a, b, existing, boundary_face_keys, guard, locked, n_points,
                  labels=None) -> np.ndarray:
    """Mask of the ring flips that keep the surface where it is (see the module docstring) and,
    with ``labels``, whose cells all hold one label."""
    w, x = ring[:, 0], ring[:, -1]
    allowed = in_sorted(face_keys(np.stack([a, b, w], 1), n_points), boundary_face_keys)
    allowed &= in_sorted(face_keys(np.stack([a, b, x], 1), n_points), boundary_face_keys)
    allowed &= ~in_sorted(edge_keys(np.stack([w, x], 1), n_points), existing)
    if locked is not None:
        allowed &= ~(locked[a] | locked[b])
    if labels is not None:
        allowed &= (labels[cells] == labels[cells[:, :1]]).all(axis=1)
    old_faces = [_outward(points, np.stack([a, b, w], 1), ring[:, 1]),
                 _outward(points, np.stack([a, b, x], 1), ring[:, -2])]
    normals = [_unit_normals(points[f]) for f in old_faces]
    allowed &= np.einsum("ij,ij->i", *normals) >= np.cos(np.radians(CREASE_ANGLE))
    check = np.flatnonzero(allowed)
    if check.size:
        outward = (normals[0] + normals[1])[check]
        new_faces = np.stack([_along(points, np.stack([a, w, x], 1)[check], outward),
                              _along(points, np.stack([b, w, x], 1)[check], outward)], axis=1)
        old = np.stack([f[check] for f in old_faces], axis=1)
        fine = guard.replacements_allowed(points[old], points[new_faces], DEPTH_SLACK)
        allowed[check[~fine]] = False
    return allowed


def _surface_after(changes, boundary_face_keys, boundary_edges, n_points):
    """The boundary keys after the flips ``changes`` (groups of ``cells, a, b, w, x``) were applied."""
    removed_faces, added_faces, removed_edges, added_edges = [], [], [], []
    for _, a, b, w, x in changes:
        removed_faces += [face_keys(np.stack([a, b, w], 1), n_points), face_keys(np.stack([a, b, x], 1), n_points)]
        added_faces += [face_keys(np.stack([a, w, x], 1), n_points), face_keys(np.stack([b, w, x], 1), n_points)]
        removed_edges.append(edge_keys(np.stack([a, b], 1), n_points))
        added_edges.append(edge_keys(np.stack([w, x], 1), n_points))
    if removed_faces:
        boundary_face_keys = np.union1d(np.setdiff1d(boundary_face_keys, np.concatenate(removed_faces)),
                                        np.concatenate(added_faces))
        boundary_edges = np.union1d(np.setdiff1d(boundary_edges, np.concatenate(removed_edges)),
                                    np.concatenate(added_edges))
    return boundary_face_keys, boundary_edges
