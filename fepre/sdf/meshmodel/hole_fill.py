"""Close the holes of a triangle surface: flat where the rim is planar, else with smooth patches.

A rim that lies in a plane (to ``PLANAR_TOLERANCE`` of its size: a CAD face missing from an STL,
a cut) is closed in that plane, so the filled solid is the one the rim bounds (a box with a
missing face gets its volume back exactly). A rim across a cut is closed straight across too: it
lies near a plane (to ``CUT_FLATNESS`` of its size) and the surface meets that plane steeply
(the triangles along the rim at more than 53 degrees to it on average), as at the open base of a
scanned statue or bust, where a patch continuing the walls' slope would bulge far past the base;
so is a rim farther from its plane (to ``CUT_FLATNESS_AT_BOX``) whose faired patch would reach
past the input's box (a neck cut at the part's extreme).
Any other boundary loop that is a simple cycle is
filled with rings of triangles shrinking to its centroid, about one rim edge apart, and the new
vertices are then placed by a bi-Laplacian fairing (Liepa 2003): they solve ``L^2 x = 0`` with the
rim and one ring of the surrounding surface held, so the patch continues the surface's slope
across the rim instead of folding there (a flat fan would leave a crease along the rim that
feature detection takes for a sharp edge). :func:`fill_holes` reports how much volume the faired
patches add beyond flat fans across their rims, so that a caller can say when a fill changed
the solid.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy import sparse
from scipy.sparse import csgraph
from scipy.sparse.linalg import spsolve

from .tables import edge_table, face_normals

__all__ = ["fill_holes", "FilledHoles", "MAX_RINGS", "PLANAR_TOLERANCE", "CUT_FLATNESS", "CUT_STEEPNESS",
           "CUT_FLATNESS_AT_BOX"]

#: Most rings of triangles in one patch (a patch is about as many rim edges across).
MAX_RINGS = 30

#: A rim is planar when no vertex is farther than this fraction of the rim's diameter from its
#: best-fitting plane (STL stores float32 coordinates: about 1e-7 relative).
PLANAR_TOLERANCE = 1e-5

#: A rim across a cut lies within this fraction of its diameter of its best-fitting plane ...
CUT_FLATNESS = 0.1
#: ... and the triangles along it meet that plane steeply: the mean |cos| between their normals
#: and the plane's normal (weighted by the rim edges' lengths) is below this (53 degrees: a
#: hole in a sphere is a cut when it is a cap of more than 53 degrees, a fifth of the sphere).
CUT_STEEPNESS = 0.6
#: A rim within this fraction of its diameter of its plane whose faired patch would reach past
#: the input's box is closed straight across as well: the cut end of a part at its extreme
#: (libigl's camelhead.off: a neck cut 0.117 of its width out of plane, whose patch added 6.8%
#: of the volume and reached 0.09 past the box).
CUT_FLATNESS_AT_BOX = 0.25


@dataclass(frozen=True)
class FilledHoles:
    """What :func:`fill_holes` did: the surface with its patches and the figures of the fill."""

    vertices: np.ndarray
    faces: np.ndarray
    holes: int
    flat: int  # of them closed flat (planar rims) or straight across (rims across a cut)
    area: float
    bulge: float  # volume the faired patches add beyond flat fans across their rims (signed)
    open_edges: int
    cut: int = 0  # of the flat ones, rims across a cut


def _rim_faces(faces: np.ndarray, boundary: np.ndarray, loops: list[np.ndarray], n: int) -> list[np.ndarray]:
    """For each loop, the triangle using each of its edges ``loop[i] -> loop[i + 1]``.

    ``boundary``: the mask over ``faces``' directed edges (three per face, in the order
    ``01, 12, 20``) of the edges used by one triangle.
    """
    directed = faces[:, [0, 1, 1, 2, 2, 0]].reshape(-1, 2)
    index = np.flatnonzero(boundary)
    keys = directed[index, 0] * n + directed[index, 1]
    order = np.argsort(keys, kind="stable")
    keys, owner = keys[order], index[order] // 3
    found = []
    for loop in loops:
        wanted = loop * n + np.roll(loop, -1)
        found.append(owner[np.searchsorted(keys, wanted)])
    return found


def _boundary_loops(vertices: np.ndarray, faces: np.ndarray):
    """Boundary edges (used by one triangle) split into simple loops, each in order along its
    edges, and for each loop the triangles along its edges (:func:`_rim_faces`).

    A hole whose rim touches itself at a vertex (a pinch, common where triangles were cut away
    around a point) is split there into simple loops. Returns the loops as vertex arrays and the
    number of boundary edges left over (where the edges into and out of a vertex do not match).
    """
    edges, face_edge, _ = edge_table(faces)
    counts = np.bincount(face_edge.reshape(-1), minlength=len(edges))
    boundary = counts[face_edge.reshape(-1)] == 1
    if not boundary.any():
        return [], 0, []
    directed = faces[:, [0, 1, 1, 2, 2, 0]].reshape(-1, 2)[boundary]
    n = len(vertices)
    out_degree = np.bincount(directed[:, 0], minlength=n)
    in_degree = np.bincount(directed[:, 1], minlength=n)
    balanced = out_degree == in_degree
    usable = balanced[directed[:, 0]] & balanced[directed[:, 1]]
    leftover = int((~usable).sum())
    directed = directed[usable]
    # walk the edges; a walk that comes back to a vertex already on it closes a simple loop
    # (one step per boundary edge, and rims are a small part of a surface)
    order = np.argsort(directed[:, 0], kind="stable")
    starts = np.searchsorted(directed[order, 0], np.arange(n + 1))
    outgoing = {int(v): list(directed[order[starts[v] : starts[v + 1]], 1]) for v in np.unique(directed[:, 0])}
    loops: list[np.ndarray] = []
    for first in list(outgoing):
        while outgoing.get(first):
            path, seen, vertex = [first], {first: 0}, first
            while True:
                following = outgoing[vertex].pop()
                if following in seen:
                    cut = seen[following]
                    loops.append(np.asarray(path[cut:], dtype=np.int64))
                    for dropped in path[cut + 1 :]:
                        del seen[dropped]
                    del path[cut + 1 :]
                    vertex = following
                    if not outgoing.get(vertex):
                        break
                    continue
                seen[following] = len(path)
                path.append(following)
                vertex = following
                if not outgoing.get(vertex):  # a dead end: unbalanced after all
                    leftover += len(path) - 1
                    break
    loops = [loop for loop in loops if len(loop) >= 3]
    return loops, leftover, _rim_faces(faces, boundary, loops, n)


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


def _rim_plane(vertices: np.ndarray, faces: np.ndarray, rim: np.ndarray, rim_faces: np.ndarray,
               flatness: float = CUT_FLATNESS) -> tuple[np.ndarray | None, bool]:
    """The normal of the plane to close ``rim`` in, and whether the rim runs across a cut; None
    when the rim is neither planar (``PLANAR_TOLERANCE``) nor across a cut: near a plane
    (``flatness``), the surface meeting it steeply along the rim (``CUT_STEEPNESS``).

    ``rim_faces``: for each rim edge ``rim[i] -> rim[i + 1]``, the one triangle using it.
    """
    points = vertices[rim]
    centred = points - points.mean(axis=0)
    diameter = float(np.ptp(points, axis=0).max())
    if diameter == 0.0:
        return None, False
    normal = np.linalg.svd(centred, full_matrices=False)[2][-1]
    offsets = centred @ normal
    if float(np.abs(offsets).max()) <= PLANAR_TOLERANCE * diameter:
        return normal, False
    if float(np.ptp(offsets)) > flatness * diameter:
        return None, False
    corners = vertices[faces[rim_faces]]
    cross = np.cross(corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0])
    cosine = np.abs(cross @ normal) / np.maximum(np.linalg.norm(cross, axis=1), 1e-300)
    length = np.linalg.norm(np.roll(points, -1, axis=0) - points, axis=1)
    steep = float(cosine @ length) < CUT_STEEPNESS * float(length.sum())
    return (normal, True) if steep else (None, False)


def _flat_patch(vertices: np.ndarray, rim: np.ndarray, normal: np.ndarray, first_new: int):
    """New vertices and triangles closing the planar loop ``rim`` in its plane.

    The rings shrinking to the centroid when the rim is star-shaped from it (every fan triangle
    turns the same way about the normal); otherwise the polygon's own triangulation (VTK's, ear
    cutting), with no new vertices.
    """
    points = vertices[rim]
    centre = points.mean(axis=0)
    turns = np.cross(points - centre, np.roll(points, -1, axis=0) - centre) @ normal
    if np.all(turns > 0) or np.all(turns < 0):
        return _ring_patch(vertices, rim, first_new)
    import pyvista as pv

    # the polygon's projection onto its plane: a rim across a cut is only near the plane, and
    # VTK's ear cutting of a polygon out of its plane leaves holes and overlaps
    flat = points - np.outer((points - centre) @ normal, normal)
    polygon = pv.PolyData(flat, faces=np.concatenate([[len(rim)], np.arange(len(rim))])).triangulate()
    local = np.asarray(polygon.faces).reshape(-1, 4)[:, 1:]
    triangles = rim[local]
    # the rim's edges run one way round the hole: the patch turns the other way, as _ring_patch
    a, b, c = (vertices[triangles[:, k]] for k in range(3))
    rim_turn = float(turns.sum())
    if np.sign((np.cross(b - a, c - a) @ normal).sum()) == np.sign(rim_turn):
        triangles = triangles[:, ::-1]
    return np.zeros((0, 3)), triangles


def _bulge(vertices: np.ndarray, rim: np.ndarray, triangles: np.ndarray) -> float:
    """Signed volume between a patch and the flat fan across its rim from the rim's centroid."""
    centre = vertices[rim].mean(axis=0)
    a, b, c = (vertices[triangles[:, k]] - centre for k in range(3))
    return float(np.einsum("ij,ij->i", a, np.cross(b, c)).sum() / 6.0)


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


