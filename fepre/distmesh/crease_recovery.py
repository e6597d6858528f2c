"""Crease segments put back: a boundary edge that cuts across a concave crease, flipped onto it.

Where a concave crease's nodes lie further apart than the surface nodes beside it (a graded
mesh's pocket edge), the final triangulation can join a node of one face to a node of the other
across the crease: two boundary faces ``u v w`` and ``u v x``, with ``w`` and ``x`` consecutive
nodes of a feature curve and ``uv`` cutting the corner. The crease segment ``wx`` is then no
mesh edge, and the two faces fill a wedge of the corner (a motor plate's pocket: centroids
0.39-0.48 off the surface, 0.16 h; the pocket's floor set short by 0.18%). Every node is on the
surface, so no check saw it, and the quality stage keeps boundary edges on creases but does not
make them.

:func:`recover_creases` flips each such ``uv`` to ``wx``: the open ring of cells around ``uv``
(from ``w`` to ``x``) is triangulated and joined to ``u`` and to ``v``, the triangulation whose
worst cell is best taken, and only when every new cell is valid. The boundary faces ``u v w``,
``u v x`` become ``u w x`` and ``v w x``, one on each face of the crease.
"""

from __future__ import annotations

import numpy as np

from .boundary_flips import _open_rings, best_ring_flips
from .flips import _apply
from .tet_shape import ShapeTargets
from .tet_topology import EDGE_OF_TET, edge_keys, face_neighbours, faces_on_boundary, in_sorted

__all__ = ["recover_creases", "BRIDGE", "ON_CURVE"]

#: ``uv`` cuts across a crease when its midpoint is at least this times its length outside the part
BRIDGE = 0.05
#: ``wx`` is a crease segment when its midpoint lies within this times h of a feature curve
ON_CURVE = 1e-6
#: the new cells' worst score (degrees) must be above this: valid, not merely less flat
MIN_SCORE = 1e-3
#: lone cells tried one at a time when removing them all at once would leave the boundary unsound
MAX_SINGLE = 20


def _crease_bridges(points: np.ndarray, tets: np.ndarray, model, features, h: float):
    """The boundary edges ``uv`` (keys, sorted) that cut across a crease segment ``wx`` of ``features``."""
    from .output import feature_flags

    n = points.shape[0]
    faces = faces_on_boundary(tets, face_neighbours(tets, n))
    on_curve = np.zeros(n, dtype=bool)
    surface = np.unique(faces)  # only boundary nodes can be feature nodes
    on_curve[surface] = feature_flags(points[surface], features) > 0
    if not on_curve.any():
        return np.zeros(0, np.int64)
    edges = np.concatenate([faces[:, [0, 1]], faces[:, [1, 2]], faces[:, [2, 0]]])
    opposite = np.concatenate([faces[:, 2], faces[:, 0], faces[:, 1]])
    keys = edge_keys(edges, n)
    order = np.argsort(keys, kind="stable")
    keys, edges, opposite = keys[order], edges[order], opposite[order]
    pair = np.flatnonzero(keys[:-1] == keys[1:])  # a closed surface: each edge in two faces
    u, v = edges[pair, 0], edges[pair, 1]
    w, x = opposite[pair], opposite[pair + 1]
    maybe = on_curve[w] & on_curve[x] & (w != x)
    u, v, w, x, pair = u[maybe], v[maybe], w[maybe], x[maybe], pair[maybe]
    if pair.size == 0:
        return np.zeros(0, np.int64)
    length = np.linalg.norm(points[u] - points[v], axis=1)
    across = 0.5 * (points[u] + points[v])
    maybe = np.asarray(model(across), dtype=float) > BRIDGE * length  # in the corner's void
    if not maybe.any():
        return np.zeros(0, np.int64)
    middle = 0.5 * (points[w[maybe]] + points[x[maybe]])
    distance, _ = features.distance(middle)
    bridges = keys[pair[maybe]][distance <= ON_CURVE * h]
    return np.unique(bridges)


def _lone_cells(tets: np.ndarray, bridges: np.ndarray, n: int) -> tuple[np.ndarray, np.ndarray]:
    """The bridges held by one cell only (a cell ``u v w x`` with both faces at ``uv`` on the
    boundary) and those cells: (B,) keys, (B,) cell indices."""
    keys = edge_keys(tets[:, EDGE_OF_TET].reshape(-1, 2), n)
    held = in_sorted(keys, bridges)
    found, counts = np.unique(keys[held], return_counts=True)
    lone = found[counts == 1]
    cells = np.flatnonzero(held)[in_sorted(keys[held], lone)] // 6
    return lone, cells


