"""Connectivity of the dual methods: one vertex per piece of surface in a cell, one quad per crossing grid edge.

Surface nets and dual contouring share it; they differ only in where they put each vertex and
how they split each quad. A cell usually holds one piece of surface; where it holds several (a
thin wall, two faces meeting at an edge at an angle to the grid, a narrow gap) each piece gets
its own vertex, the pieces being those of the marching cubes case table (the cut edges joined by
its triangles), as in Schaefer, Ju and Warren's manifold dual contouring (2007). Vertices are
numbered by active cell (the order of :attr:`fepre.surface.grid_scan.GridScan.cells`), then by
piece; crossing ``k`` is the ``k``-th crossing grid edge (x edges first, then y, then z, each in
the scan's sorted order).

Every interior crossing edge is a cut edge of exactly four cells, and a cell's local edge index
says where around the edge the cell sits, so the quads come from a scatter, not a search. Each
quad is ordered so its normal points along its edge from the inside end to the outside end. The
quads are the dual of the marching cubes surface (a polygon per piece, a vertex per crossing),
which is closed and manifold, so the dual surface is too, and consistently outward wherever the
grid encloses the part. (One vertex per cell pinched the surface wherever a cell held two
pieces: rotated boxes, slots and plates came out non-manifold.)
"""

from __future__ import annotations

import functools
from dataclasses import dataclass

import numpy as np

from ..config import config
from .grid_scan import AXIS_DIRECTIONS, GridScan, inside_threshold, scan_grid
from .marching_cubes import CUBE_TABLE
from .table_extraction import cell_edge_vertices

__all__ = ["DualCells", "dual_cells", "split_quads", "shorter_diagonal"]

#: per axis, the slots (local edge index % 4 in each cell) of the four cells around an edge,
#: counter-clockwise seen from the edge's + end: (a-1, b-1), (a, b-1), (a, b), (a-1, b) for the
#: two axes (a, b) across the edge in right-handed order
_QUAD_SLOTS = (np.array([3, 2, 0, 1]), np.array([3, 1, 0, 2]), np.array([3, 2, 0, 1]))


@dataclass
class DualCells:
    """Active cells, crossing edges, their incidences and the outward quads of one grid.

    Attributes
    ----------
    scan : GridScan
        The active cells and the crossing edges along x, y and z.
    offsets : (4,) int64
        Crossing ``offsets[a] + i`` is edge ``scan.edges[a][i]``.
    cell, crossing : (K,) int64
        One row per (active cell, cut edge of that cell): the cell's index and the crossing's.
    quads : (Q, 4) int64
        Active-cell indices of each quad, counter-clockwise seen from outside.
    """

    scan: GridScan
    offsets: np.ndarray
    cell: np.ndarray
    crossing: np.ndarray
    quads: np.ndarray
    vertex_cell: np.ndarray

    @property
    def n_cells(self) -> int:
        """Number of vertices (pieces of surface in the active cells)."""
        return int(self.vertex_cell.size)

    @property
    def vertex_grid_cell(self) -> np.ndarray:
        """Flat grid cell id (VTK order) of every vertex, non-decreasing."""
        return self.scan.cells[self.vertex_cell]

    @property
    def n_crossings(self) -> int:
        """Number of crossing grid edges."""
        return int(self.offsets[-1])

    def crossing_edges(self) -> tuple[np.ndarray, np.ndarray]:
        """Start node id (flat, VTK order) and axis (0, 1, 2) of every crossing, in crossing order."""
        start = np.concatenate(self.scan.edges)
        axis = np.repeat(np.arange(3), np.diff(self.offsets))
        return start, axis

    def cell_means(self, values: np.ndarray) -> np.ndarray:
        """Per active cell, the mean of ``values`` (crossing order, (E,) or (E, m)) over its cut edges."""
        count = np.bincount(self.cell, minlength=self.n_cells)
        per_row = values[self.crossing]
        if per_row.ndim == 1:
            return np.bincount(self.cell, weights=per_row, minlength=self.n_cells) / count
        return np.stack(
            [np.bincount(self.cell, weights=per_row[:, a], minlength=self.n_cells) for a in range(per_row.shape[1])],
            axis=1,
        ) / count[:, None]


def dual_cells(values: np.ndarray, level: float, workers: int | None = None) -> DualCells | None:
    """Scan a (nz, ny, nx) array and build the dual connectivity; None when nothing crosses ``level``.

    Examples
    --------
    >>> import numpy as np
    >>> t = np.linspace(-1, 1, 9)
    >>> r = np.sqrt(t[None, None, :]**2 + t[None, :, None]**2 + t[:, None, None]**2) - 0.6
    >>> dual = dual_cells(r, 0.0)
    >>> dual.quads.shape[1], bool(dual.quads.max() < dual.n_cells)
    (4, True)
    """
    workers = config.resolve_workers(workers)
    scan = scan_grid(values, level, AXIS_DIRECTIONS, workers)
    sizes = np.array([e.size for e in scan.edges])
    if sizes.sum() == 0:
        return None
    offsets = np.concatenate([[0], np.cumsum(sizes)])
    cell, local, crossing = cell_edge_vertices(scan, CUBE_TABLE, offsets, workers)
    piece = _pieces()[scan.cases[cell], local]
    key = cell * 4 + piece
    keys, vertex = np.unique(key, return_inverse=True)
    vertex = vertex.ravel()
    order = np.argsort(vertex, kind="stable")
    around = np.full((offsets[-1], 4), -1, dtype=np.int64)
    around[crossing, local % 4] = vertex
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
    return DualCells(scan, offsets, vertex[order], crossing[order], np.concatenate(quads), keys // 4)


@functools.lru_cache(maxsize=1)
def _pieces() -> np.ndarray:
    """(256, 12) piece (0..3) of each cut local edge of each marching cubes case: edges joined by
    the case's triangles are one piece; -1 for uncut edges."""
    table = CUBE_TABLE
    pieces = np.full((256, 12), -1, dtype=np.int64)
    for case in range(256):
        parent = list(range(12))

        def find(e: int) -> int:
            while parent[e] != e:
                parent[e] = parent[parent[e]]
                e = parent[e]
            return e

        edges = table.triangle_edges[case, : table.triangle_count[case]]
        for a, b, c in edges:
            parent[find(int(b))] = find(int(a))
            parent[find(int(c))] = find(int(a))
        roots: dict[int, int] = {}
        for e in sorted({int(e) for e in edges.ravel()}):
            pieces[case, e] = roots.setdefault(find(e), len(roots))
    return pieces


def shorter_diagonal(points: np.ndarray, quads: np.ndarray) -> np.ndarray:
    """True where a quad's diagonal 0-2 is not longer than 1-3."""
    p = points[quads]
    d02, d13 = p[:, 0] - p[:, 2], p[:, 1] - p[:, 3]
    return np.einsum("ij,ij->i", d02, d02) <= np.einsum("ij,ij->i", d13, d13)


def split_quads(quads: np.ndarray, along02: np.ndarray) -> np.ndarray:
    """Two triangles per quad (same orientation), split along 0-2 where ``along02`` else along 1-3.

    All first triangles come first, then all second ones.
    """
    first = np.where(along02[:, None], quads[:, [0, 1, 2]], quads[:, [0, 1, 3]])
    second = np.where(along02[:, None], quads[:, [0, 2, 3]], quads[:, [1, 2, 3]])
    return np.concatenate([first, second])
