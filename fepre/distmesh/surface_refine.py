"""Long boundary edges split: the surface sampling's gaps filled before the quality stage.

On a triangle-mesh model (a scan, a graphics model, a tessellated CAD part) DistMesh can leave
gaps in the nodes on the surface: where the faceted surface curves at the scale of h, a few
boundary nodes drift apart and the final triangulation bridges the gap with boundary faces two
or three times as long as h. Every cell on such a face is flat (a *cap* whose three surface
vertices are nearly collinear, or a wedge reaching 2.5 h to an inner vertex), and nothing the
quality stage does without new vertices repairs it: the vertices are on the surface where they
should be, there are too few of them. Measured on libigl's ``fertility`` at h = D/50: 176
boundary edges longer than 1.6 h (up to 3.1 h), against none over 1.8 h on a sphere.

:func:`split_long_boundary_edges` splits every boundary edge longer than ``LONG_EDGE`` times the
local size at its midpoint projected onto the zero set: each cell around the edge becomes two.
The splits of one pass touch disjoint cells (longest edges first); passes repeat until no edge
is long. A split is refused when the projection jumps away from the edge (another surface
across a thin gap) or when a new cell would be inverted.
"""

from __future__ import annotations

from typing import Callable

import numpy as np

from .tet_shape import ShapeTargets, signed_volume
from .tet_topology import EDGE_OF_TET, edge_keys, face_neighbours, faces_on_boundary

__all__ = ["split_long_boundary_edges", "split_edges", "LONG_EDGE"]

#: Edges longer than this many local sizes (times the mesh's own scale, when above 1) are split.
LONG_EDGE = 1.8
#: Edges sampled for the mesh's scale (the median of length over local size).
SCALE_SAMPLES = 20_000
#: A midpoint may move at most this fraction of the edge's length onto the zero set.
MAX_PROJECTION = 0.3
#: Passes of splits at most (an edge of 3 h needs one; of 6 h, two).
MAX_PASSES = 4
#: Times the splits are made again without those whose faces crossed the boundary.
MAX_RETRIES = 4


def _boundary_edges(tets: np.ndarray, n_points: int) -> np.ndarray:
    """The edges of the faces that only one of ``tets`` holds (with every cell at an edge's
    ends among ``tets``, its boundary edges among them are the mesh's)."""
    faces = faces_on_boundary(tets, face_neighbours(tets, n_points))
    pairs = np.concatenate([faces[:, [0, 1]], faces[:, [1, 2]], faces[:, [2, 0]]])
    return np.unique(np.sort(pairs, axis=1), axis=0)


def _disjoint(cells: np.ndarray, owner: np.ndarray, allowed: np.ndarray, n_cells: int) -> np.ndarray:
    """Which allowed edges to split in one pass, given their rings as ``cells`` (flat) of
    ``owner`` edges (in priority order): the first of the edges around each cell wins."""
    big = np.iinfo(np.int64).max
    rank = np.where(allowed[owner], owner, big)
    holder = np.full(n_cells, big)
    np.minimum.at(holder, cells, rank)
    chosen = allowed.copy()
    np.logical_and.at(chosen, owner, holder[cells] == owner)
    return chosen


