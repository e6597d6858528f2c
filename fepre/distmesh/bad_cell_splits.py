"""Vertex insertion at the cells the quality stage leaves below its targets.

Flips, smoothing, boundary flips and collapses rearrange the vertices a mesh has; where the
surface of a triangle-mesh model bends at the scale of h (a statue's base rim, the edge of a
cartoon ear, a wall thinner than h), the right vertices are missing. Measured on libigl's
``fertility`` and ``cheburashka`` at h = D/50, the stage ends with five cells each under 25 deg:

* *wedges*: a cell holding two boundary faces across a rim that bends by 45-70 deg. Its inner
  edge joins two surface vertices through the material; no cell of the rim's edge reaches
  inside, so its dihedral angle there is set by the bend, not by any vertex position;
* *caps and stretched faces*: a boundary face along a rim, 1.6-1.8 h long, with the cell's
  fourth vertex 1.3 h inside. A cap's chord is split even when the cell's longest edge is an
  inner one (nefertiti.obj at D/50: a cap on the crown's rim, apex 0.13 h off a 1.74 h chord,
  inner edges of 1.84 h; splitting those left the cap and the cell at 5.9 deg round after round).

:func:`split_bad_cells` splits one edge of each such cell at its midpoint (a wedge's inner edge;
else its longest edge that can be split, a boundary edge's midpoint projected onto the zero
set) with :func:`~fepre.distmesh.surface_refine.split_edges`, and the stage runs again: the new
vertex gives the rim's edge a cell reaching inside, or halves the stretched face. On the two
models above this takes the worst dihedral angle from 16.3 and 17.3 deg to 30.6 and 25.2 deg
with 4 and 6 new vertices. Before those choices comes a split that mends the cell at once (its
new cells all score better than the cell: cow.obj's lone cell at an ear's tip, 21.5 deg, whose
vertices are pinned feature nodes; the split of one edge gives two of 28 and 29 deg, the
choice before, an edge off the surface, 4 deg), and after them every edge split before whose
split the stage undid. A first choice on the boundary whose new vertex lies beyond its own cells
(a chord over a valley of a wall thinner than 2 h, whose plain split inverts every half:
skull_low_resolution.obj at D/50, a 2.62 h chord, 16.4 deg through every round) is split into a
star-shaped cavity instead (:mod:`~fepre.distmesh.cavity_split`), before the round's other splits.
"""

from __future__ import annotations

import numpy as np

from .surface_refine import split_edges
from .tet_shape import ShapeTargets
from .tet_topology import EDGE_OF_TET, edge_keys, face_keys, face_neighbours, faces_on_boundary, in_sorted

__all__ = ["split_bad_cells", "split_candidates", "knife_edge", "stable_edge_keys"]

#: An edge between two surface vertices whose midpoint lies farther than this (times h) off the
#: zero set is split first: the surface bends between its ends at the scale of h.
OFF_SURFACE = 0.1
#: A boundary face with an angle larger than this (degrees) is a cap: its apex lies near its longest
#: edge, so every cell on it is flat whatever its fourth vertex, and its longest edge is split first.
CAP_ANGLE = 120.0
#: A vertex within this (times h) of the zero set counts as on it.
SURFACE_NODE = 1e-3

#: The local faces of a cell, each opposite the vertex of the same index.
_FACE_OPPOSITE = np.array([[1, 2, 3], [0, 2, 3], [0, 1, 3], [0, 1, 2]])


def split_candidates(points: np.ndarray, tets: np.ndarray, cells: np.ndarray, n_points: int,
                     off_surface: np.ndarray | None = None) -> np.ndarray:
    """The edges to try splitting for ``cells`` (worst first), in priority order, (E, 2).

    A cell's choices in order: its edge whose midpoint lies farthest off the surface when
    ``off_surface`` (C, 6) marks one (in the order of ``EDGE_OF_TET``; an edge bridging a
    valley or cutting a ridge at the scale of h), else its inner edge when it holds two boundary
    faces (the edge joining the two vertices off their common edge), else the longest edge of
    its one boundary face when that face is a cap (an angle over ``CAP_ANGLE``: the cell is flat
    whatever its fourth vertex, and its own longest edge may be an inner one, whose split leaves
    the cap); a wedge whose two boundary faces are caps on their common edge takes that chord
    before any of these (its inner edge may lie off the surface, but a vertex there leaves the
    caps); then its six edges longest first. The list runs
    through every cell's first choice before any second choice, so a cell's fall-back never
    takes the cells another's first choice needs; repeated edges keep their first place.
    """
    if len(cells) == 0:
        return np.zeros((0, 2), dtype=np.int64)
    first, by_length = _choices(points, tets, cells, n_points, off_surface)
    choices = np.concatenate([first[:, None], by_length], axis=1)  # (C, 7, 2)
    ordered = np.sort(choices.transpose(1, 0, 2).reshape(-1, 2), axis=1)
    _, index = np.unique(ordered, axis=0, return_index=True)
    return ordered[np.sort(index)]


