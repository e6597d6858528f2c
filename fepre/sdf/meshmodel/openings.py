"""The solid of an open surface: where its generalised winding number exceeds 1/2.

A scan with large openings, or two open sheets that overlap, encloses no solid that a hole fill
could recover, yet the generalised winding number ``w`` of its triangles (Jacobson, Kavan and
Sorkine-Hornung 2013) still says which points it wraps: ``{w > 1/2}`` is the solid it stands
for. Its boundary is made of two kinds of surface:

* the input triangles where they separate ``w > 1/2`` from ``w <= 1/2`` (the sheet's other
  parts, hanging in or out of the solid, are dropped; triangles crossing a seam are split, as in
  :func:`.repair.repair`);
* a surface spanning each opening: the ``w = 1/2`` level set away from the sheet. It is
  extracted on a grid of ``cells`` cells along the longest side (vtkFlyingEdges3D on the fast
  winding numbers), the contour triangles that follow the sheet dropped (within ``SHEET_GAP``
  grid spacings of it, on a grid edge along which ``w`` jumps: it jumps by one across the
  sheet), and the rim of what is left snapped onto the open edges of the kept sheet, so the two
  meet without a gap. Under an open-bottomed slab ``w`` hovers near 1/2 and the span runs close
  to the sheet: such places are refined (``HOVER``), and a rim that meets no open edge of the
  sheet (a slab thinner than the grid) is capped, so that the union stays closed.

:func:`span_openings` returns both as one :class:`.repair.Repair` (the spanning triangles marked
``filled``), so :class:`.model.MeshModel` measures the exact distance to their union (continuous,
1-Lipschitz) and signs it by the winding number of that union.
"""

from __future__ import annotations

import numpy as np

from .repair import Repair, _drop_degenerate_and_duplicates, _drop_internal, _merge_vertices, _orient
from .tables import edge_table, face_normals, used_vertices, winding_numbers

__all__ = ["span_openings", "OPENING_CELLS", "SHEET_GAP"]

#: Grid cells along the longest side of the box in which the spanning surfaces are extracted.
OPENING_CELLS = 128

#: Contour triangles with a corner closer than this many grid spacings to the sheet are dropped
#: (a contour vertex that follows the sheet lies on a grid edge the sheet crosses: within one).
SHEET_GAP = 1.5


#: The grid starts this many spacings below the surface's lowest point (not a whole number).
GRID_OFFSET = 2.381966


def _grid(vertices: np.ndarray, cells: int):
    import pyvista as pv

    lower, upper = vertices.min(axis=0), vertices.max(axis=0)
    spacing = float((upper - lower).max()) / cells
    # off the grid lines by a fraction: a face of the input in the plane of its lowest or highest
    # point (a CAD face, a box's bottom) would otherwise hold a row of nodes, whose winding
    # numbers are neither side's
    origin = lower - GRID_OFFSET * spacing
    dimensions = np.ceil((upper - lower) / spacing).astype(int) + 5
    return pv.ImageData(dimensions=tuple(int(d) for d in dimensions), spacing=(spacing,) * 3, origin=tuple(origin)), spacing


def _open_edges(faces: np.ndarray) -> np.ndarray:
    """Edges (E, 2) used by one triangle."""
    edges, face_edge, _ = edge_table(faces)
    counts = np.bincount(face_edge.reshape(-1), minlength=len(edges))
    return edges[counts == 1]


def _closest_on_segments(points: np.ndarray, starts: np.ndarray, ends: np.ndarray, step: float):
    """Closest points (N, 3) on a set of segments and their distances: the segment of the
    nearest of points sampled along them every ``step``, then the exact projection onto it."""
    from scipy.spatial import cKDTree

    lengths = np.linalg.norm(ends - starts, axis=1)
    pieces = np.maximum(np.ceil(lengths / step).astype(np.int64), 1)
    counts = pieces + 1
    segment = np.repeat(np.arange(len(starts)), counts)
    first = np.repeat(np.cumsum(counts) - counts, counts)
    offsets = (np.arange(int(counts.sum())) - first) / np.repeat(pieces, counts)
    samples = starts[segment] + offsets[:, None] * (ends - starts)[segment]
    nearest = segment[cKDTree(samples).query(points)[1]]
    a, b = starts[nearest], ends[nearest]
    direction = b - a
    t = np.einsum("ij,ij->i", points - a, direction) / np.maximum(np.einsum("ij,ij->i", direction, direction), 1e-300)
    closest = a + np.clip(t, 0.0, 1.0)[:, None] * direction
    return closest, np.linalg.norm(points - closest, axis=1)


#: The winding numbers are computed on every COARSE-th grid node first, then on the nodes of the
#: coarse cells where the spanning surfaces can be (next to a crossing of 1/2 away from the sheet,
#: or near the kept sheet's open edges); the others take their nearest coarse node's value and
#: the contour there is dropped (it follows the sheet).
COARSE = 4