def _mesh_scale(points, pairs, h, size) -> float:
    """The median of edge length over local size on up to ``SCALE_SAMPLES`` edges (DistMesh's
    edges are its sizes times one global factor, about 1.05 when uniform)."""
    sample = pairs[:: max(1, pairs.shape[0] // SCALE_SAMPLES)]
    length = np.linalg.norm(points[sample[:, 0]] - points[sample[:, 1]], axis=1)
    local = h if size is None else h * np.asarray(size(0.5 * (points[sample[:, 0]] + points[sample[:, 1]])), dtype=float)
    return float(np.median(length / local))


def _long_edges(points, tets, h, size, scale) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The edges longer than ``LONG_EDGE`` times ``scale`` local sizes, longest first: (E, 2),
    midpoints, lengths."""
    pairs = tets[:, EDGE_OF_TET].reshape(-1, 2)
    vectors = points[pairs[:, 0]] - points[pairs[:, 1]]
    squared = np.einsum("ij,ij->i", vectors, vectors)
    # a cheap pre-filter on every edge of every cell (relative sizes are taken to be >= 1/2)
    floor = LONG_EDGE * scale * h * (1.0 if size is None else 0.5)
    candidates = np.unique(np.sort(pairs[squared > floor * floor], axis=1), axis=0)
    length = np.linalg.norm(points[candidates[:, 0]] - points[candidates[:, 1]], axis=1)
    middle = 0.5 * (points[candidates[:, 0]] + points[candidates[:, 1]])
    local = h if size is None else h * np.asarray(size(middle), dtype=float)
    keep = np.flatnonzero(length > LONG_EDGE * scale * local)
    keep = keep[np.argsort(-length[keep], kind="stable")]
    return candidates[keep], middle[keep], length[keep]


def _split_pass(points, tets, model, h, size, scale: float, first_new: int = 0,
                locked: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray, int]:
    """One pass of splits; only the cells with a vertex numbered ``first_new`` or above are
    searched for long edges (the halves of the last pass's splits)."""
    searched = tets if first_new == 0 else tets[(tets >= first_new).any(axis=1)]
    edges, middle, length = _long_edges(points, searched, h, size, scale)
    return split_edges(points, tets, model, h, edges, locked)


def split_edges(points: np.ndarray, tets: np.ndarray, model, h: float, edges: np.ndarray,
                locked: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray, int]:
    """Split ``edges`` (E, 2), in priority order, at their midpoints: a boundary edge's midpoint
    projected onto the zero set, an inner edge's kept where it is (if inside the model).

    Splits whose projection jumps away from the edge or that would invert a cell are left out,
    and so is every edge sharing a cell with an edge earlier in the list (the splits of one call
    touch disjoint cells), and so is a split whose new boundary faces cross the boundary (a
    midpoint projected onto the zero set across a thin wall: on libigl's halftunnel.off as a
    winding-number solid at ``h=(D/100, D/25)``, 21 crossing pairs, and the whole quality stage
    was then dropped for a 0.2 deg mesh). An edge between two ``locked`` vertices (N,) bool is
    never split (with cells in labelled regions, the faces between two regions are made of such
    vertices and stay). Returns the points with the K new vertices appended, the cells and K.
    """
    edges = np.asarray(edges, dtype=np.int64).reshape(-1, 2)
    allowed = np.ones(edges.shape[0], dtype=bool) if locked is None else ~locked[edges].all(axis=1)
    for _ in range(MAX_RETRIES):
        new_points, new_tets, chosen = _split_chosen(points, tets, model, h, edges, allowed)
        if chosen.size == 0:
            return points, tets, 0
        crossing = _crossing_new_vertices(new_points, new_tets, points.shape[0])
        if not crossing.any():
            return new_points, new_tets, int(chosen.size)
        allowed[chosen[crossing]] = False
    return points, tets, 0


def _crossing_new_vertices(points: np.ndarray, tets: np.ndarray, first_new: int) -> np.ndarray:
    """Which of the vertices numbered from ``first_new`` on lie on a boundary face that crosses
    another boundary face (only the faces near them are tested)."""
    from scipy.spatial import cKDTree

    from .validate import crossing_faces

    new = np.zeros(points.shape[0] - first_new, dtype=bool)
    faces = faces_on_boundary(tets, face_neighbours(tets, points.shape[0]))
    touching = (faces >= first_new).any(axis=1)
    if not touching.any():
        return new
    centres = points[faces].mean(axis=1)
    radius = np.linalg.norm(points[faces] - centres[:, None], axis=2).max(axis=1)
    reach = 2.0 * float(radius.max())
    near = cKDTree(centres[touching]).query_ball_point(centres, reach, return_length=True) > 0
    subset = np.flatnonzero(near | touching)
    pairs = crossing_faces(points, faces[subset])
    corners = faces[subset][pairs.ravel()].ravel() if len(pairs) else np.zeros(0, dtype=np.int64)
    corners = corners[corners >= first_new]
    new[corners - first_new] = True
    return new


def _split_chosen(points, tets, model, h: float, edges: np.ndarray, allowed: np.ndarray):
    """The splits of the ``allowed`` edges (see :func:`split_edges`): the points with the new
    vertices appended, the cells, and the indices into ``edges`` of the edges split, in the
    order of their new vertices."""
    n = points.shape[0]
    empty = np.zeros(0, dtype=np.int64)
    index_of = np.flatnonzero(allowed)
    edges = edges[index_of]
    if edges.shape[0] == 0:
        return points, tets, empty
    middle = 0.5 * (points[edges[:, 0]] + points[edges[:, 1]])
    length = np.linalg.norm(points[edges[:, 0]] - points[edges[:, 1]], axis=1)
    # everything below looks at the cells at the long edges' ends only: every cell around such
    # an edge and every face on it is one of them
    ends = np.zeros(n, dtype=bool)
    ends[edges.ravel()] = True
    around = np.flatnonzero(ends[tets].any(axis=1))
    sub = tets[around]
    # a boundary edge's midpoint goes onto the zero set; an inner edge's stays (if inside)
    keys = edge_keys(edges, n)
    on_surface = np.isin(keys, edge_keys(_boundary_edges(sub, n), n))
    new = middle.copy()
    if on_surface.any():
        new[on_surface] = model.project(middle[on_surface], iterations=20, tol=1e-6 * h, warn=False)
    near = np.linalg.norm(new - middle, axis=1) <= MAX_PROJECTION * length
    values = model(new)
    near &= np.where(on_surface, np.abs(values) <= 1e-3 * h, values < 0)
    edges, new, index_of = edges[near], new[near], index_of[near]
    if edges.shape[0] == 0:
        return points, tets, empty
    # the cells around each edge
    all_keys = edge_keys(sub[:, EDGE_OF_TET].reshape(-1, 2), n)
    order = np.argsort(all_keys, kind="stable")
    sorted_keys = all_keys[order]
    keys = edge_keys(edges, n)
    start = np.searchsorted(sorted_keys, keys, side="left")
    count = np.searchsorted(sorted_keys, keys, side="right") - start
    slots = order[np.repeat(start, count) + np.arange(count.sum()) - np.repeat(np.cumsum(count) - count, count)]
    owner = np.repeat(np.arange(edges.shape[0]), count)
    cells = around[slots // 6]
    local_edge = EDGE_OF_TET[slots % 6]
    # each cell (.., u, .., v, ..) becomes one copy with u -> m and one with v -> m
    index = n + owner
    first, second = tets[cells].copy(), tets[cells].copy()
    rows = np.arange(cells.size)
    first[rows, local_edge[:, 0]] = index
    second[rows, local_edge[:, 1]] = index
    all_points = np.concatenate([points, new])
    # a cell of zero score (flat to rounding) is refused too: the quality stage cannot start from it
    scores = ShapeTargets()
    positive = ((signed_volume(all_points[first]) > 0) & (signed_volume(all_points[second]) > 0)
                & (scores.score(all_points[first]) > 0) & (scores.score(all_points[second]) > 0))
    fine = np.ones(edges.shape[0], dtype=bool)
    np.logical_and.at(fine, owner, positive)
    chosen = _disjoint(cells, owner, fine, tets.shape[0])
    if not chosen.any():
        return points, tets, empty
    take = chosen[owner]
    keep = np.ones(tets.shape[0], dtype=bool)
    keep[cells[take]] = False
    # new points renumbered to the chosen ones only
    renumber = np.full(edges.shape[0], -1, dtype=np.int64)
    renumber[chosen] = n + np.arange(int(chosen.sum()))
    first, second = first[take], second[take]
    for part in (first, second):
        moved = part >= n
        part[moved] = renumber[part[moved] - n]
    tets = np.concatenate([tets[keep], first, second])
    return np.concatenate([points, new[chosen]]), tets, index_of[chosen]


def split_long_boundary_edges(
    points: np.ndarray,
    tets: np.ndarray,
    model,
    h: float,
    size: Callable | None = None,
    scale: float | None = None,
    locked: np.ndarray | None = None,
) -> tuple[np.ndarray, np.ndarray, int]:
    """Split the edges longer than ``LONG_EDGE`` local sizes (times ``scale``) at their midpoints,
    projected onto the zero set for boundary edges.

    Parameters
    ----------
    points : (N, 3) float array
    tets : (M, 4) int array, positively oriented, forming a solid
    model : fepre.sdf.SDF
        The model the mesh was made from: the new vertices lie on its zero set.
    h : float
        The edge length (the smallest one with ``size``).
    size : callable, optional
        ``size((K, 3)) -> (K,)``, the local edge length over ``h``; uniform when None.
    scale : float, optional
        The mesh's edge length over the local size; measured when None (the median over up to
        ``SCALE_SAMPLES`` edges, at least 1): a graded DistMesh mesh's edges are its sizes times
        one factor, and only edges long for the mesh itself are gaps.
    locked : (N,) bool, optional
        Vertices no edge between two of which is split (a region mesh's interface nodes).

    Returns
    -------
    points : (N + K, 3) the points, the K new vertices appended
    tets : the cells, every one around a split edge replaced by its two halves
    splits : K, the number of edges split

    Examples
    --------
    Four cells inscribed in the unit sphere, edges 1.63 long, refined for h = 0.5: every new
    vertex lies on the sphere:

    >>> import numpy as np
    >>> from fepre import sdf
    >>> ball = sdf.sphere(1.0)
    >>> r = 1 / np.sqrt(3)
    >>> points = np.array([[0.0, 0.0, 0.0], [r, r, r], [r, -r, -r], [-r, r, -r], [-r, -r, r]])
    >>> tets = np.array([[0, 1, 2, 3], [0, 1, 4, 2], [0, 1, 3, 4], [0, 2, 4, 3]])
    >>> new_points, new_tets, splits = split_long_boundary_edges(points, tets, ball, h=0.5, scale=1.0)
    >>> splits, len(new_points) - len(points), len(new_tets)
    (16, 16, 36)
    >>> bool(np.allclose(np.linalg.norm(new_points[5:], axis=1), 1.0))
    True
    """
    total, first_new = 0, 0
    if scale is None:
        scale = max(1.0, _mesh_scale(points, tets[:, EDGE_OF_TET].reshape(-1, 2), h, size))
    for _ in range(MAX_PASSES):
        count = points.shape[0]
        if locked is not None:
            locked = np.concatenate([locked, np.zeros(points.shape[0] - locked.shape[0], dtype=bool)])
        points, tets, splits = _split_pass(points, tets, model, h, size, scale, first_new, locked)
        first_new = count
        total += splits
        if splits == 0:
            break
    return points, tets, total
