"""Case-table isosurface extraction with one shared vertex per crossing grid edge.

Marching cubes and marching tetrahedra differ only in their tables: which local edges of a cube
a case cuts and which triangles join them. This module runs either table on a grid scan
(:mod:`fepre.surface.grid_scan`), visiting only the active cells. A vertex is created once per
crossing edge, in the order of the scan's edge lists, so its id follows from the edge id (a
sorted search) and no merging pass is needed.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ..config import config
from ..sdf.core import thread_pool
from .grid_scan import GridScan, scan_grid

__all__ = ["CaseTable", "extract_with_table", "edge_points"]


@dataclass
class CaseTable:
    """Triangles per corner case in terms of local cube edges.

    Parameters
    ----------
    directions : (D, 3) int
        Edge direction vectors (components 0 or 1) of the global edge families.
    edge_start : (L, 3) int
        Start corner (di, dj, dk) of each local edge.
    edge_direction : (L,) int
        Index into ``directions`` of each local edge.
    triangles : sequence of 256 sequences of int
        Local edges, three per outward triangle, for each corner case.
    """

    directions: np.ndarray
    edge_start: np.ndarray
    edge_direction: np.ndarray
    triangles: tuple
    triangle_count: np.ndarray = field(init=False)
    triangle_edges: np.ndarray = field(init=False)
    cut_count: np.ndarray = field(init=False)
    cut_edges: np.ndarray = field(init=False)

    def __post_init__(self) -> None:
        self.directions = np.asarray(self.directions, dtype=np.int64)
        self.edge_start = np.asarray(self.edge_start, dtype=np.int64)
        self.edge_direction = np.asarray(self.edge_direction, dtype=np.int64)
        counts = np.array([len(t) // 3 for t in self.triangles])
        table = np.zeros((256, max(1, counts.max()), 3), dtype=np.int64)
        for case, flat in enumerate(self.triangles):
            if flat:
                table[case, : counts[case]] = np.reshape(flat, (-1, 3))
        self.triangle_count, self.triangle_edges = counts, table
        corner_bit = self.edge_start @ np.array([1, 2, 4])
        end = self.edge_start + self.directions[self.edge_direction]
        end_bit = end @ np.array([1, 2, 4])
        bits = (np.arange(256)[:, None] >> corner_bit[None, :]) & 1
        end_bits = (np.arange(256)[:, None] >> end_bit[None, :]) & 1
        cut = bits != end_bits
        self.cut_count = cut.sum(axis=1)
        order = np.argsort(~cut, axis=1, kind="stable")
        self.cut_edges = np.where(np.take_along_axis(cut, order, axis=1), order, 0)


def edge_points(
    ids: np.ndarray,
    direction: np.ndarray,
    values: np.ndarray,
    level: float,
    origin: np.ndarray,
    spacing: np.ndarray,
    first_node: np.ndarray | None = None,
) -> np.ndarray:
    """World coordinates of the level crossing on the edges starting at node ``ids``.

    ``first_node`` is the (i, j, k) index of ``values[0, 0, 0]`` in the grid that ``origin``
    belongs to (a chunk of a larger grid): coordinates are computed from whole-grid indices, so
    a chunk's crossings are bit for bit those of the whole grid.
    """
    fi, fj, fk = (0, 0, 0) if first_node is None else (int(v) for v in first_node)
    nz, ny, nx = values.shape
    flat = values.reshape(-1)
    di, dj, dk = (int(v) for v in direction)
    s0 = flat[ids].astype(np.float64)
    s1 = flat[ids + (di + dj * nx + dk * nx * ny)].astype(np.float64)
    t = (level - s0) / (s1 - s0)
    k, rest = np.divmod(ids, nx * ny)
    j, i = np.divmod(rest, nx)
    points = np.empty((ids.size, 3))
    points[:, 0] = origin[0] + spacing[0] * ((i + fi) + t * di)
    points[:, 1] = origin[1] + spacing[1] * ((j + fj) + t * dj)
    points[:, 2] = origin[2] + spacing[2] * ((k + fk) + t * dk)
    return points


def _cell_ranges(count: int, workers: int) -> list[tuple[int, int]]:
    """Contiguous ranges of active cells, one or more per thread (at least ~16k cells each)."""
    pieces = max(1, min(workers, count // 16384))
    bounds = np.linspace(0, count, pieces + 1).astype(np.int64)
    return [(int(a), int(b)) for a, b in zip(bounds[:-1], bounds[1:])]


def _map_ranges(function, ranges, workers: int) -> list:
    if workers == 1 or len(ranges) == 1:
        return [function(r) for r in ranges]
    return list(thread_pool(workers).map(function, ranges))


def _cut_edges_in(scan: GridScan, table: CaseTable, offsets: np.ndarray, lo: int, hi: int):
    """(cell, local edge, vertex) of every cut edge of the active cells ``lo:hi``."""
    _, ny, nx = scan.shape
    cases = scan.cases[lo:hi]
    cut_count = table.cut_count[cases]
    cell = np.repeat(np.arange(lo, hi), cut_count)
    first = np.repeat(np.cumsum(cut_count) - cut_count, cut_count)
    local = table.cut_edges[cases[cell - lo], np.arange(cell.size) - first]
    start_offset = table.edge_start @ np.array([1, nx, nx * ny])
    start = scan.cells[cell] + start_offset[local]
    family = table.edge_direction[local]
    vertex = np.empty(cell.size, dtype=np.int64)
    for d, edges in enumerate(scan.edges):
        chosen = np.flatnonzero(family == d)
        vertex[chosen] = offsets[d] + np.searchsorted(edges, start[chosen])
    return cell, local, vertex


def cell_edge_vertices(scan: GridScan, table: CaseTable, offsets: np.ndarray, workers: int = 1):
    """Vertex ids of every cut local edge of every active cell.

    Returns ``(cell, local_edge, vertex)`` triples as three arrays (one row per cut edge).
    """
    parts = _map_ranges(
        lambda r: _cut_edges_in(scan, table, offsets, *r), _cell_ranges(scan.cells.size, workers), workers
    )
    return tuple(np.concatenate([part[k] for part in parts]) for k in range(3))


def _triangles_in(scan: GridScan, table: CaseTable, offsets: np.ndarray, lo: int, hi: int) -> np.ndarray:
    """Outward triangles (vertex ids) of the active cells ``lo:hi``."""
    cell, local, vertex = _cut_edges_in(scan, table, offsets, lo, hi)
    lookup = np.zeros((hi - lo, table.edge_start.shape[0]), dtype=np.int64)
    lookup[cell - lo, local] = vertex
    cases = scan.cases[lo:hi]
    count = table.triangle_count[cases]
    tri_cell = np.repeat(np.arange(hi - lo), count)
    first = np.repeat(np.cumsum(count) - count, count)
    edges = table.triangle_edges[cases[tri_cell], np.arange(tri_cell.size) - first]
    return np.take_along_axis(lookup[tri_cell], edges, axis=1)


def extract_with_table(
    values: np.ndarray,
    level: float,
    origin: np.ndarray,
    spacing: np.ndarray,
    table: CaseTable,
    workers: int | None = None,
    *,
    first_node: np.ndarray | None = None,
    keys: bool = False,
):
    """Points (V, 3) and outward triangles (T, 3) of the ``level`` set of a (nz, ny, nx) grid.

    After the scan, ranges of active cells are triangulated on ``workers`` threads. With
    ``keys``, also ``(vertex_edge, vertex_family, triangle_cell)``: each vertex's crossing edge
    as its start node (flat id in ``values``) and the index of its direction in
    ``table.directions``, and the cell (flat id of its lowest node) of each triangle; the
    triangles come by cell, then in table order.
    """
    workers = config.resolve_workers(workers)
    scan = scan_grid(values, level, [tuple(d) for d in table.directions], workers)
    sizes = np.array([e.size for e in scan.edges])
    offsets = np.concatenate([[0], np.cumsum(sizes)])
    if sizes.sum() == 0:
        empty = (np.empty((0, 3)), np.empty((0, 3), dtype=np.int64))
        none = np.empty(0, dtype=np.int64)
        return (*empty, (none, none, none)) if keys else empty
    points = np.concatenate(
        [edge_points(e, d, values, level, origin, spacing, first_node) for e, d in zip(scan.edges, table.directions)]
    )
    parts = _map_ranges(
        lambda r: _triangles_in(scan, table, offsets, *r), _cell_ranges(scan.cells.size, workers), workers
    )
    if keys:
        family = np.repeat(np.arange(sizes.size), sizes)
        triangle_cell = np.repeat(scan.cells, table.triangle_count[scan.cases])
        return points, np.concatenate(parts), (np.concatenate(scan.edges), family, triangle_cell)
    return points, np.concatenate(parts)
