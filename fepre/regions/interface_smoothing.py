"""Moving interface nodes within their interface, to lift the worst cells next to it.

The per-region quality stage keeps the interface nodes fixed (a move changes the cells of both
regions), so the cells that touch an interface keep the shapes the loop left them; where a
lattice meets a skin at a grazing angle, a few stay under the targets. This pass moves the
interface nodes of such cells along the interface: random moves in the tangent plane, put back
on the interface, of which the one that raises the worst score of the node's cells (in every
region) most is kept; every cell stays positive. A node on the rim of an interface (on the
part's surface) moves along the rim, put back on the curve where the interface meets the
surface. Nodes the quality stage pins (the part's sharp edges and corners) do not move.

A node where the interface bends (its faces' normals spread by more than ``EDGE_ANGLE``) may lie
on a sharp edge of the interface, which a move along the surface would cut across, or on an edge
rounded over a voxel or so (a label image's flat cap meeting a curved side), where the loop left
nodes a fraction of h apart and the cells between them flat. Such a node takes only moves that
keep its interface faces on the interface: the centres of its faces and of their edges stay
within ``max(before, BEND_TOL h)`` of it, so a node on a sharp edge stays (a face across the edge
would stand off it) while one on a rounded edge slides along it.
"""

from __future__ import annotations

import numpy as np

from ..distmesh.node_moves import best_candidate
from ..distmesh.tet_topology import vertex_stars
from ..periodic.face_smoothing import CANDIDATES, MARGIN, ROUNDS
from .interface import interface_faces, onto_interface_rim
from .partition import RegionSet

__all__ = ["smooth_interface_nodes", "EDGE_ANGLE"]

#: Interface faces around a node whose normals differ by more than this (degrees) meet at a
#: sharp edge of the interface, or a rounded one: the node moves only if its faces stay on the interface.
EDGE_ANGLE = 20.0
#: A bent node's faces may stand this far (times h) off the interface after a move, or as far as before.
BEND_TOL = 1e-3


def _smooth_nodes(points: np.ndarray, faces: np.ndarray) -> np.ndarray:
    """(N,) bool: every interface face around the node is within ``EDGE_ANGLE`` of the mean normal."""
    normals = np.cross(points[faces[:, 1]] - points[faces[:, 0]], points[faces[:, 2]] - points[faces[:, 0]])
    normals /= np.maximum(np.linalg.norm(normals, axis=1), 1e-300)[:, None]
    mean = np.zeros_like(points)
    for k in range(3):
        np.add.at(mean, faces[:, k], normals)
    mean /= np.maximum(np.linalg.norm(mean, axis=1), 1e-300)[:, None]
    cosine = np.einsum("ij,ij->i", normals[:, None, :].repeat(3, axis=1).reshape(-1, 3), mean[faces.ravel()])
    worst = np.ones(len(points))
    np.minimum.at(worst, faces.ravel(), cosine)
    return worst >= np.cos(np.radians(EDGE_ANGLE))


def _face_deviation(candidates: np.ndarray, node: int, node_faces: np.ndarray, points: np.ndarray,
                    regions: RegionSet) -> np.ndarray:
    """(C,) the largest distance from the interface (the second-smallest region value) of the
    centres of ``node_faces`` and of their edges, with ``node`` at each of ``candidates`` (C, 3)."""
    corners = np.broadcast_to(points[node_faces], (len(candidates),) + node_faces.shape + (3,)).copy()
    corners[:, node_faces == node] = candidates[:, None, :]
    samples = np.concatenate([corners.mean(axis=2)[:, :, None], 0.5 * (corners + np.roll(corners, 1, axis=2))], axis=2)
    values = np.sort(np.abs(regions.values(samples.reshape(-1, 3))), axis=1)[:, 1]
    return values.reshape(len(candidates), -1).max(axis=1)


def smooth_interface_nodes(points: np.ndarray, tets: np.ndarray, region_ids: np.ndarray, regions: RegionSet, model,
                           h: float, targets, seed: int = 0, pinned: np.ndarray | None = None) -> tuple[np.ndarray, int]:
    """``(points, moves)``: ``points`` with the interface nodes of bad cells moved (see the module)."""
    points = points.copy()
    n = len(points)
    faces, first, second = interface_faces(tets, region_ids, n)
    if len(faces) == 0:
        return points, 0
    on_interface = np.zeros(n, dtype=bool)
    on_interface[faces.ravel()] = True
    side = np.full(n, -1, np.int64)
    side[faces.ravel()] = np.repeat(region_ids[first], 3)
    other = np.full(n, -1, np.int64)
    other[faces.ravel()] = np.repeat(region_ids[second], 3)
    rim = on_interface & (np.abs(np.asarray(model(points))) <= 1e-6 * h)
    bent = on_interface & ~_smooth_nodes(points, faces) & ~rim
    movable = on_interface.copy()
    if pinned is not None:
        movable &= ~pinned
    start, cell_ids = vertex_stars(tets, n)
    face_start, face_ids = vertex_stars(faces, n)
    score = targets.score
    quality = score(points[tets])
    rng = np.random.default_rng(seed)
    moves = 0
    for _ in range(ROUNDS):
        bad = np.flatnonzero(quality < targets.min_dihedral + MARGIN)
        nodes = np.unique(tets[bad].ravel())
        nodes = nodes[movable[nodes]]
        if nodes.size == 0:
            break
        moved_any = False
        for node in nodes.tolist():  # a handful: the interface nodes of the few bad cells
            star = cell_ids[start[node]:start[node + 1]]
            region = regions.models[side[node]]
            normal = region.gradient(points[node][None])[0]
            normal /= max(float(np.linalg.norm(normal)), 1e-300)
            offsets = rng.normal(size=(CANDIDATES, 3))
            offsets -= np.outer(offsets @ normal, normal)
            offsets *= (rng.uniform(0.02, 0.25, CANDIDATES) * h / np.maximum(np.linalg.norm(offsets, axis=1), 1e-300))[:, None]
            if rim[node]:
                candidates, on = onto_interface_rim(points[node] + offsets, model, regions, (side[node], other[node]), h)
            else:
                candidates = region.project(points[node] + offsets, iterations=20, tol=1e-6 * h, warn=False)
                on = regions.on_interface(candidates, 1e-4 * h) & (np.asarray(model(candidates)) < -1e-6 * h)
            candidates = candidates[on]
            if bent[node] and len(candidates):
                node_faces = faces[face_ids[face_start[node]:face_start[node + 1]]]
                before = _face_deviation(points[node][None], node, node_faces, points, regions)[0]
                candidates = candidates[_face_deviation(candidates, node, node_faces, points, regions) <= max(before, BEND_TOL * h)]
            moved = np.broadcast_to(points[tets[star]], (len(candidates), len(star), 4, 3)).copy()
            moved[:, tets[star] == node] = candidates[:, None, :]
            chosen = best_candidate(moved, quality[star].min(), score) if len(candidates) else None
            best = None if chosen is None else candidates[chosen]
            if best is not None:
                points[node] = best
                quality[star] = score(points[tets[star]])
                moves += 1
                moved_any = True
        if not moved_any:
            break
    return points, moves