def _straddling(above: np.ndarray) -> np.ndarray:
    """Cells of a node grid whose corners are not all on one side."""
    shape = tuple(n - 1 for n in above.shape)
    cells = np.zeros(shape, dtype=bool)
    for i, j, k in np.ndindex(2, 2, 2):
        cells |= above[i:i + shape[0], j:j + shape[1], k:k + shape[2]] != above[:-1, :-1, :-1]
    return cells


#: A coarse cell that the sheet passes through and that has a corner whose winding number is
#: within this of 1/2 may hold a slab of the solid thinner than the coarse spacing (an open
#: bottom under a sheet: ``w`` hovers near 1/2 below it), which its corners do not see.
HOVER = 0.25


def _thin_slabs(coarse: np.ndarray, coarse_points: np.ndarray, tree, reach: float) -> np.ndarray:
    """Coarse cells (a boolean grid one smaller than ``coarse``) the sheet passes through with a
    corner's winding number within ``HOVER`` of 1/2."""
    near_half = np.abs(coarse - 0.5) < HOVER
    shape = tuple(n - 1 for n in coarse.shape)
    cells = np.zeros(shape, dtype=bool)
    for i, j, k in np.ndindex(2, 2, 2):
        cells |= near_half[i:i + shape[0], j:j + shape[1], k:k + shape[2]]
    index = np.nonzero(cells)
    centres = (coarse_points[index] + coarse_points[tuple(i + 1 for i in index)]) / 2
    cells[index] = np.sqrt(tree.query(centres)[0]) < reach / 2
    return cells


def _winding_grid(vertices, faces, grid, tree, rim: tuple[np.ndarray, np.ndarray]):
    """Winding numbers at the nodes of ``grid`` (VTK's order, x fastest), exact (libigl's fast
    approximation) in the refined coarse cells; those cells and the coarse nodes' grid indices."""
    from scipy import ndimage

    shape = tuple(int(d) for d in grid.dimensions)
    spacing = float(grid.spacing[0])
    axes = [np.asarray(grid.origin[k]) + spacing * np.arange(shape[k]) for k in range(3)]
    coarse_axes = [np.unique(np.append(np.arange(0, n, COARSE), n - 1)) for n in shape]
    coarse_points = np.stack(np.meshgrid(*(axes[k][coarse_axes[k]] for k in range(3)), indexing="ij"), -1)
    coarse = winding_numbers(vertices, faces, coarse_points.reshape(-1, 3)).reshape(coarse_points.shape[:3])
    cells = _straddling(coarse > 0.5)
    index = np.nonzero(cells)
    centres = (coarse_points[index] + coarse_points[tuple(i + 1 for i in index)]) / 2
    reach = np.sqrt(3.0) * COARSE * spacing  # a coarse cell's diagonal
    far = np.sqrt(tree.query(centres)[0]) > reach / 2 + SHEET_GAP * spacing
    near_rim = np.zeros(len(centres), dtype=bool)
    if len(rim[0]):
        near_rim = _closest_on_segments(centres, rim[0], rim[1], spacing)[1] < 2 * reach
    cells[index] = far | near_rim
    cells |= _thin_slabs(coarse, coarse_points, tree, reach)
    cells = ndimage.binary_dilation(cells, iterations=1)
    # fine nodes: their coarse cell (clipped at the last) and nearest coarse node
    owner = [np.minimum(np.searchsorted(coarse_axes[k], np.arange(shape[k]), side="right") - 1, cells.shape[k] - 1) for k in range(3)]
    nearest = [np.abs(np.arange(shape[k])[:, None] - coarse_axes[k][None, :]).argmin(axis=1) for k in range(3)]
    active = cells[np.ix_(*owner)]
    # a fine node on a coarse cell's face belongs to the cells on both sides
    for k in range(3):
        on_face = np.isin(np.arange(shape[k]), coarse_axes[k])
        before = list(owner)
        before[k] = np.maximum(owner[k] - 1, 0)
        active |= cells[np.ix_(*before)] & on_face.reshape([-1 if j == k else 1 for j in range(3)])
    values = coarse[np.ix_(*nearest)]
    where = np.nonzero(active)
    values[where] = winding_numbers(vertices, faces, np.stack([axes[k][where[k]] for k in range(3)], axis=1))
    return values.ravel(order="F"), cells, coarse_axes


#: A grid edge along which the winding number changes by more than this crosses the sheet (it
#: jumps by one there); across a spanning surface it changes smoothly, by far less per spacing.
JUMP = 0.5


