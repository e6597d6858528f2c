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

__all__ = ["DualCells", "dual_cells", "dual_keys", "empty_dual_result", "split_quads", "shorter_diagonal"]

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
    vertex_cell : (C,) int64
        Active-cell index of each vertex.
    vertex_piece : (C,) int64
        Label of each vertex's piece of surface in its cell (0..63; a cell's labels depend only
        on its case and its neighbours', so a chunk of a grid labels a cell as the whole grid does).
    quad_edge : (Q,) int64
        Start node id (flat, VTK order) of each quad's crossing edge.
    quad_axis : (Q,) int64
        Axis (0, 1, 2) of each quad's crossing edge (the quads come by axis, then by edge).
    """

    scan: GridScan
    offsets: np.ndarray
    cell: np.ndarray
    crossing: np.ndarray
    quads: np.ndarray
    vertex_cell: np.ndarray
    vertex_piece: np.ndarray
    quad_edge: np.ndarray
    quad_axis: np.ndarray

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
    piece = _split_tunnels(scan, cell, local, _pieces()[scan.cases[cell], local])
    key = cell * _MAX_PIECES + piece
    keys, vertex = np.unique(key, return_inverse=True)
    vertex = vertex.ravel()
    order = np.argsort(vertex, kind="stable")
    around = np.full((offsets[-1], 4), -1, dtype=np.int64)
    around[crossing, local % 4] = vertex
    flat = values.reshape(-1)
    threshold = inside_threshold(values.dtype, level)
    quads, quad_edge, quad_axis = [], [], []
    for axis, edges in enumerate(scan.edges):
        quad = around[offsets[axis] : offsets[axis + 1]][:, _QUAD_SLOTS[axis]]
        valid = (quad >= 0).all(axis=1)  # edges on the grid's faces have fewer than four cells
        quad = quad[valid]
        backwards = flat[edges[valid]] >= threshold  # the start node is outside: the edge points in
        quad[backwards] = quad[backwards][:, ::-1]
        quads.append(quad)
        quad_edge.append(edges[valid])
        quad_axis.append(np.full(quad.shape[0], axis, dtype=np.int64))
    return DualCells(
        scan,
        offsets,
        vertex[order],
        crossing[order],
        np.concatenate(quads),
        keys // _MAX_PIECES,
        keys % _MAX_PIECES,
        np.concatenate(quad_edge),
        np.concatenate(quad_axis),
    )


#: labels per cell: a case's pieces 0..3, then ``8 * (piece + 1) + arc`` for the arcs of cut pieces
_MAX_PIECES = 64


def _face_edges() -> np.ndarray:
    """(6, 12) True where local edge ``e`` lies on face ``2 * axis + side`` of the cube."""
    table = CUBE_TABLE
    faces = np.zeros((6, 12), dtype=bool)
    for axis in range(3):
        for side in range(2):
            faces[2 * axis + side] = (table.edge_direction != axis) & (table.edge_start[:, axis] == side)
    return faces


def _segments(case: int) -> list[tuple[int, int]]:
    """The boundary segments (pairs of local edges on one cube face) of a case's polygons:
    triangle edges used by one triangle only."""
    table = CUBE_TABLE
    count: dict[tuple[int, int], int] = {}
    for tri in table.triangle_edges[case, : table.triangle_count[case]]:
        for a, b in ((tri[0], tri[1]), (tri[1], tri[2]), (tri[2], tri[0])):
            edge = (int(min(a, b)), int(max(a, b)))
            count[edge] = count.get(edge, 0) + 1
    return [edge for edge, n in count.items() if n == 1]


@functools.lru_cache(maxsize=1)
def _tunnel_faces() -> np.ndarray:
    """(256, 4) bit mask of the faces on which a case's piece holds all four crossings."""
    faces = _face_edges()
    pieces = _pieces()
    mask = np.zeros((256, 4), dtype=np.int64)
    for case in range(256):
        for p in range(4):
            held = pieces[case] == p
            for f in range(6):
                if np.count_nonzero(held & faces[f]) == 4:
                    mask[case, p] |= 1 << f
    return mask


@functools.lru_cache(maxsize=None)
def _split_piece(case: int, piece: int, faces_mask: int) -> tuple[int, ...]:
    """Arc (0, 1, ...) of each local edge of ``piece`` once its polygon is cut at its segments
    on the faces in ``faces_mask`` (-1 for edges not in the piece)."""
    faces = _face_edges()[[f for f in range(6) if faces_mask >> f & 1]]
    held = _pieces()[case] == piece
    parent = list(range(12))

    def find(e: int) -> int:
        while parent[e] != e:
            e = parent[e]
        return e

    for a, b in _segments(case):
        if held[a] and held[b] and not (faces[:, a] & faces[:, b]).any():
            parent[find(b)] = find(a)
    roots: dict[int, int] = {}
    return tuple(roots.setdefault(find(e), len(roots)) if held[e] else -1 for e in range(12))


