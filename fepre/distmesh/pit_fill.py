"""Pits of the boundary filled: a boundary vertex whose three boundary faces dent the surface.

Where a crevice of the part narrower than h reaches in just under its surface, the mesh can end
with a boundary vertex ``v`` down in the crevice that holds exactly three boundary faces (a pit),
and the cells between ``v`` and the surface above it are flat, every node on the zero set: no
flip, move or collapse mends them (ur3_upperarm.stl at D/50: 2.7 deg, the bottom of a crevice
0.04 h under the top of a lip). :func:`fill_pits` adds the cell ``v x y z`` over the pit
(``x y z`` its rim): the face ``x y z`` takes the three faces' place on the boundary and ``v``
becomes an inner vertex, which smoothing then moves into the material. A closed void of four
faces (a missing cell) is the same pit with its rim a boundary face already: the new cell fills
it and the four faces leave the boundary.

A fill is kept only when the new cell is positively oriented, scores better than the worst cell
at ``v``, holds no vertex and is crossed by no edge of the mesh (it fills the pit, nothing else),
and its face ``x y z`` stays on the surface
(:meth:`~fepre.distmesh.surface_guard.SurfaceGuard.replacements_allowed`). The material it adds
lies where the model is outside, in a crevice the mesh does not resolve: the pit's volume.
"""

from __future__ import annotations

import numpy as np
from scipy.spatial import cKDTree

from .surface_guard import SurfaceGuard
from .tet_shape import ShapeTargets, signed_volume
from .tet_topology import EDGE_OF_TET, FACE_OF_TET, cells_around, edge_keys, face_keys, in_sorted, vertex_stars

__all__ = ["fill_pits", "close_flat_voids"]

#: orientation tests within this share of the cell's size cubed count as zero
FLAT = 1e-9
#: a closed void of four faces enclosing at most this volume (times h^3) is flat
FLAT_VOID = 1e-9
#: a fill must raise the worst score of the cells at its vertex by at least this (degrees)
MIN_GAIN = 1e-3
#: the new cell's centroid lies at most this far outside the model (local sizes): a pit is a
#: crevice narrower than the elements, not the open space of a concave corner (two cubes sharing
#: an edge at h = 0.2: cells of 0.1-0.38 h^3 with their centroids 0.2-0.8 h out, the mesh +1.1%)
PIT_DEPTH = 0.1


def _pit_faces(tets, candidates, boundary_face_keys, starts, cells, n: int):
    """The candidate vertices whose boundary faces are exactly three forming a closed fan, and
    those faces (K, 3, 3), outward, each turned to start at its vertex."""
    star, owner = cells_around(starts, cells, candidates)
    faces = tets[star][:, FACE_OF_TET].reshape(-1, 3)
    owner = np.repeat(owner, 4)
    keep = in_sorted(face_keys(faces, n), boundary_face_keys) & (faces == owner[:, None]).any(axis=1)
    faces, owner = faces[keep], owner[keep]
    shift = np.argmax(faces == owner[:, None], axis=1)
    faces = np.take_along_axis(faces, (shift[:, None] + np.arange(3)) % 3, axis=1)
    order = np.argsort(owner, kind="stable")
    faces, owner = faces[order], owner[order]
    vertex, first, count = np.unique(owner, return_index=True, return_counts=True)
    three = count == 3
    fans = faces[first[three][:, None] + np.arange(3)]  # (K, 3, 3): v, x, y
    # closed: each rim vertex is the second vertex of one face and the third of another
    second, third = np.sort(fans[:, :, 1], axis=1), np.sort(fans[:, :, 2], axis=1)
    closed = (second == third).all(axis=1) & (second[:, 0] != second[:, 1]) & (second[:, 1] != second[:, 2])
    return vertex[three][closed], fans[closed]


def _segments_cross(p: np.ndarray, q: np.ndarray, triangle: np.ndarray, tol: float) -> np.ndarray:
    """Whether segments ``p q`` (K, 3) pass strictly through ``triangle`` (3, 3)."""
    def orient(u, v, w, x):
        return np.einsum("ij,ij->i", u - x, np.cross(v - x, w - x))

    a, b, c = (np.broadcast_to(corner, p.shape) for corner in triangle)
    sp, sq = orient(a, b, c, p), orient(a, b, c, q)
    straddle = ((sp > tol) & (sq < -tol)) | ((sp < -tol) & (sq > tol))
    t1, t2, t3 = orient(p, q, a, b), orient(p, q, b, c), orient(p, q, c, a)
    through = ((t1 > tol) & (t2 > tol) & (t3 > tol)) | ((t1 < -tol) & (t2 < -tol) & (t3 < -tol))
    return straddle & through