def _on_jumps(points: np.ndarray, grid, values: np.ndarray) -> np.ndarray:
    """Which contour vertices (N, 3) lie on a grid edge where the winding number jumps (the edge
    crosses the sheet: the vertex follows the sheet) rather than passing 1/2 smoothly."""
    shape = np.asarray(grid.dimensions, dtype=np.int64)
    position = (points - np.asarray(grid.origin)) / float(grid.spacing[0])
    axis = np.abs(position - np.round(position)).argmax(axis=1)  # the one coordinate off the grid lines
    lower = np.round(position).astype(np.int64)
    rows = np.arange(len(points))
    lower[rows, axis] = np.floor(position[rows, axis]).astype(np.int64)
    lower = np.clip(lower, 0, shape - 1)
    upper = lower.copy()
    upper[rows, axis] = np.minimum(lower[rows, axis] + 1, shape[axis] - 1)
    stride = np.array([1, shape[0], shape[0] * shape[1]])
    values = np.asarray(values)
    return np.abs(values[upper @ stride] - values[lower @ stride]) > JUMP


def _cap_free_rims(points: np.ndarray, triangles: np.ndarray, snapped: np.ndarray):
    """Close each loop of open edges of the spans that has no vertex in ``snapped`` (a rim that
    meets no open edge of the sheet) with a fan from its centroid, oriented with the spans."""
    from scipy import sparse
    from scipy.sparse import csgraph

    directed = np.concatenate([triangles[:, [0, 1]], triangles[:, [1, 2]], triangles[:, [2, 0]]])
    keys = np.sort(directed, axis=1)
    _, inverse, counts = np.unique(keys, axis=0, return_inverse=True, return_counts=True)
    open_edges = directed[counts[inverse.reshape(-1)] == 1]
    if len(open_edges) == 0:
        return points, triangles
    graph = sparse.coo_matrix((np.ones(len(open_edges)), (open_edges[:, 0], open_edges[:, 1])), shape=(len(points),) * 2)
    _, label = csgraph.connected_components(graph, directed=False)
    loop = label[open_edges[:, 0]]
    tied = np.zeros(label.max() + 1, dtype=bool)
    tied[label[snapped]] = True
    free = ~tied[loop]
    if not free.any():
        return points, triangles
    loops, loop = np.unique(loop[free], return_inverse=True)
    ends = open_edges[free]
    centres = np.zeros((len(loops), 3))
    np.add.at(centres, loop, points[ends[:, 0]])
    centres /= np.bincount(loop, minlength=len(loops))[:, None]
    caps = np.column_stack([ends[:, 1], ends[:, 0], len(points) + loop])
    return np.concatenate([points, centres]), np.concatenate([triangles, caps])


def _spanning_surface(vertices, faces, sheet_vertices, sheet_faces, cells: int):
    """Triangles of the ``w = 1/2`` level set away from the sheet, oriented outwards, their rims
    snapped onto the kept sheet's open edges; and the grid spacing."""
    from .bvh import TriangleTree

    tree = TriangleTree(vertices, faces)
    sheet_edges = _open_edges(sheet_faces)
    rim = (sheet_vertices[sheet_edges[:, 0]], sheet_vertices[sheet_edges[:, 1]])
    grid, spacing = _grid(vertices[used_vertices(faces, len(vertices))], cells)
    grid.point_data["w"], refined, coarse_axes = _winding_grid(vertices, faces, grid, tree, rim)
    contour = grid.contour([0.5], scalars="w", method="flying_edges").triangulate().clean()
    if contour.n_cells == 0:
        return np.zeros((0, 3)), np.zeros((0, 3), np.int64), spacing
    points = np.asarray(contour.points, dtype=np.float64)
    triangles = contour.faces.reshape(-1, 4)[:, 1:].astype(np.int64)
    fine = np.floor((points - np.asarray(grid.origin)) / spacing).astype(np.int64)
    cell = [np.clip(np.searchsorted(coarse_axes[k], fine[:, k], side="right") - 1, 0, refined.shape[k] - 1) for k in range(3)]
    near = np.sqrt(tree.query(points)[0]) < SHEET_GAP * spacing
    drop = ~refined[tuple(cell)] | (near & _on_jumps(points, grid, grid.point_data["w"]))
    triangles = triangles[~drop[triangles].any(axis=1)]
    if len(triangles) == 0:
        return np.zeros((0, 3)), np.zeros((0, 3), np.int64), spacing
    used, triangles = np.unique(triangles, return_inverse=True)
    points, triangles = points[used], triangles.reshape(-1, 3)
    # outwards: towards smaller w
    normals, areas = face_normals(points, triangles)
    centres = points[triangles].mean(axis=1)
    step = 0.25 * spacing * normals
    front, back = np.split(winding_numbers(vertices, faces, np.concatenate([centres + step, centres - step])), 2)
    triangles = np.where((front > back)[:, None], triangles[:, ::-1], triangles)
    # the rim meets the sheet: its vertices move onto the nearest open edge of the kept sheet
    edge = np.unique(_open_edges(triangles))
    snap = np.zeros(len(edge), dtype=bool)
    if len(edge) and len(rim[0]):
        closest, distance = _closest_on_segments(points[edge], rim[0], rim[1], spacing / 4)
        snap = distance <= 2.0 * SHEET_GAP * spacing
    # rims that meet no open edge of the sheet bound the places where the solid is thinner than
    # the grid resolves: capped, so the union of sheet and spans stays closed
    points, triangles = _cap_free_rims(points, triangles, edge[snap])
    if len(edge) and len(rim[0]):
        points[edge[snap]] = closest[snap]
        # rim vertices snapped onto one point: one vertex, and the triangles it collapses dropped
        # (a zero-area triangle has no closest-point barycentrics)
        points, triangles, _ = _merge_vertices(points, triangles)
        triangles = triangles[face_normals(points, triangles)[1] > 1e-12 * spacing**2]
    return points, triangles, spacing


