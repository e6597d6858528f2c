"""Topological flips that remove bad tetrahedra: face removal (2-3) and edge removal (n to 2n-4).

A round collects, for every bad tetrahedron, the candidate flips on its faces and edges,
evaluates every candidate's new tetrahedra at once (their smallest dihedral angle, -1 when
inverted or flat), keeps those that raise the worst angle of the cells they replace, and
applies a set of them that touch disjoint cells. Edge removal covers 3-2 (n = 3), 4-4 (n = 4)
and the larger rings up to n = 6 (rings of 7 cost four times as much and rarely help), trying every triangulation of the ring.

Flips never move a vertex and only replace interior cells by cells filling the same region, so
the boundary surface and the volume are unchanged.
"""

from __future__ import annotations

from functools import lru_cache

import numpy as np

from .tet_shape import min_dihedral
from .tet_topology import EDGE_OF_TET, FACE_OF_TET, edge_keys, face_neighbours

__all__ = ["flip_round", "ring_triangulations", "RING_OF_EDGE"]

#: For the edge (i, j) = EDGE_OF_TET[k], the other two local vertices (k, l) such that the
#: permutation (i, j, k, l) is even: (a, b, c, d) is then positively oriented.
RING_OF_EDGE = np.array([[2, 3], [3, 1], [1, 2], [0, 3], [2, 0], [0, 1]])
#: Largest ring of tetrahedra around an edge that edge removal tries.
MAX_RING = 6
#: A flip must raise the worst angle of the replaced cells by at least this (degrees).
MIN_GAIN = 1e-3


@lru_cache(maxsize=None)
def ring_triangulations(n: int) -> np.ndarray:
    """All triangulations of a convex n-gon, shape (count, n - 2, 3), counter-clockwise triangles.

    Examples
    --------
    >>> [ring_triangulations(n).shape[0] for n in (3, 4, 5, 6, 7)]
    [1, 2, 5, 14, 42]
    """

    def polygon(vertices: tuple[int, ...]) -> list[list[tuple[int, int, int]]]:
        if len(vertices) < 3:
            return [[]]
        first, last = vertices[0], vertices[-1]
        result = []
        for split in range(1, len(vertices) - 1):
            apex = vertices[split]
            for left in polygon(vertices[: split + 1]):
                for right in polygon(vertices[split:]):
                    result.append(left + [(first, apex, last)] + right)
        return result

    return np.array(polygon(tuple(range(n))), dtype=np.int64).reshape(-1, n - 2, 3)


def _face_candidates(points, tets, neighbours, bad):
    """2-3 flips across the interior faces of the bad cells: old (K, 2), new (K, 3, 4), angles."""
    cells = np.repeat(bad, 4)
    local = np.tile(np.arange(4), bad.size)
    other = neighbours[cells, local]
    keep = other >= 0
    cells, local, other = cells[keep], local[keep], other[keep]
    face = tets[cells[:, None], FACE_OF_TET[local]]  # outward from cells, so towards e
    d = tets[cells, local]
    other_vertices = tets[other]
    e = other_vertices[(other_vertices[:, :, None] != face[:, None, :]).all(axis=2)]
    a, b, c = face[:, 0], face[:, 1], face[:, 2]
    new = np.stack(
        [np.stack([a, b, d, e], 1), np.stack([b, c, d, e], 1), np.stack([c, a, d, e], 1)], 1
    )
    old = np.stack([cells, other], 1)
    return old, new, min_dihedral(points[new])


def _edge_candidates(points, tets, bad, boundary_edges):
    """Edge removals around the edges of the bad cells, grouped by ring size.

    Returns a list of (old (K, n), new (K, 2n - 4, 4), new cells' angles) triples, one per ring
    size, with the best triangulation of each ring.
    """
    n_points = points.shape[0]
    all_keys = edge_keys(tets[:, EDGE_OF_TET].reshape(-1, 2), n_points)
    order = np.argsort(all_keys, kind="stable")
    sorted_keys = all_keys[order]
    wanted = np.unique(edge_keys(tets[bad][:, EDGE_OF_TET].reshape(-1, 2), n_points))
    if boundary_edges.size:
        wanted = wanted[~np.isin(wanted, boundary_edges)]
    start = np.searchsorted(sorted_keys, wanted, side="left")
    stop = np.searchsorted(sorted_keys, wanted, side="right")
    count = stop - start
    results = []
    for n in range(3, MAX_RING + 1):
        pick = count == n
        if not pick.any():
            continue
        slots = order[start[pick][:, None] + np.arange(n)]  # (E, n) positions in the 6M list
        cells = slots // 6
        local_edge = slots % 6
        key = wanted[pick]
        a = key // n_points
        b = key % n_points
        tv = tets[cells]  # (E, n, 4)
        ring_local = RING_OF_EDGE[local_edge]  # (E, n, 2)
        from_v = np.take_along_axis(tv, ring_local[..., 0:1], axis=2)[..., 0]
        to_v = np.take_along_axis(tv, ring_local[..., 1:2], axis=2)[..., 0]
        first_local = EDGE_OF_TET[local_edge][..., 0]
        reversed_edge = np.take_along_axis(tv, first_local[..., None], axis=2)[..., 0] != a[:, None]
        from_v, to_v = np.where(reversed_edge, to_v, from_v), np.where(reversed_edge, from_v, to_v)
        # Chain the directed ring edges into a cycle r0 -> r1 -> ... (a closed ring).
        ring = np.empty_like(from_v)
        ring[:, 0] = from_v[:, 0]
        ok = np.ones(key.size, dtype=bool)
        for step in range(1, n):
            match = from_v == ring[:, step - 1 : step]
            ok &= match.sum(1) == 1
            ring[:, step] = to_v[np.arange(key.size), np.argmax(match, axis=1)]
        ok &= to_v[np.arange(key.size), np.argmax(from_v == ring[:, -1:], axis=1)] == ring[:, 0]
        if not ok.any():
            continue
        ring, cells, a, b = ring[ok], cells[ok], a[ok], b[ok]
        # Every triangulation of the ring at once; each edge keeps its best one.
        tri = ring[:, ring_triangulations(n)]  # (E, T, n-2, 3), counter-clockwise seen from b
        shape = tri.shape[:3] + (1,)
        up = np.concatenate([tri, np.broadcast_to(b[:, None, None, None], shape)], 3)
        down = np.concatenate([tri[..., [0, 2, 1]], np.broadcast_to(a[:, None, None, None], shape)], 3)
        new = np.concatenate([up, down], 2)  # (E, T, 2n-4, 4)
        q_new = min_dihedral(points[new])
        best = np.argmax(q_new.min(axis=2), axis=1)
        pick_best = np.arange(new.shape[0])
        results.append((cells, new[pick_best, best], q_new[pick_best, best]))
    return results


