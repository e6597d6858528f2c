"""The interfaces of a label image as one triangle surface shared by all its regions.

Each label's indicator is smoothed by a Gaussian (``sigma`` voxels); a node's smoothed label is
the label of largest smoothed indicator. Every grid edge whose two nodes have different smoothed
labels ``a`` and ``b`` is crossed where ``f_a - f_b`` changes sign (linear along the edge), and
each grid cell with crossed edges gets one vertex, the mean of its crossings (surface nets, with
the crossings of the smooth indicators instead of the edges' midpoints). A crossed edge makes a
quad of the four cells around it, two triangles facing from ``a`` to ``b``. Every region's surface
is the triangles with its label on one side, so two regions share their interface's triangles
exactly, and the part's surface is the triangles with the background on one side.
"""

from __future__ import annotations

import numpy as np

from .sharp import sharp_planes

__all__ = ["LabelSurface", "label_surface", "label_rank", "swap_fields", "diagonal_faces", "CellPieces",
           "cell_pieces", "assemble", "clear_ring", "smoothed_labels", "no_diagonal_faces"]


class LabelSurface:
    """Vertices (V, 3), triangles (F, 3) facing from ``inner`` to ``outer`` (F,) label indices;
    ``plane`` (F,): the voxel-aligned plane with a sharp edge that each triangle lies on, -1 for
    none (:mod:`.sharp`)."""

    def __init__(self, vertices: np.ndarray, faces: np.ndarray, inner: np.ndarray, outer: np.ndarray,
                 plane: np.ndarray | None = None) -> None:
        self.vertices, self.faces, self.inner, self.outer = vertices, faces, inner, outer
        self.plane = np.full(len(faces), -1, dtype=np.int64) if plane is None else plane

    def region(self, index: int) -> tuple[np.ndarray, np.ndarray]:
        """Triangles of region ``index`` facing out of it, and the label on their other side."""
        faces, other, _ = self.region_planes(index)
        return faces, other

    def region_planes(self, index: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """As :meth:`region`, with each triangle's plane (-1: none)."""
        out, into = self.inner == index, self.outer == index
        faces = np.concatenate([self.faces[out], self.faces[into][:, ::-1]])
        return faces, np.concatenate([self.outer[out], self.inner[into]]), np.concatenate([self.plane[out], self.plane[into]])

    def part(self, background: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Triangles between the background and any other label, facing out of the part, the
        label inside each, and each triangle's plane."""
        out, into = self.outer == background, self.inner == background
        faces = np.concatenate([self.faces[out], self.faces[into][:, ::-1]])
        return faces, np.concatenate([self.inner[out], self.outer[into]]), np.concatenate([self.plane[out], self.plane[into]])


def smoothed_labels(indices: np.ndarray, count: int, sigma: np.ndarray):
    """Smoothed indicators (count, ...) as float32 and the smoothed labels."""
    from scipy import ndimage

    fields = np.empty((count,) + indices.shape, dtype=np.float32)
    for k in range(count):
        indicator = (indices == k).astype(np.float32)
        fields[k] = ndimage.gaussian_filter(indicator, sigma=sigma, mode="nearest") if sigma.max() > 0 else indicator
    return fields, np.argmax(fields, axis=0).astype(np.int16)


#: most rounds of :func:`no_diagonal_faces` (a node's label only grows, so they end; a brain MRI
#: at 2 mm needed 5)
DIAGONAL_ROUNDS = 50


def no_diagonal_faces(labels: np.ndarray) -> np.ndarray:
    """The labels with no grid face whose two diagonals hold one label on one diagonal only.

    A label on two opposite nodes of a face and not on the other two (voxels that touch along an
    edge only) makes the face's four crossed edges give four triangles on one surface edge, a
    non-manifold edge that no region's surface can keep (its repair took 40 s on a brain MRI at
    2 mm, and the sign near it is ambiguous). In each such face, of the two nodes along the
    side from its first corner, the one with the smaller label takes the larger, round after
    round until no face is left (the image becomes well-composed for every label).
    """
    labels = labels.copy()
    for _ in range(DIAGONAL_ROUNDS):
        changed = False
        for axis in range(3):
            u, v = [k for k in range(3) if k != axis]

            def cut(du: int, dv: int, u=u, v=v) -> tuple:
                """The face corners (du, dv) of every face normal to ``axis`` (a view)."""
                shift = {u: du, v: dv}
                return tuple(slice(shift.get(k, 0), labels.shape[k] - 1 + shift.get(k, 0)) if k != axis else slice(None)
                             for k in range(3))

            a, b, c, d = (labels[cut(du, dv)] for du, dv in ((0, 0), (1, 0), (1, 1), (0, 1)))
            first = (a == c) & (b != a) & (d != a)  # a's label on the diagonal a-c only
            second = (b == d) & (a != b) & (c != b) & ~first
            if not (first.any() or second.any()):
                continue
            changed = True
            # one node of each such face takes the larger of the two labels across a side (a
            # node's label only ever grows, so the rounds end: fixing one face this way cannot
            # undo another's)
            raise_a = (first | second) & (b > a)
            raise_b = (first | second) & (a > b)
            new_a, new_b = np.where(raise_a, b, a), np.where(raise_b, a, b)
            np.maximum(labels[cut(0, 0)], new_a, out=labels[cut(0, 0)])
            np.maximum(labels[cut(1, 0)], new_b, out=labels[cut(1, 0)])
        if not changed:
            break
    return labels


def _crossings(fields, labels, axis: int):
    """Crossed edges along ``axis``: their first node (M, 3), labels a (first node) and b, and
    the crossing's fraction along the edge."""
    count = labels.shape[axis] - 1
    first = np.take(labels, np.arange(count), axis=axis)
    second = np.take(labels, np.arange(1, count + 1), axis=axis)
    nodes = np.argwhere(first != second)
    a = first[tuple(nodes.T)].astype(np.int64)
    b = second[tuple(nodes.T)].astype(np.int64)
    ahead = nodes.copy()
    ahead[:, axis] += 1
    here = fields[(a,) + tuple(nodes.T)] - fields[(b,) + tuple(nodes.T)]
    there = fields[(a,) + tuple(ahead.T)] - fields[(b,) + tuple(ahead.T)]
    denominator = here - there
    fraction = np.where(denominator > 0, here / np.where(denominator > 0, denominator, 1), 0.5)
    return nodes, a, b, np.clip(fraction, 0.0, 1.0)


#: the cells around an edge along each axis, as offsets (of the two other axes) in the order
#: that makes the quad face along +axis
_AROUND = {0: ((1, 2), ((-1, -1), (0, -1), (0, 0), (-1, 0))),
           1: ((2, 0), ((-1, -1), (0, -1), (0, 0), (-1, 0))),
           2: ((0, 1), ((-1, -1), (0, -1), (0, 0), (-1, 0)))}


def label_rank(counts: np.ndarray) -> np.ndarray:
    """(count,) int16: each label index's rank by its smoothed nodes' count (the larger region
    takes a diagonal face's node: the smallest relative change of volume)."""
    return np.argsort(np.argsort(counts, kind="stable"), kind="stable").astype(np.int16)


def swap_fields(fields: np.ndarray, changed: np.ndarray, before: np.ndarray, after: np.ndarray) -> None:
    """Swap the smoothed values of labels ``before`` and ``after`` at the flat nodes ``changed``
    (in place): a node that changed label keeps its new label the largest there, so every
    crossing between labels still lies where their difference changes sign along the edge (with
    the values as they were, the crossings next to it fell on the edges' ends and folded
    triangles over: a brain's grey matter then held points of its ventricles)."""
    if len(changed):
        flat = fields.reshape(fields.shape[0], -1)
        flat[before, changed], flat[after, changed] = flat[after, changed], flat[before, changed].copy()


def diagonal_faces(labels: np.ndarray) -> list[np.ndarray]:
    """Per axis, the first corners (M, 3) of the faces normal to it that hold a label on one
    diagonal only (what :func:`no_diagonal_faces` joins up; the test is the same for labels
    and their ranks)."""
    found = []
    for axis in range(3):
        u, v = [k for k in range(3) if k != axis]
        shape = np.array(labels.shape)

        def cut(du: int, dv: int, u=u, v=v) -> tuple:
            shift = {u: du, v: dv}
            return tuple(slice(shift.get(k, 0), shape[k] - 1 + shift.get(k, 0)) if k != axis else slice(None)
                         for k in range(3))

        a, b, c, d = (labels[cut(du, dv)] for du, dv in ((0, 0), (1, 0), (1, 1), (0, 1)))
        first = (a == c) & (b != a) & (d != a)
        second = (b == d) & (a != b) & (c != b)
        found.append(np.argwhere(first | second))
    return found


class CellPieces:
    """The surface-nets data of the cells and edges a block of nodes owns (what
    :func:`assemble` takes; the chunked path concatenates the blocks' pieces).

    ``used`` (U,) flat cell indices (sorted), ``axes`` (U,) bits of their crossed edges' axes,
    ``sums`` (U, 3) and ``counts`` (U,) of their crossings (grid coordinates); per axis,
    ``edges[axis] = (node, quad, a, b)``: each crossed edge's first node (flat, sorted), its four
    cells (flat, in the order that faces from ``a`` to ``b``) and the labels at its ends."""

    def __init__(self, used, axes, sums, counts, edges) -> None:
        self.used, self.axes, self.sums, self.counts, self.edges = used, axes, sums, counts, edges

    @classmethod
    def empty(cls) -> "CellPieces":
        none = np.zeros(0, dtype=np.int64)
        return cls(none, np.zeros(0, np.uint8), np.zeros((0, 3)), np.zeros(0),
                   [(none, np.zeros((0, 4), np.int64), none, none) for _ in range(3)])

    @classmethod
    def joined(cls, pieces: list) -> "CellPieces":
        """The pieces of disjoint blocks as one, cells and edges in flat order."""
        if not pieces:
            return cls.empty()
        used = np.concatenate([p.used for p in pieces])
        order = np.argsort(used, kind="stable")
        edges = []
        for axis in range(3):
            node = np.concatenate([p.edges[axis][0] for p in pieces])
            by = np.argsort(node, kind="stable")
            edges.append(tuple(np.concatenate([p.edges[axis][k] for p in pieces])[by] for k in range(4)))
        return cls(used[order], np.concatenate([p.axes for p in pieces])[order],
                   np.concatenate([p.sums for p in pieces])[order], np.concatenate([p.counts for p in pieces])[order],
                   edges)


def cell_pieces(fields: np.ndarray, labels: np.ndarray, offset, owned_lo, owned_hi, nodes) -> CellPieces:
    """The crossings of a block of nodes (its first node at ``offset`` of a grid of ``nodes``
    per axis), for the cells and edges whose first node lies in ``[owned_lo, owned_hi)``; the
    block must hold the next node plane beyond them. Each cell's crossings are added in the
    same order (axis, then corner) whatever the block, so its vertex has the same bits."""
    offset, owned_lo, owned_hi = (np.asarray(x, dtype=np.int64) for x in (offset, owned_lo, owned_hi))
    cells = tuple(int(n) - 1 for n in nodes)
    cell_hi = np.minimum(owned_hi, np.array(cells))
    edges, touched = [], []  # touched: per (axis, corner) the owned cells (flat) and the crossings
    for axis in range(3):
        block, a, b, fraction = _crossings(fields, labels, axis)
        node = block + offset
        own = np.all((node >= owned_lo) & (node < owned_hi), axis=1)
        point = node.astype(np.float64)
        point[:, axis] += fraction
        (u, v), offsets = _AROUND[axis]
        quad = np.empty((len(node), 4), dtype=np.int64)
        for corner, (du, dv) in enumerate(offsets):
            cell = node.copy()
            cell[:, u] += du
            cell[:, v] += dv
            quad[:, corner] = np.ravel_multi_index(tuple(cell.T), cells, mode="clip")
            mine = np.all((cell >= owned_lo) & (cell < cell_hi), axis=1)
            touched.append((axis, quad[mine, corner], point[mine]))
        edges.append((np.ravel_multi_index(tuple(node[own].T), tuple(int(n) for n in nodes)), quad[own], a[own], b[own]))
    # the sums over the cells crossed only (a dense array of the block's cells took 33 bytes a
    # cell: 550 MB at 256^3), added in the same order
    used = np.unique(np.concatenate([t[1] for t in touched])) if touched else np.zeros(0, np.int64)
    sums, counts = np.zeros((len(used), 3)), np.zeros(len(used))
    axes = np.zeros(len(used), dtype=np.uint8)
    for axis, cell, point in touched:
        at = np.searchsorted(used, cell)
        np.add.at(sums, at, point)
        np.add.at(counts, at, 1.0)
        axes[at] |= np.uint8(1 << axis)
    return CellPieces(used.astype(np.int64), axes, sums, counts, edges)


def assemble(pieces: CellPieces, nodes, spacing: np.ndarray, origin: np.ndarray, iterations: int = 0,
             sharp: bool = True) -> LabelSurface:
    """The label surface of the cells' pieces (the whole grid's) on a grid of ``nodes`` per
    axis whose first node is at ``origin``: triangles of the quads, sharp planes, junctions
    held, the rest relaxed (see the module). It holds only what the surface holds."""
    cells = tuple(int(n) - 1 for n in nodes)
    used = pieces.used
    quads = np.concatenate([e[1] for e in pieces.edges])
    inner = np.concatenate([e[2] for e in pieces.edges])
    outer = np.concatenate([e[3] for e in pieces.edges])
    quads = np.searchsorted(used, quads)
    faces = np.concatenate([quads[:, [0, 1, 2]], quads[:, [0, 2, 3]]])
    inner, outer = np.tile(inner, 2), np.tile(outer, 2)
    points = pieces.sums / pieces.counts[:, None]
    fixed, plane = np.zeros(len(used), dtype=bool), np.full(len(faces), -1, dtype=np.int64)
    if sharp:
        points, fixed, member = sharp_planes(used, pieces.axes, points, cells)
        plane = _face_planes(faces, member)
    if iterations:
        cell = np.column_stack(np.unravel_index(used, cells)).astype(np.float64)
        junction = _junctions(len(used), faces, inner, outer)
        points = relaxed(points, faces, cell, junction | fixed, iterations)
    return LabelSurface(origin + spacing * points, faces, inner, outer, plane)


def clear_ring(labels: np.ndarray, offset, nodes, background: int) -> None:
    """Give the nodes of a block (first node at ``offset``) on the grid's outer layer (a grid of
    ``nodes`` per axis) the ``background`` label, in place: the pad stays background, so every
    crossed edge has four cells around it."""
    for axis in range(3):
        for end in (0, int(nodes[axis]) - 1):
            at = end - int(offset[axis])
            if 0 <= at < labels.shape[axis]:
                index = [slice(None)] * 3
                index[axis] = at
                labels[tuple(index)] = background


def label_surface(indices: np.ndarray, count: int, spacing: np.ndarray, origin: np.ndarray, sigma: float,
                  background: int, iterations: int = 0, sharp: bool = True) -> LabelSurface:
    """The shared interface surface of label indices ``0..count-1`` on a grid (see the module).

    The grid is padded by one node of ``background`` on every side (kept so after smoothing), so
    every region's surface is closed; regions at the border close within a voxel beyond it.
    ``sharp`` keeps the edges where large voxel-aligned planes meet (:mod:`.sharp`).
    """
    indices = np.pad(indices, 1, constant_values=background)
    fields, labels = smoothed_labels(indices, count, sigma * float(spacing.min()) / spacing)
    rank = label_rank(np.bincount(labels.ravel(), minlength=count))
    joined = np.argsort(rank).astype(np.int16)[no_diagonal_faces(rank[labels])]
    changed = np.flatnonzero((joined != labels).ravel())
    swap_fields(fields, changed, labels.ravel()[changed], joined.ravel()[changed])
    labels = joined
    nodes = labels.shape
    clear_ring(labels, (0, 0, 0), nodes, background)
    pieces = cell_pieces(fields, labels, (0, 0, 0), (0, 0, 0), nodes, nodes)
    return assemble(pieces, nodes, spacing, origin - spacing, iterations, sharp)


def _face_planes(faces: np.ndarray, member: np.ndarray) -> np.ndarray:
    """(F,) the plane all three vertices of each triangle lie on, -1 for none."""
    plane = np.full(len(faces), -1, dtype=np.int64)
    for k in range(3):
        ids = member[faces, k]
        common = (ids[:, 0] >= 0) & (ids[:, 0] == ids[:, 1]) & (ids[:, 0] == ids[:, 2]) & (plane < 0)
        plane[common] = ids[common, 0]
    return plane


def _junctions(count: int, faces: np.ndarray, inner: np.ndarray, outer: np.ndarray) -> np.ndarray:
    """(V,) bool: vertices of triangles of more than one pair of labels (where three labels
    meet, or two interfaces of one label touch)."""
    pair = inner * 65536 + outer
    pair = np.minimum(pair, outer * 65536 + inner)
    first = np.full(count, -1, dtype=np.int64)
    junction = np.zeros(count, dtype=bool)
    for k in range(3):
        vertex = faces[:, k]
        first[vertex] = pair  # any one pair of each vertex
    for k in range(3):
        junction[faces[:, k]] |= first[faces[:, k]] != pair
    return junction


#: Taubin's two steps (lambda > 0 smooths, mu < -lambda swells back: no shrinking)
TAUBIN = (0.5, -0.53)


def relaxed(points: np.ndarray, faces: np.ndarray, cell: np.ndarray, fixed: np.ndarray, iterations: int) -> np.ndarray:
    """Taubin's smoothing of the surface's vertices (grid coordinates), each kept in its cell;
    ``fixed`` vertices do not move."""
    edges = np.unique(np.sort(np.concatenate([faces[:, [0, 1]], faces[:, [1, 2]], faces[:, [2, 0]]]), axis=1), axis=0)
    ends = np.concatenate([edges[:, 0], edges[:, 1]])
    others = np.concatenate([edges[:, 1], edges[:, 0]])
    degree = np.bincount(ends, minlength=len(points)).astype(np.float64)
    moving = (~fixed) & (degree > 0)
    low, high = cell, cell + 1.0
    for _ in range(iterations):
        for factor in TAUBIN:
            mean = np.column_stack([np.bincount(ends, points[others, k], len(points)) for k in range(3)])
            step = mean / np.maximum(degree, 1)[:, None] - points
            points = np.where(moving[:, None], np.clip(points + factor * step, low, high), points)
    return points
