"""Zero-area triangles with three distinct, collinear corners, flipped away without changing the surface.

Dual contouring puts the vertices of several cells on one crease line, and marching tetrahedra
cuts a few tetrahedra through an edge: a triangle ``(u, v, w)`` whose corner ``w`` lies on its
longest edge ``u v``. With the triangle ``(v, u, d)`` across that edge, the two cover exactly
the triangles ``(w, u, d)`` and ``(w, d, v)`` (``w`` splits ``u v``), so flipping the edge to
``w d`` removes the zero-area triangle and leaves the surface, its orientation and its topology
as they were. Flips whose new edge already exists are skipped (they would make it non-manifold);
where four or more corners are collinear the flips repeat, a few rounds.

Two vertices at one point (two pieces of a cell whose vertices both land on a crease corner)
make the two triangles on their edge zero-area with no flip that helps: such an edge is
collapsed when its ends share no neighbour but the two opposite corners (the link condition,
so the surface stays a manifold of the same topology).
"""

from __future__ import annotations

import numpy as np

__all__ = ["collapse_coincident", "flip_zero_area", "remove_zero_area"]

#: a triangle has zero area when twice its area is at most this times the larger of its longest
#: side squared and the surface's mean side squared (the second is ``check_surface``'s test: far
#: from the origin, rounding leaves corners on a crease about 1e-12 off their line)
ZERO_AREA = 1e-12
#: rounds of flips (each round flips triangles that share no edge)
_ROUNDS = 8


def _measures(points: np.ndarray, triangles: np.ndarray) -> tuple[np.ndarray, np.ndarray, float]:
    """Squared double areas, squared longest sides and the mean side length, in one pass."""
    p = points[triangles]
    e0, e1 = p[:, 1] - p[:, 0], p[:, 2] - p[:, 1]
    e2 = -(e0 + e1)
    squared = [np.einsum("ij,ij->i", e, e) for e in (e0, e1, e2)]
    cross = np.cross(e0, e1)
    mean = float(sum(np.sqrt(q).sum() for q in squared) / (3 * len(p))) if len(p) else 0.0
    return np.einsum("ij,ij->i", cross, cross), np.maximum.reduce(squared), mean


def _zero_area(points: np.ndarray, triangles: np.ndarray, scale: float | None = None) -> tuple[np.ndarray, float]:
    """Zero-area triangles (three distinct corners) and the scale used (the mean side)."""
    double_area2, longest2, mean = _measures(points, triangles)
    scale = mean if scale is None else scale
    distinct = (triangles[:, 0] != triangles[:, 1]) & (triangles[:, 1] != triangles[:, 2]) & (triangles[:, 0] != triangles[:, 2])
    return distinct & (double_area2 <= (ZERO_AREA * np.maximum(longest2, scale * scale)) ** 2), scale


def remove_zero_area(points: np.ndarray, triangles: np.ndarray, tolerance: float) -> tuple[np.ndarray, np.ndarray]:
    """Collapse zero-length edges (:func:`collapse_coincident`), then flip zero-area triangles
    away (:func:`flip_zero_area`); one pass over the triangles when there are none."""
    zero, scale = _zero_area(np.asarray(points, dtype=np.float64), triangles)
    bad = np.flatnonzero(zero)
    if bad.size == 0:
        return points, triangles
    points, triangles = collapse_coincident(points, triangles, tolerance, candidates=bad)
    return points, flip_zero_area(np.asarray(points, dtype=np.float64), triangles, scale)


