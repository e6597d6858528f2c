"""Removal of flat cells on the boundary, which flips and sliding cannot repair.

Two kinds of bad cell sit on the boundary surface and resist the other operations:

* four boundary vertices and two boundary faces (a flat cap on the surface): removing it flips
  the boundary edge ``ab`` shared by its two boundary faces to the opposite edge ``cd``;
* three boundary vertices (one boundary face ``abc``) and a fourth vertex ``d`` just under the
  surface: removing it exposes its other three faces, and ``d`` is projected onto the zero set
  and becomes a boundary vertex.

Both keep the boundary a closed manifold (checked through the boundary edge keys), change the
volume by about the flat cell's volume, and leave every boundary vertex on the zero set. Only cells
whose centroid lies within ``0.1 h`` of the zero set are removed, and a boundary edge is flipped
only between nearly coplanar faces (normals within ``CREASE_ANGLE``), never on a crease; except
that within :func:`bridges_removed` a cap whose centroid lies outside the part beyond ``0.1 h`` (a
bridge over a valley of a faceted surface: ur3_base.stl's worst cell at D/50, 13.9 deg, 0.17 h
out) goes whatever the angle of its ridge. The cells removed in one call share no vertex.
"""

from __future__ import annotations

from contextlib import contextmanager
from contextvars import ContextVar

import numpy as np

from .surface_guard import SurfaceGuard
from .tet_shape import ShapeTargets
from .tet_topology import FACE_OF_TET, edge_keys, face_keys, in_sorted

__all__ = ["remove_boundary_slivers", "expose_shallow_vertices", "bridges_removed"]

#: whether caps out in the air over a valley are removed too (see :func:`bridges_removed`)
_BRIDGES: ContextVar[bool] = ContextVar("bridges", default=False)


@contextmanager
def bridges_removed():
    """Within the block, :func:`remove_boundary_slivers` also removes bad caps whose centroid
    lies outside the part beyond ``FLAT_DEPTH`` (bridges over a valley of a faceted surface),
    whatever the angle of their ridge, where the faces they expose are no farther from the
    surface and no further turned from it than theirs."""
    token = _BRIDGES.set(True)
    try:
        yield
    finally:
        _BRIDGES.reset(token)


#: A vertex this close to the zero set (times h) may be exposed onto it.
SHALLOW = 0.25
#: Only cells whose centroid is this close to the zero set (times h) are removed: flat cells on
#: the surface, never cells spanning a concave region or the inside.
FLAT_DEPTH = 0.1
#: Boundary faces whose normals differ by more than this (degrees) meet at a crease of the part
#: (the angle of :func:`fepre.distmesh.finalize.crease_nodes`): their common edge is never flipped.
CREASE_ANGLE = 30.0


def _unit_normals(triangles: np.ndarray) -> np.ndarray:
    """Unit normals of (K, 3, 3) triangles (right-hand rule)."""
    normals = np.cross(triangles[:, 1] - triangles[:, 0], triangles[:, 2] - triangles[:, 0])
    return normals / np.maximum(np.linalg.norm(normals, axis=1), 1e-300)[:, None]


def _smooth_across(points: np.ndarray, first: np.ndarray, second: np.ndarray) -> np.ndarray:
    """True where faces ``first`` and ``second`` (N, 3) are within ``CREASE_ANGLE`` of parallel
    (orientation ignored: the faces of one cell face different ways)."""
    cosine = np.abs(np.einsum("ij,ij->i", _unit_normals(points[first]), _unit_normals(points[second])))
    return cosine >= np.cos(np.radians(CREASE_ANGLE))


def _vertex_disjoint(cells: np.ndarray, priority: np.ndarray, allowed: np.ndarray, n: int) -> np.ndarray:
    """Allowed candidates (rows of ``cells``) sharing no vertex, lowest ``priority`` first."""
    rank = np.full(cells.shape[0], np.iinfo(np.int64).max)
    keep = np.flatnonzero(allowed)
    rank[keep[np.argsort(priority[keep], kind="stable")]] = np.arange(keep.size)
    holder = np.full(n, np.iinfo(np.int64).max)
    np.minimum.at(holder, cells, np.broadcast_to(rank[:, None], cells.shape))
    return allowed & (holder[cells] == rank[:, None]).all(axis=1)