def _choices(points, tets, cells, n_points: int, off_surface) -> tuple[np.ndarray, np.ndarray]:
    """Each of ``cells``' first choice (C, 2) and its six edges longest first (C, 6, 2); see
    :func:`split_candidates`."""
    faces = faces_on_boundary(tets, face_neighbours(tets, n_points))
    keys = np.sort(face_keys(faces, n_points))
    corners = tets[cells]
    on_boundary = np.stack([in_sorted(face_keys(corners[:, _FACE_OPPOSITE[k]], n_points), keys) for k in range(4)], 1)
    edges = corners[:, EDGE_OF_TET]  # (C, 6, 2)
    length = np.linalg.norm(points[edges[..., 0]] - points[edges[..., 1]], axis=2)
    by_length = np.take_along_axis(edges, np.argsort(-length, axis=1)[..., None], axis=1)
    # a wedge's inner edge joins the two vertices opposite its two boundary faces
    wedge = on_boundary.sum(axis=1) == 2
    opposite = np.sort(np.where(on_boundary, corners, -1), axis=1)[:, 2:]
    first = np.where(wedge[:, None], opposite, by_length[:, 0])
    # a cell on one boundary face that is a cap (an angle over CAP_ANGLE): that face's longest edge
    cap, chord = _cap_chords(points, corners, on_boundary)
    first[cap] = chord
    if off_surface is not None:
        far = off_surface.max(axis=1) > 0
        first[far] = edges[far, np.argmax(off_surface[far], axis=1)]
    # a wedge whose two boundary faces meet on a cap's chord: the chord (its inner edge may lie
    # off the surface too, but no vertex on it mends the cap, which leaves every cell on it flat)
    capped, shared = _wedge_chords(points, corners, on_boundary)
    first[capped] = shared
    return first, by_length


