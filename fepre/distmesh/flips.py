"""Topological flips that improve tetrahedra: face removal (2-3) and edge removal (n to 2n-4).

:func:`flip_round` collects, for every bad tetrahedron, the candidate flips on its faces and
edges, evaluates every candidate's new tetrahedra at once (their score,
:class:`~fepre.distmesh.tet_shape.ShapeTargets`: the worst of the smallest and largest dihedral
angle and the radius ratio, in degrees; -1 when inverted or flat), keeps those that raise the
worst score of the cells they replace, and
applies a set of them that touch disjoint cells. Edge removal covers 3-2 (n = 3), 4-4 (n = 4)
and the larger rings up to n = 6 (rings of 7 cost four times as much and rarely help), trying
every triangulation of the ring; each distinct triangle of a ring is evaluated once.

:func:`shape_flip_round` does the same with 3-2 and 4-4 flips ranked by the smallest radius
ratio of the new cells, around the cells of poor radius ratio: it raises the mean shape.

Flips never move a vertex and only replace interior cells by cells filling the same region, so
the boundary surface and the volume are unchanged.
"""

from __future__ import annotations

from functools import lru_cache

import numpy as np

from .tet_shape import ShapeTargets
from .tet_topology import EDGE_OF_TET, FACE_OF_TET, edge_keys, face_neighbours, in_sorted

__all__ = ["flip_round", "shape_flip_round", "ring_triangulations", "RING_OF_EDGE"]

#: For the edge (i, j) = EDGE_OF_TET[k], the other two local vertices (k, l) such that the
#: permutation (i, j, k, l) is even: (a, b, c, d) is then positively oriented.
RING_OF_EDGE = np.array([[2, 3], [3, 1], [1, 2], [0, 3], [2, 0], [0, 1]])
#: Largest ring of tetrahedra around an edge that edge removal tries.
MAX_RING = 6
#: A flip must raise the worst score of the replaced cells by at least this (degrees).
MIN_GAIN = 1e-3
#: Largest ring that shape flips try (3-2 and 4-4 flips): rings of five or more cells, and 2-3
#: flips, hardly ever hold a better configuration by radius ratio, and they cost most of the
#: candidates.
SHAPE_MAX_RING = 4
#: A shape flip must raise the smallest radius ratio of the replaced cells by at least this.
MIN_RATIO_GAIN = 1e-3


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


def _region(n_points: int, tets: np.ndarray, bad_cells: np.ndarray):
    """The cells sharing a vertex with the bad cells (indices): every candidate flip replaces only these.

    Returns ``region`` (their indices, sorted), ``sub`` (their vertices) and ``bad`` (the bad
    cells' rows in ``sub``).
    """
    near = np.zeros(n_points, dtype=bool)
    near[tets[bad_cells]] = True
    region = np.flatnonzero(near[tets].any(axis=1))
    return region, tets[region], np.searchsorted(region, bad_cells)


def _face_candidates(tets, neighbours, bad):
    """2-3 flips across the interior faces of the bad cells: old (K, 2) and new (K, 3, 4) cells."""
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
    return np.stack([cells, other], 1), new


@lru_cache(maxsize=None)
def _ring_tables(n: int) -> tuple[np.ndarray, np.ndarray]:
    """The distinct triangles of :func:`ring_triangulations` (C, 3) and, for each triangulation,
    the columns of its cells among ``[triangles + b, reversed triangles + a]``: (T, 2n - 4)."""
    triangulations = ring_triangulations(n)
    triangles, index = np.unique(triangulations.reshape(-1, 3), axis=0, return_inverse=True)
    index = index.reshape(triangulations.shape[:2])
    return triangles, np.concatenate([index, index + triangles.shape[0]], axis=1)


def _edge_candidates(tets, bad, boundary_edges, n_points, max_ring=MAX_RING):
    """Edge removals around the interior edges of the bad cells, grouped by ring size.

    Yields, for every ring size n with candidates, ``old`` (E, n), the cells around each edge;
    ``cells`` (E, 2 C, 4), the cells that a triangle of the ring (C of them) makes with either
    end of the edge; and ``table`` (T, 2n - 4), the columns of ``cells`` that make up each
    triangulation of the ring (T of them). Every triangle is shared by several triangulations,
    so evaluating the cells once and gathering them by ``table`` costs a third as much for a
    ring of six.
    """
    all_keys = edge_keys(tets[:, EDGE_OF_TET].reshape(-1, 2), n_points)
    order = np.argsort(all_keys, kind="stable")
    sorted_keys = all_keys[order]
    wanted = np.unique(edge_keys(tets[bad][:, EDGE_OF_TET].reshape(-1, 2), n_points))
    if boundary_edges.size:
        wanted = wanted[~in_sorted(wanted, boundary_edges)]
    start = np.searchsorted(sorted_keys, wanted, side="left")
    stop = np.searchsorted(sorted_keys, wanted, side="right")
    count = stop - start
    for n in range(3, max_ring + 1):
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
        triangles, table = _ring_tables(n)
        tri = ring[:, triangles]  # (E, C, 3), counter-clockwise seen from b
        shape = tri.shape[:2] + (1,)
        up = np.concatenate([tri, np.broadcast_to(b[:, None, None], shape)], 2)
        down = np.concatenate([tri[..., [0, 2, 1]], np.broadcast_to(a[:, None, None], shape)], 2)
        yield cells, np.concatenate([up, down], 1), table