def recover_creases(points: np.ndarray, tets: np.ndarray, model, features, h: float,
                    targets: ShapeTargets | None = None, flips: bool = True) -> tuple[np.ndarray, int]:
    """The cells with every boundary edge that cuts across a crease segment flipped onto it;
    returns the cells and the number of changes (see the module docstring).

    A bridge held by one cell ``u v w x`` (both its faces at ``uv`` on the boundary: a cell the
    quality stage left in the corner's void) is removed instead, when its centroid is outside
    the part. ``flips=False`` makes only those removals (after the quality stage, whose cells a
    flip would leave unimproved).

    Examples
    --------
    Two boundary faces of a notch's corner join a node of its floor to one of its wall; the
    crease between them is put back:

    >>> import numpy as np
    >>> from fepre import sdf
    >>> from fepre.features import features
    >>> notch = sdf.box(2.0) - sdf.box(2.0, center=(1, 1, 0))   # a concave crease on the z axis
    >>> found = features(notch, h=0.5)
    >>> p = np.array([[0, 0, -0.25], [0, 0, 0.25], [0, 0.3, 0], [0.3, 0, 0], [-0.4, -0.4, 0]], float)
    >>> tets = np.array([[3, 2, 0, 4], [2, 3, 1, 4]])   # the edge 2-3 cuts the corner
    >>> new, flips = recover_creases(p, tets, notch, found, 0.5)
    >>> flips, sorted(map(sorted, new.tolist()))
    (1, [[0, 1, 2, 4], [0, 1, 3, 4]])
    """
    if features is None or not features.curves or tets.size == 0:
        return tets, 0
    targets = targets or ShapeTargets()
    n = points.shape[0]
    bridges = _crease_bridges(points, tets, model, features, h)
    if bridges.size == 0:
        return tets, 0
    lone, cells = _lone_cells(tets, bridges, n)
    outside = np.asarray(model(points[tets[cells]].mean(axis=1)), dtype=float) > 0
    tets, removed = _remove_soundly(tets, cells[outside], n)
    if removed:
        bridges = np.setdiff1d(bridges, lone[outside])
    if not flips or bridges.size == 0:
        return tets, removed
    quality = targets.score(points[tets])
    existing = np.unique(edge_keys(tets[:, EDGE_OF_TET].reshape(-1, 2), n))
    candidates = []
    for _, cells, ring, a, b in _open_rings(tets, bridges, n):
        new_edge = ~in_sorted(edge_keys(ring[:, [0, -1]], n), existing)  # wx is no edge yet
        cells, ring, a, b = cells[new_edge], ring[new_edge], a[new_edge], b[new_edge]
        if cells.size == 0:
            continue
        new_cells, scores, worst = best_ring_flips(points, ring, a, b, targets)
        valid = worst > MIN_SCORE
        if valid.any():
            candidates.append((cells[valid], new_cells[valid], worst[valid], (scores[valid],)))
    if not candidates:
        return tets, removed
    flipped, _, applied, _ = _apply(tets, candidates, [quality])
    if not _sound(flipped, n):  # a flip that glued the surface wrongly: none is made
        return tets, removed
    return flipped, removed + int(applied)


def _sound(tets: np.ndarray, n: int) -> bool:
    """No face in three cells, and a boundary that is an edge-manifold without pinched vertices."""
    from .topology import check_topology

    report = check_topology(tets, n)
    return report.overused_faces == 0 and report.nonmanifold_edges == 0 and report.pinched_vertices == 0


def _remove_soundly(tets: np.ndarray, cells: np.ndarray, n: int) -> tuple[np.ndarray, int]:
    """``tets`` without ``cells``, or without those of them whose removal keeps the boundary an
    edge-manifold (one by one, up to ``MAX_SINGLE`` of them, when all at once does not): a lone
    cell whose other faces are on the boundary too, or whose crease segment is a boundary edge
    already, would leave it open or pinched (a Thingiverse model's thin fin at D/50)."""
    if cells.size == 0:
        return tets, 0
    together = np.delete(tets, cells, axis=0)
    if _sound(together, n):
        return together, int(cells.size)
    kept, removed = tets, 0
    for cell in cells[:MAX_SINGLE]:
        row = np.flatnonzero((kept == tets[cell]).all(axis=1))
        trial = np.delete(kept, row, axis=0)
        if row.size == 1 and _sound(trial, n):
            kept, removed = trial, removed + 1
    return kept, removed