def _cap_chords(points: np.ndarray, corners: np.ndarray, on_boundary: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Which cells ``corners`` (C, 4) hold exactly one boundary face that is a cap (a triangle
    with an angle over ``CAP_ANGLE``), and that face's longest edge, (K, 2)."""
    one = np.flatnonzero(on_boundary.sum(axis=1) == 1)
    face = np.take_along_axis(corners[one], _FACE_OPPOSITE[np.argmax(on_boundary[one], axis=1)], axis=1)
    sides = face[:, [[1, 2], [2, 0], [0, 1]]]  # (K, 3, 2), side k opposite corner k
    length = np.linalg.norm(points[sides[..., 0]] - points[sides[..., 1]], axis=2)
    longest = np.argmax(length, axis=1)
    rows = np.arange(one.size)
    a, b, c = length[rows, longest], length[rows, (longest + 1) % 3], length[rows, (longest + 2) % 3]
    # the angle opposite the longest side, by the law of cosines
    cosine = (b * b + c * c - a * a) / np.maximum(2.0 * b * c, 1e-300)
    cap = cosine < np.cos(np.radians(CAP_ANGLE))
    return one[cap], sides[rows, longest][cap]


def _wedge_chords(points: np.ndarray, corners: np.ndarray, on_boundary: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Which cells ``corners`` (C, 4) hold two boundary faces whose common edge is a cap's chord
    (the angle opposite it over ``CAP_ANGLE`` in either face), and that edge, (K, 2).

    The faces on the boundary are those opposite the two corners off the common edge (the
    faces' apexes); the common edge joins the corners whose opposite faces are inner ones.
    """
    two = np.flatnonzero(on_boundary.sum(axis=1) == 2)
    order = np.argsort(on_boundary[two], axis=1, kind="stable")  # the edge's ends, then the apexes
    vertices = np.take_along_axis(corners[two], order, axis=1)
    a, b = points[vertices[:, 0]], points[vertices[:, 1]]
    capped = np.zeros(two.size, dtype=bool)
    for apex in points[vertices[:, 2]], points[vertices[:, 3]]:
        u, v = a - apex, b - apex
        norms = np.linalg.norm(u, axis=1) * np.linalg.norm(v, axis=1)
        capped |= np.einsum("ij,ij->i", u, v) < np.cos(np.radians(CAP_ANGLE)) * norms
    return two[capped], vertices[capped, :2]


def split_bad_cells(
    points: np.ndarray,
    tets: np.ndarray,
    model,
    h: float,
    targets: ShapeTargets | None = None,
    off_surface_first: bool = False,
    tried: np.ndarray | None = None,
    locked: np.ndarray | None = None,
) -> tuple[np.ndarray, np.ndarray, int]:
    """Split one edge of every cell whose score is below ``targets`` (see :func:`split_candidates`).

    Parameters
    ----------
    points : (N, 3) float array
    tets : (M, 4) int array, positively oriented, forming a solid
    model : fepre.sdf.SDF
        The model of the mesh: a boundary edge's new vertex lies on its zero set.
    h : float
        The edge length (sets the projection's tolerance).
    targets : ShapeTargets, optional
        The quality stage's targets (25 deg, 150 deg, 0.25 by default).
    off_surface_first : bool
        Split first a cell's edge between two surface vertices whose midpoint lies more than
        ``OFF_SURFACE`` h off the zero set (a chord across a valley or through a ridge).
    tried : int64 array, optional
        The :func:`stable_edge_keys` of edges split before whose splits the stage undid (the
        edge is back): they come after every other candidate, so that a cell whose first choice
        was undone gets its next one (the same split would give the same mesh again).
    locked : (N,) bool, optional
        Vertices no edge between two of which is split and no cavity crosses a face of three
        (a region mesh's interface nodes: the faces between regions stay).

    A bad cell's first choice that is a boundary edge whose new vertex lies beyond the edge's
    cells is split into a cavity first; a call that makes such splits makes only those.

    Returns
    -------
    points : (N + K, 3), the K new vertices appended
    tets : the cells, each one around a split edge replaced by its two halves (or a cavity's
        cells replaced by the new vertex's cone)
    splits : K

    Examples
    --------
    A cell on a ball's surface with a vertex 0.05 inside its opposite face (a flat cell), in a
    mesh of four: its longest edge is split, and the new vertex lies on the sphere.

    >>> import numpy as np
    >>> from fepre import sdf
    >>> r = 1 / np.sqrt(3)
    >>> points = np.array([[0.0, 0.0, 0.0], [r, r, r], [r, -r, -r], [-r, r, -r], [-r, -r, r]])
    >>> tets = np.array([[0, 1, 2, 3], [0, 1, 4, 2], [0, 1, 3, 4], [0, 2, 4, 3]])
    >>> points[0] = 0.95 * points[[1, 2, 3]].mean(axis=0)
    >>> new_points, new_tets, splits = split_bad_cells(points, tets, sdf.sphere(1.0), h=1.0)
    >>> splits, len(new_tets) > len(tets)
    (1, True)
    >>> bool(np.isclose(np.linalg.norm(new_points[-1]), 1.0))
    True
    """
    targets = ShapeTargets() if targets is None else targets
    score = targets.score(points[tets])
    bad = np.flatnonzero(score < targets.min_dihedral)
    bad = bad[np.argsort(score[bad], kind="stable")]
    off = _off_surface(points, tets[bad], model, h) if off_surface_first else None
    if len(bad):
        first, _ = _choices(points, tets, bad, points.shape[0], off)
        points_after, tets_after, cavities = _cavity_splits(points, tets, model, h, first, tried, locked)
        if cavities:
            return points_after, tets_after, cavities
    edges = split_candidates(points, tets, bad, points.shape[0], off)
    if tried is not None and len(tried):
        again = np.isin(stable_edge_keys(edges), tried)
        edges = np.concatenate([edges[~again], edges[again]])
    return split_edges(points, tets, model, h, edges, locked)


def _cavity_splits(points, tets, model, h: float, first: np.ndarray, tried,
                   locked: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray, int]:
    """The bad cells' first choices that are boundary edges whose new vertex lies beyond their
    own cells (a chord across a valley of a wall thinner than 2 h: every half of a plain split
    inverted), split into cavities (:func:`~fepre.distmesh.cavity_split.cavity_split`), worst
    cell first; edges split before whose split the stage undid (``tried``) are left out."""
    from .cavity_split import cavity_split
    from .surface_refine import MAX_PROJECTION, _boundary_edges, _crossing_new_vertices

    n = points.shape[0]
    first = np.sort(first, axis=1)
    _, index = np.unique(first, axis=0, return_index=True)
    first = first[np.sort(index)]
    first = first[np.isin(edge_keys(first, n), edge_keys(_boundary_edges(tets, n), n))]
    if tried is not None and len(tried):
        first = first[~np.isin(stable_edge_keys(first), tried)]
    done = 0
    for edge in first:
        if locked is not None:
            locked = np.concatenate([locked, np.zeros(points.shape[0] - locked.shape[0], dtype=bool)])
        new_points, new_tets, split = cavity_split(points, tets, model, h, edge, MAX_PROJECTION, beyond_ring=True,
                                                   locked=locked)
        if split and not _crossing_new_vertices(new_points, new_tets, points.shape[0]).any():
            points, tets, done = new_points, new_tets, done + 1
    return points, tets, done


def stable_edge_keys(pairs: np.ndarray) -> np.ndarray:
    """One int64 per (K, 2) vertex pair, whatever the order of its ends and the number of points
    (vertex numbers below 2**31)."""
    return edge_keys(np.asarray(pairs, dtype=np.int64).reshape(-1, 2), 2**31)


def _off_surface(points: np.ndarray, corners: np.ndarray, model, h: float) -> np.ndarray:
    """How far each edge's midpoint of the cells ``corners`` (C, 4) lies off the model's zero
    set, where more than ``OFF_SURFACE`` h and both ends are on it (else 0), (C, 6)."""
    ends = points[corners[:, EDGE_OF_TET]]  # (C, 6, 2, 3)
    values = model(np.concatenate([points[corners].reshape(-1, 3), ends.mean(axis=2).reshape(-1, 3)]))
    at_node = np.abs(values[: corners.size].reshape(-1, 4)) <= SURFACE_NODE * h
    both = at_node[:, EDGE_OF_TET].all(axis=2)
    off = np.abs(values[corners.size:].reshape(-1, 6))
    return np.where(both & (off > OFF_SURFACE * h), off, 0.0)


def knife_edge(points: np.ndarray, tets: np.ndarray, model, cell: int) -> tuple[float, np.ndarray] | None:
    """The angle at which the model's surfaces meet (degrees) where ``cell`` holds two boundary
    faces whose common edge lies on the surface, and where (the middle of that edge), at the
    sharpest such pair; None when the cell holds no such pair.

    A cell with two faces on a convex edge of the part fills the wedge between them: its angle
    at that edge is at most the edge's, so no mesh that keeps a knife edge of 10 deg meets a 25
    deg target there (libigl's decimated knight holds three, of 10.7-18.7 deg).

    Examples
    --------
    A thin wedge, 10 deg at its edge along y, and one cell in its tip (its faces all on the
    boundary, meeting the wedge's two faces):

    >>> import numpy as np
    >>> from fepre import sdf
    >>> t = np.tan(np.radians(5.0))
    >>> wedge = sdf.plane((-t, 0, 1)) & sdf.plane((-t, 0, -1))
    >>> points = np.array([[0.0, 0, 0], [0, 1, 0], [1, 0.5, t], [1, 0.5, -t]])
    >>> angle, where = knife_edge(points, np.array([[0, 1, 2, 3]]), wedge, 0)
    >>> round(angle, 1)
    10.0

    A cell across a plate 0.2 thick: its faces on the plate's two sides meet at edges that cross
    the plate, not on an edge of it (the pairs left meet on one side, at 180 deg):

    >>> plate = sdf.box((4.0, 4.0, 0.2))
    >>> across = np.array([[0.0, 0, 0.1], [1, 0, 0.1], [0.5, 0.2, -0.1], [0.5, -0.8, -0.1]])
    >>> round(knife_edge(across, np.array([[0, 1, 2, 3]]), plate, 0)[0], 1)
    180.0
    """
    n = points.shape[0]
    faces = faces_on_boundary(tets, face_neighbours(tets, n))
    corners = tets[cell]
    on = in_sorted(face_keys(corners[_FACE_OPPOSITE], n), np.sort(face_keys(faces, n)))
    local = np.flatnonzero(on)
    if local.size < 2:
        return None
    centroids = points[corners[_FACE_OPPOSITE[local]]].mean(axis=1)
    _, gradient = model.value_and_gradient(centroids)
    gradient /= np.maximum(np.linalg.norm(gradient, axis=1), 1e-300)[:, None]
    best = None
    for i in range(local.size):
        for j in range(i + 1, local.size):
            angle = 180.0 - float(np.degrees(np.arccos(np.clip(gradient[i] @ gradient[j], -1.0, 1.0))))
            ends = points[corners[np.setdiff1d(np.arange(4), local[[i, j]])]]
            middle = ends.mean(axis=0)
            # an edge of the model holds the faces' common edge; across a wall thinner than the
            # cell, the faces lie on its two sides and their edge crosses it (a 1 mm sheet's cell
            # was "a knife edge ... where its surfaces meet at 0.0 deg")
            if abs(float(model(middle[None])[0])) > 0.1 * float(np.linalg.norm(ends[1] - ends[0])):
                continue
            if best is None or angle < best[0]:
                best = (angle, middle)
    return best