def span_openings(vertices: np.ndarray, faces: np.ndarray, cells: int = OPENING_CELLS) -> Repair:
    """The boundary of ``{w > 1/2}`` of a triangle surface: the separating input triangles and
    surfaces spanning its openings (see the module's description).

    Parameters
    ----------
    vertices : (V, 3) float64
    faces : (F, 3) int64
    cells : int
        Grid cells along the longest side for the spanning surfaces.

    Returns
    -------
    Repair
        ``filled`` marks the spanning triangles, ``holes`` counts their pieces and ``hole_area``
        their area; ``closed`` is False (the two kinds of triangle meet along the rims without
        shared vertices).

    Examples
    --------
    >>> import numpy as np, pyvista as pv
    >>> cap = pv.Sphere(theta_resolution=48, phi_resolution=48).clip(normal="-z", origin=(0, 0, 0))
    >>> cap = cap.triangulate().clean()
    >>> solid = span_openings(np.asarray(cap.points, float), cap.faces.reshape(-1, 4)[:, 1:])
    >>> solid.holes, round(solid.hole_area / (np.pi * 0.25), 2)    # one flat disc across the rim
    (1, 1.0)
    """
    # about the surface's centre: the grid, VTK's contour (single precision) and the winding
    # numbers then give the same spans wherever the part is placed
    vertices = np.asarray(vertices, dtype=np.float64)
    centre = 0.5 * (vertices.min(axis=0) + vertices.max(axis=0)) if len(vertices) else np.zeros(3)
    vertices = vertices - centre
    faces = np.asarray(faces, dtype=np.int64)
    vertices, faces, merged = _merge_vertices(vertices, faces, weld=True)
    faces, degenerate, duplicates = _drop_degenerate_and_duplicates(faces)
    faces, flipped = _orient(vertices, faces)
    # a sheet written inside out wraps its solid with w near -1: turn it over
    grid, _ = _grid(vertices, 24)
    probe = winding_numbers(vertices, faces, np.asarray(grid.points, dtype=np.float64))
    if np.count_nonzero(probe < -0.5) > np.count_nonzero(probe > 0.5):
        faces = faces[:, ::-1]
        flipped = len(faces) - flipped
    sheet_vertices, sheet_faces, _, internal, backwards = _drop_internal(vertices, faces)
    # the pieces of triangles split at a seam share their corners: one patch, not one per piece
    sheet_vertices, sheet_faces, _ = _merge_vertices(sheet_vertices, sheet_faces)
    sheet_faces = _drop_degenerate_and_duplicates(sheet_faces)[0]
    points, triangles, _ = _spanning_surface(vertices, faces, sheet_vertices, sheet_faces, cells)
    pieces = 0
    if len(triangles):
        from scipy import sparse
        from scipy.sparse import csgraph

        owners = np.repeat(np.arange(len(triangles)), 3)
        incidence = sparse.coo_matrix((np.ones(len(owners)), (owners, triangles.reshape(-1))), shape=(len(triangles), len(points)))
        pieces = int(csgraph.connected_components((incidence @ incidence.T).tocsr(), directed=False)[0])
    all_vertices = np.concatenate([sheet_vertices, points]) + centre
    all_faces = np.concatenate([sheet_faces, triangles + len(sheet_vertices)])
    filled = np.arange(len(all_faces)) >= len(sheet_faces)
    return Repair(
        vertices=all_vertices,
        faces=all_faces,
        merged=merged,
        degenerate=degenerate,
        duplicates=duplicates,
        flipped=flipped + backwards,
        holes=pieces,
        hole_area=float(face_normals(points, triangles)[1].sum()) if len(triangles) else 0.0,
        internal=internal,
        open_edges=0,
        closed=False,
        filled=filled,
    )
