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
    used = np.flatnonzero(np.bincount(triangles.ravel(), minlength=len(keys)))
    index = np.full(len(keys), -1, dtype=np.int64)
    index[used] = np.arange(used.size)
    return ChunkSurface(keys[used], points[used], index[triangles], order, on_level)


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
            return _flying_edges_chunk(cells, lo, level, origin, spacing, counts, on_level)
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
) -> ChunkSurface:
    """Flying edges' surface on one chunk: its triangles are marching cubes' (the same case table
    and tie rule, one vertex per crossing edge) and its coordinates are computed as VTK computes
    them: the crossing in node indices rounded to float32, scaled by the spacing and rounded to
    float32 again, then placed at the grid's origin in float64 (as :func:`flying_edges` does).
    The tests check the result against VTK's own output on the whole grid."""
    from ..surface.marching_cubes import marching_cubes

    _, triangles, (edge, family, cell) = marching_cubes(cells, level, origin, spacing, 1, first_node=lo, keys=True)
    nz, ny, nx = cells.shape
    k, rest = np.divmod(edge, nx * ny)
    j, i = np.divmod(rest, nx)
    index = np.stack([i + lo[0], j + lo[1], k + lo[2]], axis=1).astype(np.float64)
    flat = cells.reshape(-1)
    stride = np.array([1, nx, nx * ny])[family]
    start = flat[edge].astype(np.float64)
    t = (level - start) / (flat[edge + stride].astype(np.float64) - start)
    index[np.arange(index.shape[0]), family] += t
    scaled = (spacing * index.astype(np.float32).astype(np.float64)).astype(np.float32)
    points = scaled.astype(np.float64) + origin
    keys = family * int(np.prod(counts)) + _global_ids(edge, cells.shape, lo, counts)
    return ChunkSurface(keys, points, triangles, None, on_level)