def _split_tunnels(scan: GridScan, cell: np.ndarray, local: np.ndarray, piece: np.ndarray) -> np.ndarray:
    """Piece labels (0..``_MAX_PIECES``-1) once no two neighbouring cells both join the four
    crossings of their common face into one piece.

    On an ambiguous face (inside corners diagonal) a case may join both of the face's segments
    into one piece: a tunnel through the face. If the cell across the face does too, the two
    vertices share the four quads of the face's crossings: a non-manifold edge. Both pieces
    are cut at that face into their two arcs (the face resolved the other way, the tunnel
    closed); the arcs pair the face's crossings alike on both sides (the polygons are simple
    curves on the cube), so each new vertex shares two quads with its partner and has one
    closed fan. A cut arc can still hold the four crossings of another face, so cutting
    repeats until no such pair is left. Only cells whose case has a tunnel take part; they
    are few (edges that touch, saddles at the grid's resolution).
    """
    tunnels = _tunnel_faces()
    cases = scan.cases
    if not tunnels.any(axis=1)[cases].any():
        return piece
    rows = np.flatnonzero(tunnels[cases[cell], piece])
    if rows.size == 0:
        return piece
    nz, ny, nx = scan.shape
    # every row of the cells involved: arcs are formed from all of a piece's crossings
    involved = np.unique(cell[rows])
    rows = np.flatnonzero(np.isin(cell, involved))
    row_cell, row_local, row_piece = cell[rows], local[rows], piece[rows]
    row_case = cases[row_cell]
    cut = np.zeros(rows.size, dtype=np.int64)  # faces at which each row's piece is cut
    faces_of_edge = np.nonzero(_face_edges().T)[1].reshape(12, 2)
    steps = np.array([1, nx, nx * ny])
    original = np.unique(row_cell * 4 + row_piece, return_inverse=True)[1].ravel()
    label = row_piece
    for _ in range(12):
        # crossings held by each (cell, label) on each face
        key = (row_cell * _MAX_PIECES + label)[:, None] * 6 + faces_of_edge[row_local]
        keys, counts = np.unique(key.ravel(), return_counts=True)
        full = keys[counts == 4]
        full_face = full % 6
        full_cell = scan.cells[full // 6 // _MAX_PIECES]  # grid node ids, so neighbours are offsets
        plus = full_face % 2 == 1
        across = full_cell[plus] + steps[full_face[plus] // 2]
        minus_faces = full_face[plus] - 1
        has = np.isin(across * 6 + minus_faces, full_cell[~plus] * 6 + full_face[~plus])
        minus = full[~plus][np.isin(full_cell[~plus] * 6 + full_face[~plus], (across * 6 + minus_faces)[has])]
        to_cut = np.concatenate([full[plus][has], minus])
        if to_cut.size == 0:
            break
        row_key = (row_cell * _MAX_PIECES + label) * 6
        for face in range(6):
            cut[np.isin(row_key + face, to_cut)] |= 1 << face
        # every arc of a piece is labelled from the same cuts (the new faces cut one arc only)
        np.bitwise_or.at(piece_cut := np.zeros(original.max() + 1, dtype=np.int64), original, cut)
        cut = piece_cut[original]
        label = _arc_labels(row_case, row_piece, cut, row_local)
    else:  # pragma: no cover - each round cuts a new face of some piece, at most 3 per piece
        raise RuntimeError("dual cells: splitting tunnels did not settle")
    piece = piece.copy()
    piece[rows] = label
    return piece


def _arc_labels(case: np.ndarray, piece: np.ndarray, cut: np.ndarray, local: np.ndarray) -> np.ndarray:
    """Label of each row's arc: its piece unless cut, else ``8 * (piece + 1) + arc``."""
    label = piece.copy()
    split = np.flatnonzero(cut)
    combos, inverse = np.unique(np.stack([case[split], piece[split], cut[split]], axis=1), axis=0, return_inverse=True)
    arcs = np.array([_split_piece(int(c), int(p), int(m)) for c, p, m in combos], dtype=np.int64)
    label[split] = 8 * (piece[split] + 1) + arcs[inverse.ravel(), local[split]]
    return label


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


def dual_keys(dual: DualCells) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Where each vertex and triangle of a dual surface comes from, in the grid's own ids.

    Returns ``(vertex_cell, vertex_piece, triangle_edge, triangle_rank)``: each vertex's grid
    cell (flat id of its lowest node) and piece label; the start node of each triangle's
    crossing edge, and ``3 * half + axis`` (the triangles of :func:`split_quads` come all first
    halves, then all second halves, each half by edge axis, then by edge).
    """
    rank = np.concatenate([dual.quad_axis, dual.quad_axis + 3])
    return dual.vertex_grid_cell, dual.vertex_piece, np.concatenate([dual.quad_edge, dual.quad_edge]), rank


def empty_dual_result(keys: bool):
    """No vertices and no triangles (with empty keys when asked)."""
    empty = (np.empty((0, 3)), np.empty((0, 3), dtype=np.int64))
    if not keys:
        return empty
    none = np.empty(0, dtype=np.int64)
    return (*empty, (none, none, none, none))