def flip_round(
    points: np.ndarray,
    tets: np.ndarray,
    quality: np.ndarray,
    threshold: float,
    boundary_edges: np.ndarray,
    active: np.ndarray | None = None,
) -> tuple[np.ndarray, np.ndarray, int, np.ndarray]:
    """One round of flips on the cells whose smallest dihedral angle is below ``threshold``.

    Parameters
    ----------
    points : (N, 3) float array
    tets : (M, 4) int array, positively oriented
    quality : (M,) smallest dihedral angle of each cell (degrees)
    threshold : cells below this angle are improved
    boundary_edges : sorted edge keys (see :func:`edge_keys`) of the boundary surface; edges
        on the boundary are never removed.
    active : (N,) bool, optional
        Only bad cells with an active vertex are tried (the vertices whose surroundings
        changed since the last try); all bad cells when None.

    Returns
    -------
    tets, quality : the new cells and their angles
    flips : number of flips applied
    touched : (N,) bool, the vertices of the new cells
    """
    touched = np.zeros(points.shape[0], dtype=bool)
    bad_cells = quality < threshold
    if active is not None:
        bad_cells &= active[tets].any(axis=1)
    if not bad_cells.any():
        return tets, quality, 0, touched
    # Every candidate replaces cells that share at least two vertices with a bad cell, so the
    # work is confined to the cells touching the bad cells' vertices.
    near = np.zeros(points.shape[0], dtype=bool)
    near[tets[bad_cells]] = True
    region = np.flatnonzero(near[tets].any(axis=1))
    sub = tets[region]
    bad = np.flatnonzero(bad_cells[region])
    neighbours = face_neighbours(sub, points.shape[0])
    groups = [_face_candidates(points, sub, neighbours, bad)]
    groups += _edge_candidates(points, sub, bad, boundary_edges)
    olds, news, gains, new_quality = [], [], [], []
    for old, new, q_new in groups:
        if old.shape[0] == 0:
            continue
        old = region[old]
        worst_new = q_new.min(axis=1)
        worst_old = quality[old].min(axis=1)
        good = worst_new > worst_old + MIN_GAIN
        if good.any():
            olds.append(old[good])
            news.append(new[good])
            gains.append(worst_new[good])
            new_quality.append(q_new[good])
    if not olds:
        return tets, quality, 0, touched
    # Rank every candidate by the worst angle it produces (best first); a candidate is applied
    # when it is the best-ranked candidate on every cell it replaces.
    worst = np.concatenate(gains)
    rank_of = np.empty(worst.size, dtype=np.int64)
    rank_of[np.argsort(-worst, kind="stable")] = np.arange(worst.size)
    best = np.full(tets.shape[0], np.iinfo(np.int64).max)
    offset = 0
    ranks = []
    for old in olds:
        r = rank_of[offset : offset + old.shape[0]]
        ranks.append(r)
        np.minimum.at(best, old, np.broadcast_to(r[:, None], old.shape))
        offset += old.shape[0]
    remove = np.zeros(tets.shape[0], dtype=bool)
    add_tets, add_quality = [], []
    applied = 0
    for old, new, q_new, r in zip(olds, news, new_quality, ranks):
        chosen = (best[old] == r[:, None]).all(axis=1)
        if not chosen.any():
            continue
        # A cell can appear twice in one candidate only if the mesh is broken; guard anyway.
        remove[old[chosen]] = True
        add_tets.append(new[chosen].reshape(-1, 4))
        add_quality.append(q_new[chosen].reshape(-1))
        applied += int(chosen.sum())
    keep = ~remove
    tets = np.concatenate([tets[keep]] + add_tets).astype(np.int64)
    quality = np.concatenate([quality[keep]] + add_quality)
    for added in add_tets:
        touched[added.ravel()] = True
    return tets, quality, applied, touched

