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

from ..config import config
from .grid_scan import AXIS_DIRECTIONS, inside_threshold, scan_grid
from .marching_cubes import CUBE_TABLE
from .table_extraction import cell_edge_vertices, edge_points

__all__ = ["surface_nets"]


#: per axis, the slots (local edge index % 4 in each cell) of the four cells around an edge,
#: counter-clockwise seen from the edge's + end: (a-1, b-1), (a, b-1), (a, b), (a-1, b) for the
#: two axes (a, b) across the edge in right-handed order
_QUAD_SLOTS = (np.array([3, 2, 0, 1]), np.array([3, 1, 0, 2]), np.array([3, 2, 0, 1]))


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
    cell, local, vertex = cell_edge_vertices(scan, CUBE_TABLE, offsets, config.resolve_workers(workers))
    count = np.bincount(cell, minlength=scan.cells.size)
    points = np.stack(
        [np.bincount(cell, weights=crossings[vertex, a], minlength=scan.cells.size) for a in range(3)], axis=1
    ) / count[:, None]
    # every interior crossing edge is a cut edge of exactly four cells, and the cell's local
    # edge index says where around the edge the cell sits: a scatter, no search
    around = np.full((offsets[-1], 4), -1, dtype=np.int64)
    around[vertex, local % 4] = cell
    flat = values.reshape(-1)
    threshold = inside_threshold(values.dtype, level)
    quads = []
    for axis, edges in enumerate(scan.edges):
        quad = around[offsets[axis] : offsets[axis + 1]][:, _QUAD_SLOTS[axis]]
        valid = (quad >= 0).all(axis=1)  # edges on the grid's faces have fewer than four cells
        quad = quad[valid]
        backwards = flat[edges[valid]] >= threshold  # the start node is outside: the edge points in
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