def _overlaps(points, tets, cell, tree: cKDTree, reach: float, starts, cells) -> bool:
    """Whether the new ``cell`` (4,) holds a vertex of the mesh or is crossed by one of its
    edges. Its three faces at the pit are the mesh's own, so an edge can only cross its new face,
    and then has an end within ``reach`` (the longest edge) of that face."""
    corners = points[cell]
    centre = corners.mean(axis=0)
    size = float(np.linalg.norm(corners - centre, axis=1).max())
    tol = FLAT * size**3
    near = np.setdiff1d(np.asarray(tree.query_ball_point(centre, size), dtype=np.int64), cell)
    if near.size:
        inside = np.ones(near.size, dtype=bool)
        for m in range(4):
            swapped = np.repeat(corners[None], near.size, axis=0)
            swapped[:, m] = points[near]
            inside &= signed_volume(swapped) > tol
        if inside.any():
            return True
    around = np.asarray(tree.query_ball_point(centre, size + reach), dtype=np.int64)
    touching, _ = cells_around(starts, cells, around)
    edges = np.unique(np.sort(tets[np.unique(touching)][:, EDGE_OF_TET].reshape(-1, 2), axis=1), axis=0)
    edges = edges[~np.isin(edges, cell[1:]).any(axis=1)]
    return bool(_segments_cross(points[edges[:, 0]], points[edges[:, 1]], corners[1:], tol).any())


def fill_pits(
    points: np.ndarray,
    tets: np.ndarray,
    quality: np.ndarray,
    threshold: float,
    on_boundary: np.ndarray,
    movable: np.ndarray,
    boundary_face_keys: np.ndarray,
    boundary_edges: np.ndarray,
    *,
    targets: ShapeTargets,
    guard: SurfaceGuard,
    locked: np.ndarray | None = None,
    labels: np.ndarray | None = None,
) -> tuple:
    """Fill the pits at the vertices of the cells scoring under ``threshold``.

    Parameters
    ----------
    points : (N, 3) float array; no vertex moves
    tets : (M, 4) int array, positively oriented, forming a solid with a closed boundary
    quality : (M,) the cells' scores (``targets.score``, degrees)
    threshold : float
        The pits at the vertices of cells scoring below this are filled.
    on_boundary, movable : (N,) bool
        The boundary vertices and those that may move; only a movable pit is filled (it must
        move once inside). ``on_boundary`` is updated in place.
    boundary_face_keys, boundary_edges : sorted keys of the boundary surface
    targets : ShapeTargets
    guard : SurfaceGuard
    locked : (N,) bool, optional
        Vertices whose faces stay as they are: no pit of theirs is filled.
    labels : (M,) int array, optional
        The cells' regions: a pit is filled only where every cell at its vertex is of one
        region, and the new cell takes it. Returned last, updated.

    Returns
    -------
    tets, quality : the cells, the new ones appended, and their scores
    filled : (N,) bool, the vertices the new cells made inner
    boundary_face_keys, boundary_edges : the updated keys
    touched : (N,) bool, the vertices of the new cells

    Examples
    --------
    A tetrahedron less the cell over its base: the vertex ``4`` is the bottom of a pit of three
    faces 0.3 over the model's bottom face (h = 4 for these coarse faces). Its fill gives the
    tetrahedron back, as four cells, with ``4`` inside:

    >>> import numpy as np
    >>> from fepre import sdf
    >>> from fepre.distmesh.surface_guard import SurfaceGuard
    >>> from fepre.distmesh.tet_shape import ShapeTargets
    >>> from fepre.distmesh.tet_topology import edge_keys, face_keys, face_neighbours, faces_on_boundary
    >>> points = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0.3, 0.3, 1], [0.3, 0.3, 0.3]])
    >>> tets = np.array([[4, 0, 1, 3], [4, 1, 2, 3], [4, 2, 0, 3]])
    >>> faces = faces_on_boundary(tets, face_neighbours(tets, 5))
    >>> keys = np.unique(face_keys(faces, 5))
    >>> edges = np.unique(edge_keys(faces[:, [0, 1, 1, 2, 2, 0]].reshape(-1, 2), 5))
    >>> targets, on, movable = ShapeTargets(), np.ones(5, dtype=bool), np.ones(5, dtype=bool)
    >>> guard = SurfaceGuard(sdf.box((4, 4, 2), center=(0, 0, 1)), 4.0, points, on)
    >>> quality = targets.score(points[tets])
    >>> tets, quality, filled, keys, edges, _ = fill_pits(points, tets, quality, 33.0, on, movable, keys, edges,
    ...                                                   targets=targets, guard=guard)
    >>> tets[-1].tolist(), np.flatnonzero(filled).tolist(), len(keys), len(edges), bool(on[4])
    ([4, 1, 0, 2], [4], 4, 6, False)
    """
    n = points.shape[0]
    unchanged = (tets, quality, np.zeros(n, dtype=bool), boundary_face_keys, boundary_edges, np.zeros(n, dtype=bool))
    unchanged += () if labels is None else (labels,)
    starts, cells = vertex_stars(tets, n)
    vertex, fans, new, new_quality, worst = _pits(points, tets, quality, threshold, on_boundary & movable, locked,
                                                  boundary_face_keys, targets, guard, starts, cells)
    rim_keys = face_keys(new[:, 1:], n)
    closes_void = in_sorted(rim_keys, boundary_face_keys)
    chosen = _chosen(points, tets, vertex, fans, new, closes_void, np.argsort(worst, kind="stable"), guard, labels,
                     starts, cells)
    if not chosen:
        return unchanged
    index = np.array([k for k, _ in chosen])
    added, void = new[index], closes_void[index]
    gone_faces = face_keys(fans[index].reshape(-1, 3), n)
    boundary_face_keys = np.setdiff1d(boundary_face_keys, np.concatenate([gone_faces, rim_keys[index][void]]))
    boundary_face_keys = np.union1d(boundary_face_keys, rim_keys[index][~void])
    spokes = np.stack([np.repeat(added[:, 0], 3), added[:, 1:].ravel()], axis=1)
    rim_edges = np.stack([added[void][:, [1, 2, 3]].ravel(), added[void][:, [2, 3, 1]].ravel()], axis=1)
    boundary_edges = np.setdiff1d(boundary_edges, edge_keys(np.concatenate([spokes, rim_edges]), n))
    filled = np.zeros(n, dtype=bool)
    filled[added[:, 0]] = True
    on_boundary[added[:, 0]] = False
    if void.any():  # a rim vertex of a closed void stays on the boundary only through other faces
        rims = np.unique(added[void][:, 1:])
        on_boundary[rims] = _on_edges(rims, boundary_edges, n)
    touched = np.zeros(n, dtype=bool)
    touched[added.ravel()] = True
    result = (np.concatenate([tets, added]), np.concatenate([quality, new_quality[index]]), filled, boundary_face_keys,
              boundary_edges, touched)
    if labels is not None:
        result += (np.concatenate([labels, np.array([region for _, region in chosen], dtype=labels.dtype)]),)
    return result


