"""fepre's naive surface nets: one vertex per piece of surface in an active cell, one quad per crossing grid edge.

The vertex of a piece is the mean of the level crossings on its cut edges. The connectivity
(:mod:`fepre.surface.dual_cells`) gives every interior crossing grid edge the quad of the four
pieces around it, outward; each quad is split along its shorter diagonal. A cell holding two
separate pieces of the surface (an ambiguous face or cube: a thin wall, an edge at an angle to
the grid) gives each its own vertex, so the surface is closed and manifold wherever marching
cubes' is.
"""

from __future__ import annotations

import numpy as np

from .dual_cells import dual_cells, dual_keys, empty_dual_result, shorter_diagonal, split_quads
from .table_extraction import edge_points

__all__ = ["surface_nets"]


def surface_nets(
    values: np.ndarray,
    level: float,
    origin: np.ndarray,
    spacing: np.ndarray,
    workers: int | None = None,
    *,
    first_node: np.ndarray | None = None,
    keys: bool = False,
):
    """Points (one per active cell) and outward triangles of the ``level`` set.

    ``first_node``: the (i, j, k) index of ``values[0, 0, 0]`` in the grid of ``origin``. With
    ``keys``, also :func:`fepre.surface.dual_cells.dual_keys` (each vertex's cell and piece, each
    triangle's crossing edge).

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
    dual = dual_cells(values, level, workers)
    if dual is None:
        return empty_dual_result(keys)
    crossings = np.concatenate(
        [
            edge_points(e, d, values, level, origin, spacing, first_node)
            for e, d in zip(dual.scan.edges, np.eye(3, dtype=int))
        ]
    )
    points = dual.cell_means(crossings)
    triangles = split_quads(dual.quads, shorter_diagonal(points, dual.quads))
    return (points, triangles, dual_keys(dual)) if keys else (points, triangles)