def _label_values(labels: np.ndarray | None, old: np.ndarray, k: int) -> tuple:
    """The labels of ``k`` new cells replacing each row of ``old`` (all one label), for ``_apply``."""
    if labels is None:
        return ()
    return (np.repeat(labels[old[:, 0]][:, None], k, axis=1),)


def _apply(tets: np.ndarray, candidates: list, cell_values: list[np.ndarray], chosen_masks: list | None = None):
    """Apply the best candidates that replace disjoint sets of cells.

    ``candidates`` holds ``(old (K, n), new (K, k, 4), score (K,), values)`` groups, ``values`` a
    tuple of (K, k) arrays, one per entry of ``cell_values`` (M,): the new cells' values. A
    candidate is applied when it has the best score on every cell it replaces. ``chosen_masks``,
    when given, receives each group's (K,) mask of the candidates applied.

    Returns
    -------
    tets, cell_values : the updated cells and their values
    applied : number of candidates applied
    new_vertices : the vertices of the new cells (flat, with repeats)
    """
    score = np.concatenate([group[2] for group in candidates])
    rank_of = np.empty(score.size, dtype=np.int64)
    rank_of[np.argsort(-score, kind="stable")] = np.arange(score.size)
    best = np.full(tets.shape[0], np.iinfo(np.int64).max)
    ranks, offset = [], 0
    for old, *_ in candidates:
        rank = rank_of[offset : offset + old.shape[0]]
        ranks.append(rank)
        np.minimum.at(best, old, np.broadcast_to(rank[:, None], old.shape))
        offset += old.shape[0]
    remove = np.zeros(tets.shape[0], dtype=bool)
    added = [[] for _ in range(len(cell_values) + 1)]
    applied = 0
    for (old, new, _, values), rank in zip(candidates, ranks):
        chosen = (best[old] == rank[:, None]).all(axis=1)
        if chosen_masks is not None:
            chosen_masks.append(chosen)
        if not chosen.any():
            continue
        remove[old[chosen]] = True
        added[0].append(new[chosen].reshape(-1, 4))
        for column, value in zip(added[1:], values):
            column.append(value[chosen].reshape(-1))
        applied += int(chosen.sum())
    keep = ~remove
    tets = np.concatenate([tets[keep]] + added[0]).astype(np.int64)
    cell_values = [np.concatenate([value[keep]] + column) for value, column in zip(cell_values, added[1:])]
    new_vertices = np.concatenate(added[0]).ravel() if added[0] else np.zeros(0, dtype=np.int64)
    return tets, cell_values, applied, new_vertices