def _pits(points, tets, quality, threshold, free, locked, boundary_face_keys, targets: ShapeTargets,
          guard: SurfaceGuard, starts, cells) -> tuple:
    """The pits at the ``free`` vertices of the cells under ``threshold`` whose new cell passes the
    tests of one cell: its vertex (K,), faces (K, 3, 3), new cell (K, 4) and its score, and the
    worst score at the vertex."""
    n = points.shape[0]
    candidates = np.unique(tets[quality < threshold])
    keep = free[candidates] if locked is None else free[candidates] & ~locked[candidates]
    vertex, fans = _pit_faces(tets, candidates[keep], boundary_face_keys, starts, cells, n)
    rim = fans[:, :, 1]  # x and y of each face; the new cell is v, x, y of the first face and the third rim vertex
    first = fans[:, 0]
    third = np.where((rim != first[:, 1:2]) & (rim != first[:, 2:3]), rim, -1).max(axis=1, initial=-1)
    new = np.column_stack([first, third]).astype(tets.dtype)
    size = np.linalg.norm(points[new] - points[new].mean(axis=1, keepdims=True), axis=2).max(axis=1, initial=0.0)
    new_quality = targets.score(points[new]) if len(new) else np.zeros(0)
    star, owner = cells_around(starts, cells, vertex)
    worst = np.full(n, np.inf)
    np.minimum.at(worst, owner, quality[star])
    centroids = points[new].mean(axis=1)
    keep = (signed_volume(points[new]) > FLAT * size**3) & (new_quality > worst[vertex] + MIN_GAIN)
    if keep.any():
        keep[keep] = np.asarray(guard.model(centroids[keep]), dtype=float) <= PIT_DEPTH * guard.length(centroids[keep])
    return vertex[keep], fans[keep], new[keep], new_quality[keep], worst[vertex[keep]]


def _chosen(points, tets, vertex, fans, new, closes_void, order, guard: SurfaceGuard, labels, starts, cells) -> list:
    """The fills kept, in ``order``, as (index, region): no two share a vertex, the new cell's rim is
    no face of the mesh (but a closed void's), the surface guard passes it, it overlaps nothing,
    and with ``labels`` the cells at its vertex are of one region."""
    chosen = []
    if not len(order):
        return chosen
    tree = cKDTree(points)
    ends = tets[:, EDGE_OF_TET]
    reach = float(np.linalg.norm(points[ends[..., 0]] - points[ends[..., 1]], axis=2).max())  # the longest edge
    used = np.zeros(points.shape[0], dtype=bool)
    for k in order:
        cell = new[k]
        if used[cell].any() or (_face_in_use(tets, cell[1:], starts, cells) and not closes_void[k]):
            continue
        region = None
        if labels is not None:
            around = np.unique(labels[cells[starts[vertex[k]]:starts[vertex[k] + 1]]])
            if around.size != 1:
                continue
            region = around[0]
        if not closes_void[k] and not guard.replacements_allowed(points[fans[k]][None], points[cell[1:]][None, None])[0]:
            continue
        if _overlaps(points, tets, cell, tree, reach, starts, cells):
            continue
        used[cell] = True
        chosen.append((k, region))
    return chosen


