"""An edge split whose new vertex lies beyond the edge's own cells: the cells around it re-coned.

:func:`~fepre.distmesh.surface_refine.split_edges` replaces each cell around an edge by its
two halves at the new vertex, so the vertex must lie inside the union of those cells (the
edge's *ring*). A boundary edge that bridges a valley of the surface (a chord whose midpoint
lies off the zero set) gets its new vertex on the zero set, below the chord; on a wall thinner
than 2 h the ring is a few flat cells whose other vertices are on the surface too, and the
projected midpoint lies beyond them: every half is inverted and the split is refused. Measured
on skull_low_resolution.obj (odedstein/meshes) at h = D/50: a 2.62 h boundary edge on a bone
0.84 h thick, its midpoint 0.35 h outside, its ring two cells whose halves all had negative
volume; the gap stayed through the surface refinement and every insertion round (a 16.4 deg
cell on it).

:func:`cavity_split` inserts the vertex as Delaunay refinement does, into a *cavity*: starting
from the ring, every cell across a face that the new vertex does not see from inside is added,
until the vertex sees every face of the cavity's border (it is star-shaped from the vertex) or
the cavity would cross the mesh's boundary; then the cavity's cells are replaced by the new
vertex joined to its border's faces, except the boundary faces on the edge, which become two
faces each through the new vertex (as in a plain split). A plain split is this with the ring as
the cavity.
"""

from __future__ import annotations

import numpy as np

from .tet_shape import ShapeTargets, signed_volume
from .tet_topology import FACE_OF_TET, NonManifoldCells, face_neighbours

__all__ = ["cavity_split", "CAVITY_CELLS"]

#: Cells a cavity may hold at most (a ring is 2-8; the skull's gap took 5).
CAVITY_CELLS = 48


def cavity_split(
    points: np.ndarray,
    tets: np.ndarray,
    model,
    h: float,
    edge,
    max_projection: float = 0.3,
    neighbours: np.ndarray | None = None,
    beyond_ring: bool = False,
    locked: np.ndarray | None = None,
) -> tuple[np.ndarray, np.ndarray, bool]:
    """Split ``edge`` (its two vertex numbers) at its midpoint (projected onto the model's zero set
    when it is a boundary edge) into a star-shaped cavity of cells grown from its ring.

    Parameters
    ----------
    points : (N, 3) float array
    tets : (M, 4) int array, positively oriented, forming a solid
    model : fepre.sdf.SDF
        The mesh's model: a boundary edge's new vertex lies on its zero set.
    h : float
        The edge length (sets the tolerances).
    edge : pair of int
    max_projection : float
        The new vertex may lie at most this fraction of the edge's length from its midpoint.
    neighbours : (M, 4) int array, optional
        ``face_neighbours(tets, N)``, when the caller has it.
    beyond_ring : bool
        Refuse the split when the edge's ring is the cavity (a plain split, which
        :func:`~fepre.distmesh.surface_refine.split_edges` makes).
    locked : (N,) bool, optional
        Vertices whose faces must stay (the faces between two regions of a region mesh): an
        edge between two of them is not split, and a cavity never grows across a face of three.

    Returns
    -------
    points : (N + 1, 3) with the new vertex appended, or ``points`` when refused
    tets : the cells, the cavity's replaced (appended at the end)
    done : bool
        False when the split is refused (the vertex off the model or too far from the midpoint,
        a cavity reaching the boundary, a locked face or over ``CAVITY_CELLS``, a vertex
        swallowed, a new cell of zero score, a face used three times).

    Examples
    --------
    Four cells inscribed in the unit sphere: an edge between two surface vertices is split, its
    new vertex on the sphere, and the cells still fill a solid of positive cells.

    >>> import numpy as np
    >>> from fepre import sdf
    >>> r = 1 / np.sqrt(3)
    >>> points = np.array([[0.0, 0.0, 0.0], [r, r, r], [r, -r, -r], [-r, r, -r], [-r, -r, r]])
    >>> tets = np.array([[0, 1, 2, 3], [0, 1, 4, 2], [0, 1, 3, 4], [0, 2, 4, 3]])
    >>> new_points, new_tets, done = cavity_split(points, tets, sdf.sphere(1.0), 0.5, (1, 2))
    >>> done, len(new_tets), bool(np.isclose(np.linalg.norm(new_points[-1]), 1.0))
    (True, 6, True)
    """
    u, v = int(edge[0]), int(edge[1])
    n = points.shape[0]
    refused = (points, tets, False)
    if locked is not None and locked[u] and locked[v]:
        return refused
    if neighbours is None:
        neighbours = face_neighbours(tets, n)
    ring = np.flatnonzero((tets == u).any(axis=1) & (tets == v).any(axis=1))
    if ring.size == 0:
        return refused
    # the edge is on the boundary when a cell on it has a boundary face holding it
    local_u = np.argmax(tets[ring] == u, axis=1)
    local_v = np.argmax(tets[ring] == v, axis=1)
    on_edge_face = np.ones((ring.size, 4), dtype=bool)
    on_edge_face[np.arange(ring.size), local_u] = False
    on_edge_face[np.arange(ring.size), local_v] = False
    boundary = bool(((neighbours[ring] < 0) & on_edge_face).any())
    middle = 0.5 * (points[u] + points[v])
    length = float(np.linalg.norm(points[u] - points[v]))
    new = model.project(middle[None], iterations=20, tol=1e-6 * h, warn=False)[0] if boundary else middle
    value = float(model(new[None])[0])
    if np.linalg.norm(new - middle) > max_projection * length or (abs(value) > 1e-3 * h if boundary else value >= 0):
        return refused
    cavity = _grow(points, tets, neighbours, ring, new, u, v, locked)
    if cavity is None or (beyond_ring and cavity.size == ring.size):
        return refused
    cones, kept_vertices = _cones(tets, neighbours, cavity, n, u, v)
    removed = np.unique(tets[cavity])
    if not np.isin(removed, kept_vertices).all():
        return refused  # a vertex inside the cavity would be lost
    all_points = np.concatenate([points, new[None]])
    if (ShapeTargets().score(all_points[cones]) <= 0).any():
        return refused
    keep = np.ones(tets.shape[0], dtype=bool)
    keep[cavity] = False
    new_tets = np.concatenate([tets[keep], cones])
    try:
        face_neighbours(new_tets, n + 1)
    except NonManifoldCells:
        return refused
    return all_points, new_tets, True


