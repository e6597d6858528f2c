"""fepre's naive surface nets: one vertex per active cell, one quad per crossing grid edge.

The vertex of a cell is the mean of the level crossings on its cut edges. Every interior grid
edge whose ends lie on different sides gives the quad of the four cells around it, ordered so
its normal points along the edge from the inside end to the outside end, and split along its
shorter diagonal.

Where one cell holds two separate pieces of the surface (an ambiguous face or cube), both pieces
share the cell's vertex and the surface pinches there; :func:`fepre.check_surface` reports such
a surface as not manifold. On smooth parts sampled finely enough it does not happen.
"""

from __future__ import annotations

import numpy as np

from .grid_scan import AXIS_DIRECTIONS, inside_threshold, scan_grid
from .marching_cubes import CUBE_TABLE
from .table_extraction import cell_edge_vertices, edge_points

__all__ = ["surface_nets"]


def _quad_cells(edges: np.ndarray, axis: int, shape) -> tuple[np.ndarray, np.ndarray]:
    """The four cells around each edge, counter-clockwise seen from the edge's + end."""
    nz, ny, nx = shape
    layer = nx * ny
    k, rest = np.divmod(edges, layer)
    j, i = np.divmod(rest, nx)
    # (a, b): the two axes across the edge, in right-handed cyclic order after ``axis``
    steps = {0: ((j, ny, nx), (k, nz, layer)), 1: ((k, nz, layer), (i, nx, 1)), 2: ((i, nx, 1), (j, ny, nx))}
    (ia, na, sa), (ib, nb, sb) = steps[axis]
    valid = (ia >= 1) & (ia <= na - 2) & (ib >= 1) & (ib <= nb - 2)
    n = edges[valid]
    quads = np.stack([n - sa - sb, n - sb, n, n - sa], axis=1)
    return quads, valid


def surface_nets(
    values: np.ndarray, level: float, origin: np.ndarray, spacing: np.ndarray, workers: int | None = None
) -> tuple[np.ndarray, np.ndarray]:
    """Points (one per active cell) and outward triangles of the ``level`` set.

    Examples
    --------
    >>> import numpy as np
    >>> t = np.linspace(-1, 1, 9)
    >>> r = np.sqrt(t[None, None, :]**2 + t[None, :, None]**2 + t[:, None, None]**2) - 0.6
    >>> points, triangles = surface_nets(r, 0.0, np.full(3, -1.0), np.full(3, 0.25))
    >>> len(points) < len(triangles)
    True
    """
    origin = np.asarray(origin, float)
    spacing = np.asarray(spacing, float)
    scan = scan_grid(values, level, AXIS_DIRECTIONS, workers)
    sizes = np.array([e.size for e in scan.edges])
    if sizes.sum() == 0:
        return np.empty((0, 3)), np.empty((0, 3), dtype=np.int64)
    offsets = np.concatenate([[0], np.cumsum(sizes)])
    crossings = np.concatenate(
        [edge_points(e, d, values, level, origin, spacing) for e, d in zip(scan.edges, AXIS_DIRECTIONS)]
    )
    cell, _, vertex = cell_edge_vertices(scan, CUBE_TABLE, offsets)
    count = np.bincount(cell, minlength=scan.cells.size)
    points = np.stack(
        [np.bincount(cell, weights=crossings[vertex, a], minlength=scan.cells.size) for a in range(3)], axis=1
    ) / count[:, None]
    flat = values.reshape(-1)
    quads = []
    for axis, edges in enumerate(scan.edges):
        cells, valid = _quad_cells(edges, axis, values.shape)
        quad = np.searchsorted(scan.cells, cells)
        backwards = flat[edges[valid]] >= inside_threshold(values.dtype, level)  # edge points inwards
        quad[backwards] = quad[backwards][:, ::-1]
        quads.append(quad)
    quads = np.concatenate(quads)
    p = points[quads]
    short02 = np.einsum("ij,ij->i", p[:, 0] - p[:, 2], p[:, 0] - p[:, 2]) <= np.einsum(
        "ij,ij->i", p[:, 1] - p[:, 3], p[:, 1] - p[:, 3]
    )
    first = np.where(short02[:, None], quads[:, [0, 1, 2]], quads[:, [0, 1, 3]])
    second = np.where(short02[:, None], quads[:, [0, 2, 3]], quads[:, [1, 2, 3]])
    return points, np.concatenate([first, second])