def fill_holes(vertices: np.ndarray, faces: np.ndarray) -> FilledHoles:
    """Fill every simple boundary loop: flat when it is planar or across a cut, else with a faired patch.

    Returns
    -------
    FilledHoles
        The surface with the patches, the loops filled (and how many flat), the patches' area,
        the volume the faired patches add beyond flat fans across their rims, and the boundary
        edges left open (where the edges into and out of a vertex do not match).

    Examples
    --------
    >>> import numpy as np, pyvista as pv
    >>> sphere = pv.Sphere(theta_resolution=64, phi_resolution=64)   # radius 0.5
    >>> points, faces = np.asarray(sphere.points, float), sphere.faces.reshape(-1, 4)[:, 1:]
    >>> centres = points[faces].mean(axis=1)
    >>> cut = np.abs(centres[:, 0] - 0.3) + np.abs(centres[:, 2] - 0.3) > 0.12   # a skewed window
    >>> filled = fill_holes(points, faces[cut])
    >>> filled.holes, filled.flat, bool(filled.bulge > 0)              # faired: it bulges like the sphere
    (1, 0, True)
    >>> box = pv.Box().triangulate()                                   # the cube [-1, 1]^3
    >>> quads = box.faces.reshape(-1, 4)[:, 1:]
    >>> top = np.asarray(box.points)[quads].mean(axis=1)[:, 2] > 0.99
    >>> open_box = fill_holes(np.asarray(box.points, float), quads[~top])  # the top face missing
    >>> open_box.flat, open_box.bulge                                   # closed flat: volume 8 again
    (1, 0.0)
    """
    loops, open_edges, rim_faces = _boundary_loops(vertices, faces)
    if not loops:
        return FilledHoles(vertices, faces, 0, 0, 0.0, 0.0, open_edges)
    planes = [_rim_plane(vertices, faces, rim, along) for rim, along in zip(loops, rim_faces)]
    patched = _patched(vertices, faces, loops, planes, open_edges)
    lower, upper, wider = vertices.min(axis=0), vertices.max(axis=0), False
    for k, start, count in patched.faired:
        if _past_box(patched.holes.vertices, patched.holes.faces[start:start + count], lower, upper):
            plane = _rim_plane(vertices, faces, loops[k], rim_faces[k], CUT_FLATNESS_AT_BOX)
            if plane[0] is not None:
                planes[k], wider = plane, True
    return (_patched(vertices, faces, loops, planes, open_edges) if wider else patched).holes