def _border(tets, neighbours, cavity: np.ndarray, u: int, v: int):
    """The faces of the cavity's border the new vertex is joined to (all but the boundary faces
    on the edge), as (cells, local vertex opposite, cell across) of those faces."""
    cells = np.repeat(cavity, 4)
    local = np.tile(np.arange(4), cavity.size)
    across = neighbours[cells, local]
    corners = tets[cells]
    opposite = corners[np.arange(cells.size), local]
    holds_edge = (corners == u).any(axis=1) & (corners == v).any(axis=1) & (opposite != u) & (opposite != v)
    face = ~np.isin(across, cavity) & ~(holds_edge & (across < 0))
    return cells[face], local[face], across[face]


def _grow(points, tets, neighbours, ring: np.ndarray, new: np.ndarray, u: int, v: int,
          locked: np.ndarray | None = None) -> np.ndarray | None:
    """The cavity: the ring and every cell across a face the new vertex does not see from inside
    (the cone on it would not be positive), until none is left; None when such a face is on the
    boundary (off the edge) or has three ``locked`` vertices, or the cavity grows over
    ``CAVITY_CELLS``."""
    cavity = ring
    scale = float(np.linalg.norm(points[u] - points[v])) ** 3
    while cavity.size <= CAVITY_CELLS:
        cells, local, across = _border(tets, neighbours, cavity, u, v)
        cone = points[tets[cells]]
        cone[np.arange(cells.size), local] = new
        blind = signed_volume(cone) <= 1e-9 * scale
        if not blind.any():
            return cavity
        if (across[blind] < 0).any():
            return None
        if locked is not None:
            corners = tets[cells[blind]]
            face = corners[np.arange(corners.shape[0])[:, None], FACE_OF_TET[local[blind]]]
            if locked[face].all(axis=1).any():
                return None
        cavity = np.union1d(cavity, across[blind])
    return None


def _cones(tets, neighbours, cavity: np.ndarray, n: int, u: int, v: int) -> tuple[np.ndarray, np.ndarray]:
    """The new cells (the new vertex, numbered ``n``, joined to each face of the cavity's border
    but the boundary faces on the edge) and the vertices they use."""
    cells, local, _ = _border(tets, neighbours, cavity, u, v)
    cones = tets[cells].copy()
    cones[np.arange(cells.size), local] = n
    return cones, np.unique(cones[cones < n])
