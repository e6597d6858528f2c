"""From the loop's final points to a valid tetrahedral solid.

The final Delaunay triangulation, minus the cells whose centroid is outside (sdf >= -geps), is
repaired until it is a valid solid: boundary nodes on the zero set, a closed manifold boundary,
no flat or inverted cells and no unused points.
"""

from __future__ import annotations

import numpy as np

from ..errors import MeshingError
from ..quality import signed_volumes
from .delaunay import tetrahedralize
from .topology import boundary_faces, nonmanifold_items, tet_faces

__all__ = ["final_mesh", "compact"]

_ROUNDS = 12


def compact(points: np.ndarray, tets: np.ndarray, *arrays: np.ndarray):
    """Drop unused points; returns (points, tets, *arrays) renumbered."""
    used = np.zeros(len(points), bool)
    used[tets.ravel()] = True
    new_index = np.cumsum(used) - 1
    return (points[used], new_index[tets], *(a[used] for a in arrays))


def _snap_boundary(model, points, tets, fixed, h, tol) -> np.ndarray:
    """Project boundary nodes onto the zero set; returns the nodes that did not get there."""
    nodes = np.unique(boundary_faces(tets))
    nodes = nodes[~fixed[nodes]]
    values = model(points[nodes])
    off = nodes[np.abs(values) > tol]
    if len(off):
        points[off] = model.project(points[off], iterations=20, tol=0.05 * tol)
        still = np.abs(model(points[off])) > tol
        return off[still]
    return off


def final_mesh(
    model,
    points: np.ndarray,
    fixed: np.ndarray,
    h: float,
    geps: float,
    backend: str,
    previous: np.ndarray | None = None,
):
    """Triangulate ``points`` and repair the result into a valid solid.

    ``previous`` is a triangulation of (nearly) the same points, the loop's last one: it is
    reused when every cell is still positive (the reference also returns its last
    triangulation); otherwise the points are triangulated again. Returns ``(points, tets,
    fixed)`` with only the points used. Raises ``MeshingError`` when the repair does not reach
    a valid mesh.
    """
    tol = 1e-3 * h
    points = points.copy()
    values = model(points)
    outside = np.flatnonzero((values > 0) & ~fixed)
    if len(outside):
        points[outside] = model.project(points[outside], iterations=20, tol=0.05 * tol)
        values[outside] = model(points[outside])
    tets = previous
    if tets is None or len(tets) == 0 or signed_volumes(points, tets).min() <= 1e-9 * h**3:
        tets = tetrahedralize(points, backend, h)
    # Drop cells outside (centroid sdf >= 0) and the flat cells spanning the surface (four
    # surface nodes, centroid within geps of it). Unlike the loop's rule (centroid sdf >= -geps)
    # this keeps cells with an interior node, which would otherwise be left on the surface.
    centroids = points[tets].mean(axis=1)
    centroid_values = model(centroids)
    on_surface = np.abs(values) <= 10 * tol
    flat = on_surface[tets].all(axis=1) & (centroid_values >= -geps * h)
    tets = tets[(centroid_values < 0) & ~flat]
    for _ in range(_ROUNDS):
        if len(tets) == 0:
            raise MeshingError("DistMesh produced no tetrahedra inside the domain; try a smaller h")
        unsnapped = _snap_boundary(model, points, tets, fixed, h, tol)
        remove = np.zeros(len(tets), bool)
        # cells flattened or inverted (by the snapping or by Delaunay degeneracy)
        volumes = signed_volumes(points, tets)
        remove |= volumes <= 1e-9 * h**3
        # cells touching a boundary node that cannot reach the zero set
        if len(unsnapped):
            remove |= np.isin(tets, unsnapped).any(axis=1)
        # non-manifold boundary: peel the cells with a boundary face at the defect
        faces = boundary_faces(tets)
        bad_edges, pinched = nonmanifold_items(faces, len(points))
        if len(bad_edges) or len(pinched):
            defect = np.zeros(len(points), bool)
            defect[bad_edges.ravel()] = True
            defect[pinched] = True
            _, counts, inverse = tet_faces(tets)
            on_boundary = (counts[inverse] == 1).reshape(-1, 4).any(axis=1)
            remove |= on_boundary & defect[tets].any(axis=1)
        if not remove.any():
            break
        tets = tets[~remove]
    else:
        raise MeshingError(
            f"DistMesh could not repair the final mesh into a valid solid after {_ROUNDS} rounds; "
            "try a smaller h or a larger geps"
        )
    points, tets, fixed = compact(points, tets, fixed)
    return points, tets, fixed