def _past_box(vertices: np.ndarray, patch: np.ndarray, lower: np.ndarray, upper: np.ndarray) -> bool:
    """Whether the ``patch``'s vertices reach past the box (beyond rounding of its size)."""
    points = vertices[np.unique(patch)]
    slack = PLANAR_TOLERANCE * float(np.max(upper - lower))
    return bool((points < lower - slack).any() or (points > upper + slack).any())


@dataclass(frozen=True)
class _Patched:
    holes: FilledHoles
    faired: list  # (loop, first patch triangle in faces, count) of each faired patch


def _patched(vertices: np.ndarray, faces: np.ndarray, loops: list[np.ndarray], planes: list, open_edges: int) -> _Patched:
    """The ``loops`` closed: flat in the plane of ``planes[k] = (normal, cut)``, faired where the
    normal is None."""
    new_points, new_faces, free, faired, cuts = [], [], [], [], 0
    first, placed = len(vertices), len(faces)  # next new vertex, next patch triangle
    for k, (rim, (normal, cut)) in enumerate(zip(loops, planes)):  # one patch per hole, built with array operations
        cuts += cut
        if normal is None:
            points, triangles = _ring_patch(vertices, rim, first)
            free.append(np.arange(first, first + len(points)))
            faired.append((k, placed, len(triangles)))
        else:
            points, triangles = _flat_patch(vertices, rim, normal, first)
        new_points.append(points)
        new_faces.append(triangles)
        first += len(points)
        placed += len(triangles)
    vertices = np.concatenate([vertices] + new_points)
    patches = np.concatenate(new_faces)
    faces = np.concatenate([faces, patches])
    bulge = 0.0
    if free:
        vertices = _fair(vertices, faces, np.concatenate(free))
        bulge = sum(_bulge(vertices, loops[k], faces[start : start + count]) for k, start, count in faired)
    area = float(face_normals(vertices, patches)[1].sum())
    return _Patched(FilledHoles(vertices, faces, len(loops), len(loops) - len(faired), area, bulge, open_edges, cuts),
                    faired)
