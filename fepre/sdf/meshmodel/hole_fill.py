"""Close the holes of a triangle surface with smooth patches.

Every boundary loop that is a simple cycle is filled with rings of triangles shrinking to its
centroid, about one rim edge apart, and the new vertices are then placed by a bi-Laplacian
fairing (Liepa 2003): they solve ``L^2 x = 0`` with the rim and one ring of the surrounding surface
held, so the patch continues the surface's slope across the rim instead of folding there. A flat
fan would leave a crease along the rim that feature detection takes for a sharp edge.
"""

from __future__ import annotations

import numpy as np
from scipy import sparse
from scipy.sparse import csgraph
from scipy.sparse.linalg import spsolve

from .tables import edge_table, face_normals

__all__ = ["fill_holes", "MAX_RINGS"]

#: Most rings of triangles in one patch (a patch is about as many rim edges across).
MAX_RINGS = 30


def _boundary_loops(vertices: np.ndarray, faces: np.ndarray):
    """Directed boundary edges grouped into simple loops, each in order along its edges.

    Returns the loops as a list of vertex arrays and the number of loops that are not simple
    cycles (a vertex with two outgoing boundary edges).
    """
    edges, face_edge, _ = edge_table(faces)
    counts = np.bincount(face_edge.reshape(-1), minlength=len(edges))
    boundary = counts[face_edge.reshape(-1)] == 1
    if not boundary.any():
        return [], 0
    directed = faces[:, [0, 1, 1, 2, 2, 0]].reshape(-1, 2)[boundary]
    n = len(vertices)
    graph = sparse.coo_matrix((np.ones(len(directed)), (directed[:, 0], directed[:, 1])), shape=(n, n)).tocsr()
    _, label = csgraph.connected_components(graph, directed=False)
    out_degree = np.bincount(directed[:, 0], minlength=n)
    in_degree = np.bincount(directed[:, 1], minlength=n)
    bad_vertex = ((out_degree != in_degree) | (out_degree > 1)) & (out_degree + in_degree > 0)
    bad_loop = np.zeros(label.max() + 1, dtype=bool)
    bad_loop[label[bad_vertex]] = True
    loop_of_edge = label[directed[:, 0]]
    simple = ~bad_loop[loop_of_edge]
    open_loops = int(len(np.unique(loop_of_edge[~simple])))
    kept = directed[simple]
    if len(kept) == 0:
        return [], open_loops
    # rank every vertex along its loop by pointer jumping from the loop's smallest vertex
    following = np.arange(n)
    following[kept[:, 0]] = kept[:, 1]
    loop = label[kept[:, 0]]
    start = np.full(label.max() + 1, n)
    np.minimum.at(start, loop, kept[:, 0])
    before_start = kept[following[kept[:, 0]] == start[loop], 0]
    following[before_start] = before_start
    steps = np.zeros(n, dtype=np.int64)
    steps[kept[:, 0]] = 1
    steps[before_start] = 0
    while True:
        jump = following[following]
        if np.array_equal(jump, following):
            break
        steps = steps + steps[following]
        following = jump
    size = np.bincount(loop, minlength=label.max() + 1)
    position = size[loop] - 1 - steps[kept[:, 0]]
    order = np.lexsort((position, loop))
    members = kept[order, 0]
    bounds = np.concatenate([[0], np.cumsum(np.bincount(loop[order])[np.unique(loop)])])
    return [members[a:b] for a, b in zip(bounds[:-1], bounds[1:])], open_loops