def _face_in_use(tets, face, starts, cells) -> bool:
    """Whether a cell of the mesh holds the three vertices of ``face``."""
    around = cells[starts[face[0]]:starts[face[0] + 1]]
    return bool(((tets[around] == face[1]).any(axis=1) & (tets[around] == face[2]).any(axis=1)).any())


def _on_edges(vertices: np.ndarray, edge_codes: np.ndarray, n: int) -> np.ndarray:
    """Whether each of ``vertices`` ends one of the edges ``edge_codes`` (sorted keys)."""
    ends = np.unique(np.concatenate([edge_codes // n, edge_codes % n]))
    return np.isin(vertices, ends)


def close_flat_voids(points: np.ndarray, tets: np.ndarray, h: float) -> np.ndarray:
    """``tets`` with each closed void of four faces and no volume glued shut: a flat cell of four
    co-planar nodes (a, b, c, d) dropped from inside the solid leaves the two cells over its faces
    ``abc`` and ``acd`` on one side and two over ``abd`` and ``bcd`` on the other, each pair
    split along another diagonal of the flat quad (four nodes of the circle where a sphere meets a
    capsule, ``sphere(2) | capsule(0.6)`` at h = 1: a void of 4e-15 that the checks named as a
    cavity). Where the two cells on one side share their fourth node ``e``, a 2-2 flip turns them
    to the other diagonal (``e b d a`` and ``e b d c``), whose faces are the other side's.

    Examples
    --------
    A flat square inside a double pyramid, between two cells above and two below, each pair on
    its own diagonal (a void of no volume), is closed by the flip above:

    >>> import numpy as np
    >>> from fepre.distmesh.tet_shape import signed_volume
    >>> from fepre.distmesh.topology import boundary_faces
    >>> points = np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0], [0.5, 0.5, 1], [0.5, 0.5, -1],
    ...                    [0.5, -1, 0], [2, 0.5, 0], [0.5, 2, 0], [-1, 0.5, 0]])
    >>> rim = [[t, a, b, o] for t in (4, 5) for a, b, o in ((0, 1, 6), (1, 2, 7), (2, 3, 8), (3, 0, 9))]
    >>> tets = np.array([[4, 0, 1, 2], [4, 0, 2, 3], [5, 0, 3, 1], [5, 1, 3, 2]] + rim)
    >>> tets[signed_volume(points[tets]) < 0] = tets[signed_volume(points[tets]) < 0][:, [1, 0, 2, 3]]
    >>> closed = close_flat_voids(points, tets, 1.0)
    >>> len(boundary_faces(tets)), len(boundary_faces(closed))     # the void's four faces are inside now
    (20, 16)
    >>> float(signed_volume(points[closed]).sum()), float(signed_volume(points[closed]).min()) > 0
    (2.0, True)
    """
    from .cavities import inner_voids
    from .tet_topology import face_neighbours
    from .topology import check_topology

    n = points.shape[0]
    cell, local = np.nonzero(face_neighbours(tets, n) < 0)
    faces = tets[cell[:, None], FACE_OF_TET[local]]
    voids = [chosen for chosen, _, volume, _, _ in inner_voids(points, faces, h)
             if chosen.sum() == 4 and volume <= FLAT_VOID * h**3]
    if not voids:
        return tets
    closed = tets.copy()
    for chosen in voids:
        owners, sides = cell[chosen], faces[chosen]
        apexes = np.array([np.setdiff1d(closed[owner], side)[0] for owner, side in zip(owners, sides)])
        for i, j in ((0, 1), (0, 2), (0, 3), (1, 2), (1, 3), (2, 3)):
            if apexes[i] != apexes[j] or owners[i] == owners[j]:
                continue
            diagonal = np.intersect1d(sides[i], sides[j])
            if diagonal.size != 2:
                continue
            b, d = np.setdiff1d(sides[i], diagonal)[0], np.setdiff1d(sides[j], diagonal)[0]
            new = np.array([[apexes[i], b, d, diagonal[0]], [apexes[i], b, d, diagonal[1]]])
            turned = signed_volume(points[new]) < 0
            new[turned] = new[turned][:, [1, 0, 2, 3]]
            if (signed_volume(points[new]) > FLAT * h**3).all():
                closed[owners[i]], closed[owners[j]] = new
                break
    return closed if check_topology(closed, n).ok else tets