def flip_round(
    points: np.ndarray,
    tets: np.ndarray,
    quality: np.ndarray,
    threshold: float,
    boundary_edges: np.ndarray,
    active: np.ndarray | None = None,
    *,
    targets: ShapeTargets | None = None,
    labels: np.ndarray | None = None,
):
    """One round of flips on the cells whose score is below ``threshold``.

    Parameters
    ----------
    points : (N, 3) float array
    tets : (M, 4) int array, positively oriented
    quality : (M,) score of each cell (``targets.score``, degrees)
    threshold : cells below this score are improved
    boundary_edges : sorted edge keys (see :func:`edge_keys`) of the boundary surface; edges
        on the boundary are never removed.
    active : (N,) bool, optional
        Only bad cells with an active vertex are tried (the vertices whose surroundings
        changed since the last try); all bad cells when None.
    targets : ShapeTargets, optional
        The score (default targets).
    labels : (M,) int array, optional
        A label of each cell (its region): only cells of one label are flipped together, and
        the new cells take it. It is returned last, updated.

    Returns
    -------
    tets, quality : the new cells and their scores
    flips : number of flips applied
    touched : (N,) bool, the vertices of the new cells
    labels : the new cells' labels (only when ``labels`` is given)
    """
    score = (ShapeTargets() if targets is None else targets).score
    touched = np.zeros(points.shape[0], dtype=bool)
    bad_cells = np.flatnonzero(quality < threshold)
    if active is not None:
        bad_cells = bad_cells[active[tets[bad_cells]].any(axis=1)]
    unchanged = (tets, quality, 0, touched) + (() if labels is None else (labels,))
    if bad_cells.size == 0:
        return unchanged
    region, sub, bad = _region(points.shape[0], tets, bad_cells)
    old, new = _face_candidates(sub, face_neighbours(sub, points.shape[0]), bad)
    groups = [(old, new, score(points[new]))]
    for old, cells, table in _edge_candidates(sub, bad, boundary_edges, points.shape[0]):
        q_cells = score(points[cells])
        # each edge keeps its best triangulation
        best = table[np.argmax(q_cells[:, table].min(axis=2), axis=1)]
        rows = np.arange(old.shape[0])[:, None]
        groups.append((old, cells[rows, best], q_cells[rows, best]))
    candidates = []
    for old, new, q_new in groups:
        if old.shape[0] == 0:
            continue
        old = region[old]
        worst_new = q_new.min(axis=1)
        good = worst_new > quality[old].min(axis=1) + MIN_GAIN
        if labels is not None:
            good &= (labels[old] == labels[old[:, :1]]).all(axis=1)
        if good.any():
            values = (q_new[good],) + _label_values(labels, old[good], new.shape[1])
            candidates.append((old[good], new[good], worst_new[good], values))
    if not candidates:
        return unchanged
    tets, values, applied, new_vertices = _apply(tets, candidates, [quality] + ([] if labels is None else [labels]))
    touched[new_vertices] = True
    return (tets, values[0], applied, touched) + tuple(values[1:])


def shape_flip_round(
    points: np.ndarray,
    tets: np.ndarray,
    quality: np.ndarray,
    ratio: np.ndarray,
    ratio_threshold: float,
    floor: float,
    boundary_edges: np.ndarray,
    *,
    targets: ShapeTargets | None = None,
    labels: np.ndarray | None = None,
):
    """One round of flips that raise the radius ratio of the cells below ``ratio_threshold``.

    The same flips as :func:`flip_round`, ranked by the smallest radius ratio of the new cells:
    a flip is applied when it raises the smallest radius ratio of the cells it replaces and
    leaves no new cell with a score under ``min(floor, the replaced cells' smallest score)``.
    It lifts the mean shape (a Delaunay mesh keeps many cells that another local triangulation
    of the same points beats) without lowering the worst score.

    Parameters
    ----------
    points, tets : the mesh (positively oriented cells)
    quality : (M,) score of each cell (``targets.score``, degrees)
    ratio : (M,) radius ratio of each cell (:func:`~fepre.distmesh.tet_shape.radius_ratio`)
    ratio_threshold : cells below this radius ratio are improved
    floor : degrees; no flip creates a cell scoring under ``min(floor, scores of the cells it replaces)``
    boundary_edges : sorted edge keys of the boundary surface; never removed
    targets : ShapeTargets, optional
        The score (default targets).
    labels : (M,) int array, optional
        As in :func:`flip_round`; returned last when given.

    Returns
    -------
    tets, quality, ratio : the new cells, their scores and radius ratios
    flips : number of flips applied
    """
    measures = (ShapeTargets() if targets is None else targets).score_and_ratio
    bad_cells = np.flatnonzero(ratio < ratio_threshold)
    unchanged = (tets, quality, ratio, 0) + (() if labels is None else (labels,))
    if bad_cells.size == 0:
        return unchanged
    region, sub, bad = _region(points.shape[0], tets, bad_cells)
    candidates = []
    for old, cells, table in _edge_candidates(sub, bad, boundary_edges, points.shape[0], SHAPE_MAX_RING):
        if old.shape[0] == 0:
            continue
        old = region[old]
        q_cells, r_cells = measures(points[cells])
        required = np.minimum(quality[old].min(axis=1), floor)
        score = np.where(q_cells[:, table].min(axis=2) >= required[:, None], r_cells[:, table].min(axis=2), -1.0)
        choice = np.argmax(score, axis=1)
        rows = np.arange(old.shape[0])
        score = score[rows, choice]
        good = score > ratio[old].min(axis=1) + MIN_RATIO_GAIN
        if labels is not None:
            good &= (labels[old] == labels[old[:, :1]]).all(axis=1)
        if good.any():
            rows = rows[good, None]
            best = table[choice[good]]
            values = (q_cells[rows, best], r_cells[rows, best]) + _label_values(labels, old[good], best.shape[1])
            candidates.append((old[good], cells[rows, best], score[good], values))
    if not candidates:
        return unchanged
    tets, values, applied, _ = _apply(tets, candidates, [quality, ratio] + ([] if labels is None else [labels]))
    return (tets, values[0], values[1], applied) + tuple(values[2:])
