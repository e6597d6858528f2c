"""Moving face nodes of a periodic cell together with their partners, to lift the worst cells.

The quality stage keeps a periodic cell's face nodes fixed (a move must be made on every image
at once), so the cells that touch the faces keep the shapes the loop left them. Where a lattice
meets a face at a grazing angle, a few of them stay under the targets. This pass moves the face
nodes of such cells within their face: each node and its images (one period away) take the same
in-plane move (an edge node and its three images the same move along the edge); a face node on
the model's surface (on the rim of the face's solid) is put back on its zero curve in the plane.
Of a few dozen random candidate moves the one that raises the worst score of all the images'
cells most is kept; every cell stays positive. Corners, and edge nodes where the edge crosses the
model's surface, do not move.
"""

from __future__ import annotations

import numpy as np

from ..distmesh.tet_topology import vertex_stars
from .cell import PeriodicCell

__all__ = ["smooth_face_nodes"]

ROUNDS = 6
CANDIDATES = 32
#: cells scoring below the target plus this (degrees) are worked on
MARGIN = 3.0


def _in_plane_projection(model, points: np.ndarray, axis: int) -> np.ndarray:
    """Newton steps onto the model's zero set using the in-plane part of the gradient."""
    points = points.copy()
    for _ in range(8):
        values, gradient = model.value_and_gradient(points)
        gradient[:, axis] = 0.0
        norm2 = np.einsum("ij,ij->i", gradient, gradient)
        points -= (values / np.where(norm2 > 1e-300, norm2, 1.0))[:, None] * gradient
    return points


def smooth_face_nodes(points: np.ndarray, tets: np.ndarray, cell: PeriodicCell, model, h: float,
                      targets, seed: int = 0) -> tuple[np.ndarray, int]:
    """``(points, moves)``: ``points`` with face nodes of bad cells moved (see the module)."""
    from ..distmesh.node_moves import best_candidate
    from .nodes import match_faces

    points = points.copy()
    n = len(points)
    tol = cell.tolerance(h)
    slaves, masters, _, _ = match_faces(points, cell, tol)
    on_plane = cell.on_planes(points, tol)
    # a group: a master on a face (one plane) or an edge (two) and its images; corners stay
    order = np.argsort(masters, kind="stable")
    group_masters, first = np.unique(masters[order], return_index=True)
    planes = on_plane[group_masters].sum(axis=1)
    rim = np.abs(model(points[group_masters])) <= 1e-6 * h
    movable = (planes == 1) | ((planes == 2) & ~rim)
    images = np.split(slaves[order], first[1:])
    group_of = np.full(n, -1, np.int64)
    group_of[group_masters[movable]] = np.flatnonzero(movable)
    slave_group = np.repeat(np.arange(group_masters.size), np.diff(np.append(first, masters.size)))
    chosen = movable[slave_group]
    group_of[slaves[order][chosen]] = slave_group[chosen]
    start, cell_ids = vertex_stars(tets, n)
    score = targets.score
    quality = score(points[tets])
    rng = np.random.default_rng(seed)
    moves = 0
    for _ in range(ROUNDS):
        bad = np.flatnonzero(quality < targets.min_dihedral + MARGIN)
        groups = np.unique(group_of[tets[bad]].ravel())
        groups = groups[groups >= 0]
        if groups.size == 0:
            break
        moved_any = False
        for g in groups.tolist():  # a handful of groups: the face and edge nodes of the few bad cells
            nodes = np.concatenate([[group_masters[g]], images[g]])
            star = np.unique(np.concatenate([cell_ids[start[v]:start[v + 1]] for v in nodes]))
            free_axes = ~on_plane[group_masters[g]]
            offsets = rng.normal(size=(CANDIDATES, 3)) * free_axes
            offsets *= (rng.uniform(0.02, 0.25, CANDIDATES) * h / np.linalg.norm(offsets, axis=1))[:, None]
            base = points[nodes[0]]
            candidates = base + offsets
            if rim[g]:  # a face node on the rim: back onto the zero curve in its plane
                axis = int(np.flatnonzero(~free_axes)[0])
                candidates = _in_plane_projection(model, candidates, axis)
                candidates[:, axis] = base[axis]
            local = tets[star][..., None] == nodes  # (S, 4, images)
            moved = np.broadcast_to(points[tets[star]], (CANDIDATES, len(star), 4, 3)).copy()
            for k, node in enumerate(nodes):
                position = np.broadcast_to(points[node], (CANDIDATES, 3)).copy()
                position[:, free_axes] = candidates[:, free_axes]
                moved[:, local[..., k]] = position[:, None, :]
            chosen = best_candidate(moved, quality[star].min(), score)
            best = None if chosen is None else candidates[chosen]
            if best is not None:
                for node in nodes:
                    points[node, free_axes] = best[free_axes]
                quality[star] = score(points[tets[star]])
                moves += 1
                moved_any = True
        if not moved_any:
            break
    return points, moves
