"""One chunk's piece of an isosurface, with whole-grid keys for its vertices and triangles.

A chunk extracts from the nodes it reads (its own and the halo) with every coordinate computed
from whole-grid node indices, so a vertex that two chunks both make has the same coordinates in
both, bit for bit. It keeps the triangles it owns:

- case-table methods: the triangles of its cells (cells named by their lowest node);
- dual methods: the triangles of the quads of its crossing edges (edges named by their start).

Each vertex gets a whole-grid key and each triangle an order key, chosen so that sorting by them
gives exactly the single-grid extraction's vertex and triangle order:

- case-table methods: vertex ``family * N + edge start``, triangle ``cell`` (stable);
- dual methods: vertex ``cell * 64 + piece``, triangle ``(3 * half + axis) * N + edge start``;
- flying edges: as marching cubes (VTK's triangles are marching cubes'; its float32 coordinates
  are reproduced), no order key (VTK numbers its output itself).

``N`` is the grid's node count. Identical keys are identical vertices, so stitching chunks is a
sort, not a search by position.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

__all__ = ["ChunkSurface", "extract_chunk"]

_PIECES = 64


@dataclass
class ChunkSurface:
    """A chunk's owned triangles and the vertices they use.

    Attributes
    ----------
    keys : (V,) int64
        Whole-grid key of each vertex (see the module).
    points : (V, 3) float64
    triangles : (T, 3) int64
        Outward triangles, indices into ``points``.
    order : (T,) int64 or None
        Whole-grid order key of each triangle (None for flying edges).
    on_level : bool
        Whether a node the chunk owns has a value exactly at the level.
    """

    keys: np.ndarray
    points: np.ndarray
    triangles: np.ndarray
    order: np.ndarray | None
    on_level: bool

    @classmethod
    def empty(cls, on_level: bool = False) -> "ChunkSurface":
        none = np.empty(0, dtype=np.int64)
        return cls(none, np.empty((0, 3)), np.empty((0, 3), dtype=np.int64), none, on_level)


def _global_ids(local: np.ndarray, shape: tuple[int, int, int], first: np.ndarray, counts: np.ndarray) -> np.ndarray:
    """Flat whole-grid node ids of flat ids ``local`` in an array of ``shape`` (z, y, x) whose
    node 0 is whole-grid node ``first`` (x, y, z)."""
    _, ny, nx = shape
    k, rest = np.divmod(local, nx * ny)
    j, i = np.divmod(rest, nx)
    return (k + first[2]) * (counts[0] * counts[1]) + (j + first[1]) * counts[0] + (i + first[0])


def _node_index(ids: np.ndarray, counts: np.ndarray) -> np.ndarray:
    k, rest = np.divmod(ids, counts[0] * counts[1])
    j, i = np.divmod(rest, counts[0])
    return np.stack([i, j, k], axis=1)


def _used(keys: np.ndarray, points: np.ndarray, triangles: np.ndarray, order: np.ndarray | None, on_level: bool):
    """Keep only the vertices the kept triangles use."""
    from ..surface.weld import drop_unused

    used, triangles = drop_unused(len(keys), triangles)
    return ChunkSurface(keys[used], points[used], triangles, order, on_level)


def extract_chunk(
    values: np.ndarray,
    read_lo: np.ndarray,
    lo: np.ndarray,
    hi: np.ndarray,
    *,
    method: str,
    level: float,
    origin: np.ndarray,
    spacing: np.ndarray,
    counts: np.ndarray,
    model: Any = None,
    named: bool = True,
) -> ChunkSurface:
    """The owned part of the ``level`` set in one chunk.

    Parameters
    ----------
    values : (z, y, x) array
        The samples of the nodes the chunk reads, starting at whole-grid node ``read_lo``.
    lo, hi : (3,) int
        The nodes the chunk owns, ``[lo, hi)`` along x, y, z.
    method, level
        As for :func:`fepre.isosurface`.
    origin, spacing, counts : (3,)
        The whole grid's geometry.
    model : fepre.sdf.SDF, optional
        For dual contouring: the model the samples came from.
    named : bool
        Flying edges only: name the vertices (False when only the triangles' corners are
        wanted, as in a streamed file; the keys are then empty).
    """
    from ..surface.grid_scan import inside_threshold

    counts = np.asarray(counts, dtype=np.int64)
    total = int(np.prod(counts))
    owned = values[
        lo[2] - read_lo[2] : hi[2] - read_lo[2],
        lo[1] - read_lo[1] : hi[1] - read_lo[1],
        lo[0] - read_lo[0] : hi[0] - read_lo[0],
    ]
    on_level = bool((owned == level).any())
    threshold = inside_threshold(values.dtype, level)
    inside = values < threshold
    if not inside.any() or inside.all():
        return ChunkSurface.empty(on_level)
    if method in ("marching_cubes", "marching_tetrahedra", "flying_edges"):
        # the owned nodes and the next node plane: all the cells named by owned nodes
        stop = np.minimum(hi + 1, counts) - read_lo
        start = lo - read_lo
        cells = values[start[2] : stop[2], start[1] : stop[1], start[0] : stop[0]]
        if method == "flying_edges":
            return _flying_edges_chunk(cells, lo, level, origin, spacing, counts, on_level, named)
        from ..surface.marching_cubes import marching_cubes
        from ..surface.marching_tetrahedra import marching_tetrahedra

        extractor = marching_cubes if method == "marching_cubes" else marching_tetrahedra
        points, triangles, (edge, family, cell) = extractor(
            cells, level, origin, spacing, 1, first_node=lo, keys=True
        )
        keys = family * total + _global_ids(edge, cells.shape, lo, counts)
        return ChunkSurface(keys, points, triangles, _global_ids(cell, cells.shape, lo, counts), on_level)
    from ..surface.dual_contouring import dual_contouring
    from ..surface.surface_nets import surface_nets

    if method == "surface_nets":
        points, triangles, dual = surface_nets(values, level, origin, spacing, 1, first_node=read_lo, keys=True)
    else:
        points, triangles, dual = dual_contouring(
            values, level, origin, spacing, 1, model=model, first_node=read_lo, keys=True
        )
    vertex_cell, piece, edge, rank = dual
    if triangles.shape[0] == 0:
        return ChunkSurface.empty(on_level)
    start = _global_ids(edge, values.shape, read_lo, counts)
    node = _node_index(start, counts)
    mine = np.all((node >= lo) & (node < hi), axis=1)
    keys = _global_ids(vertex_cell, values.shape, read_lo, counts) * _PIECES + piece
    order = (rank[mine] * total + start[mine]).astype(np.int64)
    return _used(keys, points, triangles[mine], order, on_level)


def _flying_edges_chunk(
    cells: np.ndarray,
    lo: np.ndarray,
    level: float,
    origin: np.ndarray,
    spacing: np.ndarray,
    counts: np.ndarray,
    on_level: bool,
    named: bool,
) -> ChunkSurface:
    """VTK's flying edges on one chunk; the vertices on its faces named by their crossing edges.

    VTK computes a crossing in node indices (from the extent's first node) rounded to float32,
    scales it by the spacing and rounds to float32 again; the chunk is given the extent of its
    place in the whole grid, so its coordinates are the whole grid's. Only vertices on a face
    shared with another chunk need a whole-grid name: each crossing edge of the two node planes
    at such a face (from a grid scan of them) gets the coordinates VTK gives it, and each face
    vertex takes the key of the edge with its coordinates (crossings that round to one float32
    point, at a node exactly on the level, take the smallest of their keys: one vertex, as the
    single-grid weld makes them). The other vertices are the chunk's own: negative keys made
    from the chunk's first node and their index.
    """
    import pyvista as pv

    from ..surface.flying_edges import flying_edges

    nz, ny, nx = cells.shape
    grid = pv.ImageData(dimensions=(nx, ny, nz), spacing=tuple(spacing))
    grid.SetExtent(int(lo[0]), int(lo[0]) + nx - 1, int(lo[1]), int(lo[1]) + ny - 1, int(lo[2]), int(lo[2]) + nz - 1)
    grid.point_data["sdf"] = cells.reshape(-1)
    raw, triangles = flying_edges(grid, "sdf", level, 1)  # about the origin: VTK's float32 values
    if raw.shape[0] == 0:
        return ChunkSurface.empty(on_level)
    if not named:
        return ChunkSurface(np.empty(0, dtype=np.int64), raw + origin, triangles, None, on_level)
    written = raw.astype(np.float32)
    size = np.array([nx, ny, nz])
    seam = np.zeros(raw.shape[0], dtype=bool)
    planes = []  # (axis, local node plane) of every face shared with another chunk
    for axis in range(3):
        if lo[axis] > 0:
            planes.append((axis, 0))
        if lo[axis] + size[axis] - 1 < counts[axis] - 1:
            planes.append((axis, size[axis] - 1))
    for axis, plane in planes:
        seam |= written[:, axis] == np.float32(spacing[axis] * np.float32(lo[axis] + plane))
    keys = -(_global_ids(np.zeros(1, dtype=np.int64), cells.shape, lo, counts)[0] << np.int64(28)) - 1 - np.arange(raw.shape[0])
    if seam.any():
        edge_keys, expected = _face_crossings(cells, lo, level, spacing, counts, planes)
        keys[seam] = _keys_of_points(edge_keys, expected, written[seam])
    return ChunkSurface(keys, raw + origin, triangles, None, on_level)


def _face_crossings(cells, lo, level, spacing, counts, planes) -> tuple[np.ndarray, np.ndarray]:
    """Keys and VTK coordinates (float32) of the crossing edges in the two node planes at each
    shared face (in-plane edges, and edges across whose crossing may round onto the face)."""
    from ..surface.grid_scan import AXIS_DIRECTIONS, scan_grid

    total = int(np.prod(counts))
    all_keys, all_points = [], []
    for axis, plane in planes:
        first = max(0, plane - 1)
        block = np.take(cells, np.arange(first, first + 2), axis=2 - axis)
        start = lo.copy()
        start[axis] += first
        scan = scan_grid(np.ascontiguousarray(block), level, AXIS_DIRECTIONS, 1)
        edge = np.concatenate(scan.edges)
        family = np.repeat(np.arange(3), [e.size for e in scan.edges])
        bz, by, bx = block.shape
        k, rest = np.divmod(edge, bx * by)
        j, i = np.divmod(rest, bx)
        index = np.stack([i + start[0], j + start[1], k + start[2]], axis=1).astype(np.float64)
        flat = block.reshape(-1)
        stride = np.array([1, bx, bx * by])[family]
        value = flat[edge].astype(np.float64)
        # VTK subtracts the two samples in their own type (float32 rounds when they differ in
        # magnitude, as next to an image's padding), the level in double
        step = (flat[edge + stride] - flat[edge]).astype(np.float64)
        index[np.arange(index.shape[0]), family] += (level - value) / step
        all_points.append((spacing * index.astype(np.float32).astype(np.float64)).astype(np.float32))
        all_keys.append(family * total + _global_ids(edge, block.shape, start, counts))
    return np.concatenate(all_keys), np.concatenate(all_points)


def _keys_of_points(keys: np.ndarray, points: np.ndarray, wanted: np.ndarray) -> np.ndarray:
    """For each float32 point of ``wanted``, the smallest key among ``keys`` whose ``points`` are
    that point (bit for bit)."""
    known, asked = points.view(np.uint32), wanted.view(np.uint32)
    hashed = row_hash(known)
    order = np.lexsort((keys, hashed))
    ordered = hashed[order]
    fresh = np.r_[True, ordered[1:] != ordered[:-1]]
    group = np.cumsum(fresh) - 1
    table, table_keys, table_rows = ordered[fresh], keys[order][fresh], known[order][fresh]
    where = np.minimum(np.searchsorted(table, row_hash(asked)), table.size - 1)
    if np.array_equal(table_rows[group], known[order]) and np.array_equal(table_rows[where], asked):
        return table_keys[where]
    # a 64-bit hash collision (or a vertex with no edge): match the rows themselves
    order = np.lexsort((keys, *known.T[::-1]))  # pragma: no cover
    first = np.r_[True, np.any(known[order][1:] != known[order][:-1], axis=1)]  # pragma: no cover
    where = _row_search(known[order][first], asked)  # pragma: no cover
    if np.any(where < 0):  # pragma: no cover
        raise RuntimeError("flying edges: a vertex on a chunk face matches no crossing edge of the face")
    return keys[order][first][where]  # pragma: no cover


def row_hash(rows: np.ndarray) -> np.ndarray:
    """A 64-bit hash of each row of an (n, 3) uint32 array (callers check for collisions)."""
    wide = rows.astype(np.uint64)
    with np.errstate(over="ignore"):
        hashed = (wide[:, 0] * np.uint64(0x9E3779B97F4A7C15)) ^ (wide[:, 1] * np.uint64(0xC2B2AE3D27D4EB4F))
        hashed ^= wide[:, 2] * np.uint64(0x165667B19E3779F9) + (hashed >> np.uint64(29))
    return hashed


def _row_search(table: np.ndarray, rows: np.ndarray) -> np.ndarray:
    """Index in ``table`` (sorted lexicographically by x, then y, then z columns) of each row of
    ``rows``, or -1."""
    combined = np.concatenate([table, rows])
    order = np.lexsort(combined.T[::-1])
    ordered = combined[order]
    group = np.cumsum(np.r_[True, np.any(ordered[1:] != ordered[:-1], axis=1)]) - 1
    owner = np.full(group[-1] + 1, -1, dtype=np.int64)
    is_table = order < len(table)
    owner[group[is_table]] = order[is_table]
    result = np.empty(len(rows), dtype=np.int64)
    result[order[~is_table] - len(table)] = owner[group[~is_table]]
    return result