def flip_zero_area(points: np.ndarray, triangles: np.ndarray, scale: float | None = None) -> np.ndarray:
    """``triangles`` with the zero-area ones flipped away where a flip can do it (see the module).

    Examples
    --------
    >>> import numpy as np
    >>> points = np.array([[0, 0, 0], [2, 0, 0], [1, 0, 0], [1, 1, 0]], float)
    >>> # (0, 1, 2) has corner 2 on its edge 0-1; (1, 0, 3) is across that edge
    >>> flip_zero_area(points, np.array([[0, 1, 2], [1, 0, 3]])).tolist()
    [[2, 0, 3], [2, 3, 1]]
    """
    triangles = np.array(triangles, dtype=np.int64, copy=True)
    for _ in range(_ROUNDS):
        zero, scale = _zero_area(points, triangles, scale)
        bad = np.flatnonzero(zero)
        if bad.size == 0:
            break
        n = int(points.shape[0])
        p = points[triangles[bad]]
        lengths = np.stack([np.einsum("ij,ij->i", p[:, (k + 1) % 3] - p[:, k], p[:, (k + 1) % 3] - p[:, k]) for k in range(3)], axis=1)
        first = np.argmax(lengths, axis=1)  # the longest edge runs from corner first to first + 1
        rows = np.arange(bad.size)
        u = triangles[bad, first]
        v = triangles[bad, (first + 1) % 3]
        w = triangles[bad, (first + 2) % 3]
        # only triangles holding one of these vertices can be across u -> v or hold the new edge
        near = np.flatnonzero(np.isin(triangles, np.unique(np.concatenate([u, v, w]))).any(axis=1))
        directed = triangles[near][:, [0, 1, 1, 2, 2, 0]].reshape(-1, 2)
        keys = directed[:, 0] * n + directed[:, 1]
        order = np.argsort(keys)
        sorted_keys = keys[order]

        def lookup(key: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
            where = np.minimum(np.searchsorted(sorted_keys, key), sorted_keys.size - 1)
            return sorted_keys[where] == key, order[where]

        # the triangle across u -> v holds v -> u
        found, slot = lookup(v * n + u)
        other = np.where(found, near[slot // 3], -1)
        local = np.where(found, slot % 3, 0)
        d = triangles[np.maximum(other, 0), (local + 2) % 3]
        exists = lookup(w * n + d)[0] | lookup(d * n + w)[0]
        ok = found & ~exists & (d != w)
        # one flip per triangle per round: a triangle in two candidate flips keeps the first
        used = np.zeros(triangles.shape[0], dtype=bool)
        chosen = []
        for row in rows[ok]:  # the zero-area triangles only: a handful per surface
            a, b = bad[row], other[row]
            if used[a] or used[b]:
                continue
            used[a] = used[b] = True
            chosen.append(row)
        if not chosen:
            break
        chosen = np.asarray(chosen)
        triangles[bad[chosen]] = np.stack([w[chosen], u[chosen], d[chosen]], axis=1)
        triangles[other[chosen]] = np.stack([w[chosen], d[chosen], v[chosen]], axis=1)
    return triangles


def collapse_coincident(points: np.ndarray, triangles: np.ndarray, tolerance: float,
                        candidates: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
    """Collapse triangle edges no longer than ``tolerance`` where the link condition holds.

    ``candidates`` (indices of triangles, e.g. the zero-area ones) limits where short edges
    are looked for; a short edge makes both its triangles zero-area.

    Returns the used points and the renumbered triangles (unchanged when no edge is that short).

    Examples
    --------
    >>> import numpy as np
    >>> # a square pyramid's apex 4 and a copy 5 of it: the edge 4-5 is zero-length
    >>> points = np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0], [.5, .5, 1], [.5, .5, 1]], float)
    >>> triangles = np.array([[0, 2, 1], [0, 3, 2], [0, 1, 4], [1, 5, 4], [1, 2, 5], [2, 3, 5], [3, 4, 5], [3, 0, 4]])
    >>> p, t = collapse_coincident(points, triangles, 1e-9)
    >>> len(p), len(t)
    (5, 6)
    """
    triangles = np.asarray(triangles, dtype=np.int64)
    looked = np.arange(len(triangles)) if candidates is None else np.asarray(candidates, dtype=np.int64)
    p = points[triangles[looked]]
    short = np.stack([np.einsum("ij,ij->i", p[:, (k + 1) % 3] - p[:, k], p[:, (k + 1) % 3] - p[:, k]) for k in range(3)], axis=1)
    rows, first = np.nonzero(short <= tolerance * tolerance)
    rows = looked[rows]
    if rows.size == 0:
        return points, triangles
    ends = np.sort(np.stack([triangles[rows, first], triangles[rows, (first + 1) % 3]], axis=1), axis=1)
    ends = np.unique(ends[ends[:, 0] != ends[:, 1]], axis=0)
    touched = np.unique(ends)
    near = triangles[np.isin(triangles, touched).any(axis=1)]  # the triangles around the short edges
    representative = np.arange(len(points), dtype=np.int64)
    for a, b in ends:  # a handful per surface
        a, b = representative[a], representative[b]
        if a == b:
            continue
        ring = representative[near]
        around_a = set(ring[(ring == a).any(axis=1)].ravel().tolist()) - {a}
        around_b = set(ring[(ring == b).any(axis=1)].ravel().tolist()) - {b}
        on_edge = ring[(ring == a).any(axis=1) & (ring == b).any(axis=1)]
        opposite = set(on_edge.ravel().tolist()) - {a, b}
        # (a tetrahedron meets the link condition but would collapse to two triangles)
        if len(on_edge) != 2 or (around_a & around_b) != opposite or len((around_a | around_b) - {a, b}) < 3:
            continue
        representative[touched[representative[touched] == b]] = a
    if np.array_equal(representative, np.arange(len(points))):
        return points, triangles
    merged = representative[triangles]
    keep = (merged[:, 0] != merged[:, 1]) & (merged[:, 1] != merged[:, 2]) & (merged[:, 0] != merged[:, 2])
    merged = merged[keep]
    used = np.flatnonzero(np.bincount(merged.ravel(), minlength=len(points)))
    index = np.full(len(points), -1, dtype=np.int64)
    index[used] = np.arange(used.size)
    return points[used], index[merged]