def remove_boundary_slivers(
    points: np.ndarray,
    tets: np.ndarray,
    quality: np.ndarray,
    threshold: float,
    on_boundary: np.ndarray,
    boundary_face_keys: np.ndarray,
    boundary_edges: np.ndarray,
    model,
    h: float,
    *,
    guard: SurfaceGuard | None = None,
    locked: np.ndarray | None = None,
) -> tuple[np.ndarray, np.ndarray, int, np.ndarray, np.ndarray]:
    """Remove bad cells with four boundary vertices and two boundary faces.

    Removing one exposes its other two faces, whose vertices are all on the zero set: the
    boundary surface undergoes an edge flip (``ab`` to ``cd``), which keeps it a closed manifold
    as long as ``cd`` is not already a boundary edge. With a ``guard``, the exposed faces must
    lie on the surface (:meth:`~fepre.distmesh.surface_guard.SurfaceGuard.faces_allowed`).

    Returns
    -------
    tets, quality : the remaining cells
    removed : number of cells removed
    boundary_face_keys, boundary_edges : the updated sorted keys of the boundary surface
    """
    n = points.shape[0]
    candidates = np.flatnonzero(quality < threshold)
    candidates = candidates[on_boundary[tets[candidates]].all(axis=1)]
    if candidates.size == 0:
        return tets, quality, 0, boundary_face_keys, boundary_edges
    cells = tets[candidates]
    keys = face_keys(cells[:, FACE_OF_TET].reshape(-1, 3), n).reshape(-1, 4)
    on_surface = in_sorted(keys, boundary_face_keys)
    two = on_surface.sum(axis=1) == 2
    cells, candidates, on_surface, keys = cells[two], candidates[two], on_surface[two], keys[two]
    if candidates.size == 0:
        return tets, quality, 0, boundary_face_keys, boundary_edges
    # c, d: the vertices opposite the two boundary faces; a, b: the edge those faces share.
    order = np.argsort(~on_surface, axis=1, kind="stable")
    c_d = np.take_along_axis(cells, order[:, :2], axis=1)
    a_b = np.take_along_axis(cells, order[:, 2:], axis=1)
    new_edge = edge_keys(c_d, n)
    allowed = ~in_sorted(new_edge, boundary_edges)
    if locked is not None:  # faces between locked vertices stay (a periodic cell's faces)
        allowed &= ~locked[cells].all(axis=1)
    centroids = points[cells].mean(axis=1)
    scale = h if guard is None else guard.length(centroids)
    value = np.asarray(model(centroids), dtype=float)
    # the two boundary faces must be nearly coplanar: an edge on a crease of the part is never
    # flipped; a cell out in the air (centroid outside beyond FLAT_DEPTH) bridges a valley, and
    # its ridge ``ab`` is no crease of the part: removing it takes away material the part has not
    rows = np.arange(cells.shape[0])[:, None]
    normals = [_unit_normals(points[cells[rows, FACE_OF_TET[order[:, k]]]]) for k in (0, 1)]
    coplanar = np.einsum("ij,ij->i", normals[0], normals[1]) >= np.cos(np.radians(CREASE_ANGLE))
    bridge = (value > FLAT_DEPTH * scale) & _BRIDGES.get()
    allowed &= ((np.abs(value) <= FLAT_DEPTH * scale) & coplanar) | bridge
    if guard is not None and allowed.any():
        check = np.flatnonzero(allowed)
        # the faces opposite a and b, seen from outside once the cell is gone
        exposed = [cells[check[:, None], FACE_OF_TET[order[check, k]]][:, ::-1] for k in (2, 3)]
        fine = guard.faces_allowed(None, points[np.concatenate(exposed)]).reshape(2, -1).all(axis=0)
        # a bridge's faces lie off the surface: the exposed ones need only be no farther
        over = bridge[check]
        if over.any():
            old = np.stack([points[cells[check[over, None], FACE_OF_TET[order[check[over], k]]]] for k in (0, 1)], axis=1)
            new = np.stack([points[faces[over]] for faces in exposed], axis=1)
            fine[over] = guard.replacements_allowed(old, new)
        allowed[check[~fine]] = False
    chosen = _vertex_disjoint(cells, quality[candidates], allowed, n)
    if not chosen.any():
        return tets, quality, 0, boundary_face_keys, boundary_edges
    removed_faces = keys[chosen][on_surface[chosen]]
    exposed_faces = keys[chosen][~on_surface[chosen]]
    boundary_face_keys = np.union1d(np.setdiff1d(boundary_face_keys, removed_faces), exposed_faces)
    boundary_edges = np.union1d(np.setdiff1d(boundary_edges, edge_keys(a_b[chosen], n)), new_edge[chosen])
    keep_cells = np.ones(tets.shape[0], dtype=bool)
    keep_cells[candidates[chosen]] = False
    return tets[keep_cells], quality[keep_cells], int(chosen.sum()), boundary_face_keys, boundary_edges