def _ring_patch(vertices: np.ndarray, rim: np.ndarray, first_new: int) -> tuple[np.ndarray, np.ndarray]:
    """New vertices and triangles filling the loop ``rim`` (in the direction of its edges)."""
    points = vertices[rim]
    centre = points.mean(axis=0)
    rim_edge = float(np.linalg.norm(np.roll(points, -1, axis=0) - points, axis=1).mean())
    radius = float(np.linalg.norm(points - centre, axis=1).mean())
    rings = int(np.clip(round(radius / max(rim_edge, 1e-300)), 1, MAX_RINGS))
    count = len(rim)
    t = 1.0 - np.arange(1, rings) / rings  # inner rings, outermost first
    ring_points = centre + t[:, None, None] * (points - centre)[None]
    new_points = np.concatenate([ring_points.reshape(-1, 3), centre[None]])
    ids = np.concatenate([rim[None], first_new + np.arange((rings - 1) * count).reshape(rings - 1, count)])
    apex = first_new + (rings - 1) * count
    nxt = np.roll(np.arange(count), -1)
    outer, inner = ids[:-1], ids[1:]
    bands = np.concatenate(
        [
            np.stack([outer[:, nxt], outer, inner], axis=-1).reshape(-1, 3),
            np.stack([outer[:, nxt], inner, inner[:, nxt]], axis=-1).reshape(-1, 3),
        ]
    )
    last = ids[-1]
    fan = np.stack([last[nxt], last, np.full(count, apex)], axis=1)
    return new_points, np.concatenate([bands, fan])


def _fair(vertices: np.ndarray, faces: np.ndarray, free: np.ndarray) -> np.ndarray:
    """Solve ``(L^2 x)[free] = 0`` for the free vertices, the others held (uniform Laplacian)."""
    n = len(vertices)
    pairs = faces[:, [0, 1, 1, 2, 2, 0]].reshape(-1, 2)
    adjacency = sparse.coo_matrix((np.ones(len(pairs)), (pairs[:, 0], pairs[:, 1])), shape=(n, n)).tocsr()
    adjacency = ((adjacency + adjacency.T) > 0).astype(np.float64)
    laplacian = sparse.diags(np.asarray(adjacency.sum(axis=1)).ravel()) - adjacency
    rows = (laplacian[free] @ laplacian).tocsc()
    is_free = np.zeros(n, dtype=bool)
    is_free[free] = True
    held = np.flatnonzero(~is_free)
    system = rows[:, free].tocsc()
    right = -(rows[:, held] @ vertices[held])
    solved = spsolve(system, right)
    result = vertices.copy()
    result[free] = np.asarray(solved).reshape(-1, 3)
    return result


def fill_holes(vertices: np.ndarray, faces: np.ndarray) -> tuple[np.ndarray, np.ndarray, int, float, int]:
    """Fill every simple boundary loop with a faired patch.

    Returns
    -------
    vertices, faces : ndarray
        The surface with the patches.
    holes : int
        Loops filled.
    area : float
        Area of the patches.
    open_loops : int
        Loops left open (not simple cycles).

    Examples
    --------
    >>> import numpy as np, pyvista as pv
    >>> sphere = pv.Sphere(theta_resolution=64, phi_resolution=64)   # radius 0.5
    >>> points, faces = np.asarray(sphere.points, float), sphere.faces.reshape(-1, 4)[:, 1:]
    >>> cut = points[faces].mean(axis=1)[:, 2] < 0.4                  # a cap off: rim at z = 0.4
    >>> filled, _, holes, _, _ = fill_holes(points, faces[cut])
    >>> holes, round(float(filled[len(points):, 2].max()), 2)         # the patch bulges like the sphere
    (1, 0.47)
    """
    loops, open_loops = _boundary_loops(vertices, faces)
    if not loops:
        return vertices, faces, 0, 0.0, open_loops
    new_points, new_faces = [], []
    first = len(vertices)
    for rim in loops:  # one patch per hole; each is built with array operations
        points, triangles = _ring_patch(vertices, rim, first)
        new_points.append(points)
        new_faces.append(triangles)
        first += len(points)
    free = np.arange(len(vertices), first)
    vertices = np.concatenate([vertices] + new_points)
    patches = np.concatenate(new_faces)
    faces = np.concatenate([faces, patches])
    vertices = _fair(vertices, faces, free)
    area = float(face_normals(vertices, patches)[1].sum())
    return vertices, faces, len(loops), area, open_loops
