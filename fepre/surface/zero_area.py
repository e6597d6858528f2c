"""Zero-area triangles with three distinct, collinear corners, flipped away without changing the surface.

Dual contouring puts the vertices of several cells on one crease line, and marching tetrahedra
cuts a few tetrahedra through an edge: a triangle ``(u, v, w)`` whose corner ``w`` lies on its
longest edge ``u v``. With the triangle ``(v, u, d)`` across that edge, the two cover exactly
the triangles ``(w, u, d)`` and ``(w, d, v)`` (``w`` splits ``u v``), so flipping the edge to
``w d`` removes the zero-area triangle and leaves the surface, its orientation and its topology
as they were. Flips whose new edge already exists are skipped (they would make it non-manifold);
where four or more corners are collinear the flips repeat, a few rounds.
"""

from __future__ import annotations

import numpy as np

__all__ = ["flip_zero_area"]

#: a triangle has zero area when twice its area is at most this times its longest side squared
ZERO_AREA = 1e-12
#: rounds of flips (each round flips triangles that share no edge)
_ROUNDS = 8


def _zero_area(points: np.ndarray, triangles: np.ndarray) -> np.ndarray:
    p = points[triangles]
    double_area = np.linalg.norm(np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0]), axis=1)
    longest = np.max([np.einsum("ij,ij->i", p[:, k] - p[:, (k + 1) % 3], p[:, k] - p[:, (k + 1) % 3]) for k in range(3)], axis=0)
    distinct = (triangles[:, 0] != triangles[:, 1]) & (triangles[:, 1] != triangles[:, 2]) & (triangles[:, 0] != triangles[:, 2])
    return distinct & (double_area <= ZERO_AREA * longest)


def flip_zero_area(points: np.ndarray, triangles: np.ndarray) -> np.ndarray:
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
        bad = np.flatnonzero(_zero_area(points, triangles))
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