def expose_shallow_vertices(
    points: np.ndarray,
    tets: np.ndarray,
    quality: np.ndarray,
    threshold: float,
    on_boundary: np.ndarray,
    movable: np.ndarray,
    boundary_face_keys: np.ndarray,
    boundary_edges: np.ndarray,
    model,
    h: float,
    surface_tol: float,
    *,
    targets: ShapeTargets | None = None,
    guard: SurfaceGuard | None = None,
    locked: np.ndarray | None = None,
):
    """Remove bad cells made of a boundary face and a vertex just under it; project that vertex.

    A candidate is accepted when the projected vertex reaches the zero set (within
    ``surface_tol``), the exposed faces lie on the surface (with a ``guard``, which then records
    the vertex's patch) and no other cell around it becomes invalid or scores worse than
    ``min(its score, the removed cell's score)`` (``targets.score``).

    Returns
    -------
    points, tets, quality, exposed, on_boundary, boundary_face_keys, boundary_edges
    """
    n = points.shape[0]
    score = (ShapeTargets() if targets is None else targets).score
    unchanged = (points, tets, quality, 0, on_boundary, boundary_face_keys, boundary_edges)
    candidates = np.flatnonzero(quality < threshold)
    candidates = candidates[on_boundary[tets[candidates]].sum(axis=1) == 3]
    if candidates.size == 0:
        return unchanged
    cells = tets[candidates]
    rows = np.arange(candidates.size)
    local = np.argmin(on_boundary[cells], axis=1)
    vertex = cells[rows, local]
    face = cells[rows[:, None], FACE_OF_TET[local]]
    allowed = in_sorted(face_keys(face, n), boundary_face_keys) & movable[vertex]
    if locked is not None:  # a face between locked vertices stays (a periodic cell's faces)
        allowed &= ~locked[face].all(axis=1)
    centroids = points[cells].mean(axis=1)
    scale = h if guard is None else guard.length(centroids)
    allowed &= model(points[vertex]) > -SHALLOW * scale
    allowed &= np.abs(model(centroids)) <= FLAT_DEPTH * scale
    # the exposed faces continue the removed one: no face of them crosses a crease
    for k in range(3):
        exposed = face.copy()
        exposed[:, k] = vertex
        allowed &= _smooth_across(points, face, exposed)
    chosen = _vertex_disjoint(cells, quality[candidates], allowed, n)
    if not chosen.any():
        return unchanged
    cells, candidates, vertex = cells[chosen], candidates[chosen], vertex[chosen]
    projected = model.project(points[vertex], iterations=20, tol=0.05 * surface_tol, warn=False)
    reached = np.abs(model(projected)) <= surface_tol
    if guard is not None:
        reached &= guard.in_own_region(vertex, projected)
    if guard is not None and reached.any():
        check = np.flatnonzero(reached)
        local_of = np.argmax(cells[check] == vertex[check, None], axis=1)
        # the removed cell's three faces around the vertex, seen from outside once it is gone
        others = np.stack([FACE_OF_TET[(local_of + k) % 4] for k in range(1, 4)], axis=1)  # (K, 3, 3)
        faces = np.take_along_axis(cells[check][:, None, :], others, axis=2)[..., ::-1].reshape(-1, 3)
        old = points[faces]
        new = old.copy()
        at_vertex = faces == np.repeat(vertex[check], 3)[:, None]
        new[at_vertex] = np.repeat(projected[check], 3, axis=0)
        fine = guard.faces_allowed(old, new).reshape(-1, 3).all(axis=1)
        reached[check[~fine]] = False
    cells, candidates, vertex, projected = cells[reached], candidates[reached], vertex[reached], projected[reached]
    removed_quality = quality[candidates]
    new_points = points.copy()
    keep = np.ones(tets.shape[0], dtype=bool)
    keep[candidates] = False
    accepted = np.ones(vertex.size, dtype=bool)
    while accepted.any():
        new_points[vertex] = np.where(accepted[:, None], projected, points[vertex])
        moved = np.zeros(n, dtype=bool)
        moved[vertex[accepted]] = True
        star = np.flatnonzero(keep & moved[tets].any(axis=1))
        limit = np.full(n, np.inf)
        np.minimum.at(limit, vertex[accepted], removed_quality[accepted])
        allowed_quality = np.minimum(quality[star], limit[tets[star]].min(axis=1))
        new_quality = score(new_points[tets[star]])
        failing = (new_quality <= 0) | (new_quality < allowed_quality - 1e-9)
        if not failing.any():
            break
        culprits = np.zeros(n, dtype=bool)
        culprits[tets[star[failing]]] = True
        rejected = accepted & culprits[vertex]
        accepted &= ~rejected
        keep[candidates[rejected]] = True
        new_points[vertex[rejected]] = points[vertex[rejected]]
    if not accepted.any():
        return unchanged
    quality = quality.copy()
    quality[star] = new_quality
    cells, vertex = cells[accepted], vertex[accepted]
    all_faces = face_keys(cells[:, FACE_OF_TET].reshape(-1, 3), n).reshape(-1, 4)
    local = np.argmax(cells == vertex[:, None], axis=1)
    surface_face = all_faces[np.arange(cells.shape[0]), local]
    exposed = all_faces[np.arange(4)[None, :] != local[:, None]]
    boundary_face_keys = np.union1d(np.setdiff1d(boundary_face_keys, surface_face), exposed)
    others = cells[np.arange(4)[None, :] != local[:, None]].reshape(-1, 3)
    new_edges = edge_keys(np.stack([others.ravel(), np.repeat(vertex, 3)], axis=1), n)
    boundary_edges = np.union1d(boundary_edges, new_edges)
    on_boundary = on_boundary.copy()
    on_boundary[vertex] = True
    if guard is not None:
        guard.add(vertex, new_points)
    return (new_points, tets[keep], quality[keep], int(accepted.sum()), on_boundary, boundary_face_keys, boundary_edges)
