"""Make a triangle soup the closed, consistently oriented boundary of a solid where it can be.

Files from CAD, scanners and topology optimisation carry the same defects: vertices written once
per triangle, duplicated and degenerate triangles, triangles flipped against their neighbours,
small holes, and shells that overlap. The steps, each vectorised over the triangles:

1. merge vertices with equal coordinates, or closer than 1e-8 of the diagonal (CAD writers give
   one vertex coordinates that differ in the last bits), and drop triangles with a repeated
   vertex and duplicates (the same three vertices in any order);
2. orient every connected piece consistently across its manifold edges, keeping the
   orientation most of its triangles had, and turn pieces that are inside out (a solid whose
   material lies outside it) the right way; where bodies that touch share their contact faces,
   written once (a fragmented multi-volume export) or twice, the faces with material on both
   sides are dropped and the rest oriented again: the union's boundary (the sides of the faces
   are joined into the cells of space they bound, sorting the triangles around each edge of
   three or more by angle; each piece of faces joined through edges has its own outside cell).
   A face is dropped only if the surface left then encloses it (its winding number above
   ``CONTACT_WINDING`` just in front of it and just behind it), a second check where cells can
   leak: surfaces that cross themselves or lie over each other;
3. close holes: every boundary loop that is a simple cycle is closed, flat when its rim is planar
   (a missing CAD face), else with a smooth patch (:mod:`.hole_fill`);
4. drop triangles that do not separate inside from outside: where the generalised winding number
   is on the same side of 1/2 just in front of and just behind a triangle (the inner parts of
   overlapping shells, sheets hanging in or out of the solid), after splitting the triangles that
   cross a seam. A surface that is one closed, consistently oriented piece that does not cross
   itself skips this step.

The result records what was changed, for the model's summary and its ``exact`` flag.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np
from scipy import sparse
from scipy.sparse import csgraph

from .hole_fill import fill_holes
from .tables import edge_table, enclosed_volume, face_normals, manifold_pairs, used_vertices, weld_vertices, winding_numbers

__all__ = ["Repair", "repair"]

#: Holes (boundary loops) are closed only while their patches' total area is below this
#: fraction of the input's own area; more than that and the input is a sheet, not a solid with
#: holes (a box missing a face: 20%)
MAX_HOLE_FRACTION = 1 / 3


@dataclass(frozen=True)
class Repair:
    """A repaired triangle surface and what was done to it.

    Attributes
    ----------
    vertices, faces : ndarray
        The surface, (V, 3) float64 and (F, 3) int64.
    merged, degenerate, duplicates, flipped, holes, internal : int
        Vertices merged, triangles dropped for a repeated vertex, duplicate triangles dropped,
        triangles turned over, boundary loops closed and triangles dropped, or split at a seam, as
        not (wholly) separating inside from outside.
    hole_area : float
        Area of the triangles added to close holes.
    flat_holes : int
        Of the holes, those closed in the plane of their rim (planar rims) or straight across
        (rims across a cut: near a plane, the surface meeting it steeply).
    cut_holes : int
        Of the flat holes, those across a cut.
    hole_bulge : float
        Volume the faired patches of the other holes add beyond flat fans across their rims
        (signed: positive where they bulge out).
    open_edges : int
        Boundary edges left open (where the edges into and out of a vertex do not match).
    contacts : int
        Triangles dropped from patches between touching bodies (faces of a contact written once
        or twice; step 2).
    closed : bool
        Every edge is shared by exactly two triangles that traverse it in opposite directions.
    filled : ndarray
        (F,) bool: the triangles added to close holes.
    tree : TriangleTree or None
        The hierarchy of the returned triangles when the repair built one (to find a closed
        piece crossing itself); the model's distance queries reuse it. Not pickled.
    """

    vertices: np.ndarray = field(repr=False)
    faces: np.ndarray = field(repr=False)
    merged: int
    degenerate: int
    duplicates: int
    flipped: int
    holes: int
    hole_area: float
    internal: int
    open_edges: int
    closed: bool
    filled: np.ndarray = field(repr=False)
    flat_holes: int = 0
    hole_bulge: float = 0.0
    cut_holes: int = 0
    contacts: int = 0
    tree: Any = field(default=None, repr=False, compare=False)

    def __getstate__(self) -> dict:
        return {**self.__dict__, "tree": None}

    def __setstate__(self, state: dict) -> None:
        self.__dict__.update(state)

    @property
    def changed(self) -> bool:
        """True when anything beyond merging vertices was needed."""
        return bool(self.degenerate or self.duplicates or self.flipped or self.holes or self.internal or self.contacts)

    def summary(self) -> str:
        """What was repaired, in words (empty when the input was clean)."""
        parts = []
        for count, text in (
            (self.degenerate, "degenerate triangles dropped"),
            (self.duplicates, "duplicate triangles dropped"),
            (self.flipped, "triangles turned over"),
            (self.holes, f"holes closed (area {self.hole_area:.4g}, {self.flat_holes} of them flat"
                         + (f", {self.cut_holes} across a cut" if self.cut_holes else "") + ")"),
            (self.contacts, "triangles between touching bodies dropped"),
            (self.internal, "triangles inside or outside the solid dropped"),
            (self.open_edges, "boundary edges left open"),
        ):
            if count:
                parts.append(f"{count} {text}")
        return ", ".join(parts)


def _merge_vertices(vertices: np.ndarray, faces: np.ndarray, *, weld: bool = False) -> tuple[np.ndarray, np.ndarray, int]:
    """One vertex per distinct position, the faces renumbered, and how many vertices merged.
    ``weld=True`` (a file's vertices) also merges vertices closer than :func:`.tables.weld_vertices` does."""
    used = used_vertices(faces, len(vertices))
    points = vertices[used]
    if weld:
        points = weld_vertices(points)
    order = np.lexsort(points.T[::-1])
    ordered = points[order]
    new = np.ones(len(order), dtype=bool)
    new[1:] = np.any(ordered[1:] != ordered[:-1], axis=1)
    rank = np.cumsum(new) - 1
    remap = np.zeros(len(vertices), dtype=np.int64)
    remap[used[order]] = rank
    return ordered[new], remap[faces], int(len(used) - int(new.sum()))


def _collapsed(vertices: np.ndarray, faces: np.ndarray) -> bool:
    """Whether some triangle has two corners at the same position."""
    a, b, c = (vertices[faces[:, k]] for k in range(3))
    return bool(((a == b).all(axis=1) | (b == c).all(axis=1) | (a == c).all(axis=1)).any())


def _drop_degenerate_and_duplicates(faces: np.ndarray) -> tuple[np.ndarray, int, int]:
    repeated = (faces[:, 0] == faces[:, 1]) | (faces[:, 1] == faces[:, 2]) | (faces[:, 0] == faces[:, 2])
    faces = faces[~repeated]
    ordered = np.sort(faces, axis=1)
    order = np.lexsort(ordered.T[::-1])
    new = np.ones(len(order), dtype=bool)
    new[1:] = np.any(ordered[order[1:]] != ordered[order[:-1]], axis=1)
    first = np.sort(order[new])
    return faces[first], int(repeated.sum()), int(len(faces) - len(first))


def _drop_cancelling_pairs(faces: np.ndarray) -> tuple[np.ndarray, int]:
    """``faces`` without the pairs of triangles on the same three vertices and turned opposite
    ways, and how many triangles went. A contoured field's surface has such pairs where a pocket
    thinner than float32's rounding closed when its vertices merged: the two sheets bound no
    volume, and keeping one of them would leave its edges used three times and once."""
    if len(faces) < 2:
        return faces, 0
    start = np.argmin(faces, axis=1)
    turned = faces[np.arange(len(faces))[:, None], (start[:, None] + np.arange(3)) % 3]
    key = np.sort(faces, axis=1)
    order = np.lexsort(key.T[::-1])
    same = np.flatnonzero((key[order[1:]] == key[order[:-1]]).all(axis=1))
    if same.size == 0:
        return faces, 0
    lone = np.ones(len(same), dtype=bool)  # a vertex set used exactly twice
    lone[1:] &= same[1:] != same[:-1] + 1
    lone[:-1] &= same[:-1] + 1 != same[1:]
    first, second = order[same[lone]], order[same[lone] + 1]
    opposite = (turned[first, 1] == turned[second, 2]) & (turned[first, 2] == turned[second, 1])
    proper = (turned[first, 0] != turned[first, 1]) & (turned[first, 1] != turned[first, 2])  # degenerate ones go as such
    drop = np.zeros(len(faces), dtype=bool)
    drop[first[opposite & proper]] = drop[second[opposite & proper]] = True
    return faces[~drop], int(drop.sum())


def _material_sides(vertices: np.ndarray, faces: np.ndarray, edges: np.ndarray, face_edge: np.ndarray,
                    forward: np.ndarray) -> np.ndarray:
    """(F, 2) bool: whether the cell of space in front of (column 0) and behind (1) each face is
    material, from the cells of the faces' arrangement.

    Each face has two sides. Across an edge of two triangles the sides join as the orientation
    says; around an edge of three or more the triangles are sorted by angle and the sides that
    face each other across each wedge between neighbours join. The joined sides are the cells.
    In each piece of the arrangement (faces joined through shared edges), the cell that its face
    farthest along -x looks into is outside; a cell that every one of its faces looks into (their
    normals point into it) is a void; every other cell is material. With one outside cell for
    the whole surface, a second piece whose own outer cell its faces did not all look into (two
    bodies of a robot link standing on one ring of edges, their walls over each other) was taken
    for material, and the whole piece dropped.
    """
    count = len(faces)
    f, g, agree, counts = manifold_pairs(face_edge, forward, len(edges))
    normals, areas = face_normals(vertices, faces)
    rows = [2 * f, 2 * f + 1]  # side k of face f is node 2 f + k
    cols = [np.where(agree, 2 * g, 2 * g + 1), np.where(agree, 2 * g + 1, 2 * g)]
    # the triangles around each edge of three or more, grouped by edge
    branched = counts[face_edge.reshape(-1)] >= 3
    edge = face_edge.reshape(-1)[branched]
    order = np.argsort(edge, kind="stable")
    edge, fs = edge[order], np.repeat(np.arange(count), 3)[branched][order]
    many, sizes = np.unique(edge, return_counts=True)
    offsets = np.cumsum(sizes) - sizes
    group = np.repeat(np.arange(len(many)), sizes)
    ends = edges[edge]
    axis = vertices[ends[:, 1]] - vertices[ends[:, 0]]
    axis /= np.linalg.norm(axis, axis=1)[:, None]
    spoke = vertices[faces[fs].sum(axis=1) - ends.sum(axis=1)] - vertices[ends[:, 0]]  # to the third corner
    spoke -= np.einsum("ij,ij->i", spoke, axis)[:, None] * axis
    spoke /= np.maximum(np.linalg.norm(spoke, axis=1), 1e-300)[:, None]
    reference = spoke[np.repeat(offsets, sizes)]
    angle = np.arctan2(np.einsum("ij,ij->i", spoke, np.cross(axis, reference)), np.einsum("ij,ij->i", spoke, reference))
    order = np.lexsort((angle, group))
    fs, spoke, axis = fs[order], spoke[order], axis[order]
    ahead = np.einsum("ij,ij->i", normals[fs], np.cross(axis, spoke)) > 0  # the front faces the larger angles
    following = np.arange(len(fs)) + 1
    following[offsets + sizes - 1] = offsets  # around the edge
    rows.append(np.where(ahead, 2 * fs, 2 * fs + 1))
    cols.append(np.where(ahead, 2 * fs + 1, 2 * fs)[following])
    rows, cols = np.concatenate(rows), np.concatenate(cols)
    graph = sparse.coo_matrix((np.ones(len(rows)), (rows, cols)), shape=(2 * count, 2 * count))
    cells, cell = csgraph.connected_components(graph, directed=False)
    behind = np.bincount(cell, weights=np.column_stack([-areas, areas]).ravel(), minlength=cells)
    material = behind > -0.999 * np.bincount(cell, weights=np.repeat(areas, 2), minlength=cells)
    lowest = _lowest_faces(faces, face_edge, len(edges), vertices[faces].mean(axis=1)[:, 0], np.abs(normals[:, 0]))
    material[cell[2 * lowest + (normals[lowest, 0] >= 0)]] = False
    return material[cell].reshape(-1, 2)


def _lowest_faces(faces: np.ndarray, face_edge: np.ndarray, edge_count: int, x: np.ndarray,
                  facing: np.ndarray) -> np.ndarray:
    """Per piece of faces joined through shared edges: of its hundredth of faces lowest in ``x``
    (at least one), the one whose normal is most along x (``facing``, its |n_x|)."""
    count = len(faces)
    incidence = sparse.coo_matrix((np.ones(3 * count), (np.repeat(np.arange(count), 3), count + face_edge.reshape(-1))),
                                  shape=(count + edge_count, count + edge_count))
    pieces, label = csgraph.connected_components(incidence, directed=False)
    piece = label[:count]
    order = np.lexsort((x, piece))
    starts = np.searchsorted(piece[order], np.arange(pieces + 1))
    sizes = np.diff(starts)
    rank = np.arange(count) - np.repeat(starts[:-1], sizes)
    low = order[rank < np.repeat(np.maximum(1, sizes // 100), sizes)]
    best = low[np.lexsort((-facing[low], piece[low]))]
    return best[np.unique(piece[best], return_index=True)[1]]


#: the winding number a dropped contact face must have, on both sides, of the surface left
CONTACT_WINDING = 0.75


def _drop_contacts(vertices: np.ndarray, faces: np.ndarray) -> tuple[np.ndarray, int]:
    """Faces less those between two material cells (see the module's step 2, :func:`_material_sides`)
    that the surface left encloses, and their count; kept whole unless every edge is then in an
    even number of triangles."""
    edges, face_edge, forward = edge_table(faces)
    if not (np.bincount(face_edge.reshape(-1), minlength=len(edges)) >= 3).any():
        return faces, 0
    sides = _material_sides(vertices, faces, edges, face_edge, forward)
    dropped = sides.all(axis=1)
    if dropped.any():
        dropped[dropped] = _enclosed(vertices, faces[~dropped], faces[dropped])
    if not dropped.any() or not _even_edges(faces[~dropped]):
        return faces, 0
    return faces[~dropped], int(dropped.sum())


def _enclosed(vertices: np.ndarray, kept: np.ndarray, faces: np.ndarray) -> np.ndarray:
    """Whether the winding number of the ``kept`` faces exceeds :data:`CONTACT_WINDING` just in
    front of and just behind each of ``faces``."""
    normals, _ = face_normals(vertices, faces)
    corners = vertices[faces]
    front, behind = _sides(vertices, kept, corners.mean(axis=1), normals, _longest_side(corners), level=CONTACT_WINDING)
    return front & behind


def _orient(vertices: np.ndarray, faces: np.ndarray) -> tuple[np.ndarray, int]:
    """Faces turned so that neighbours across manifold edges agree, keeping each piece's
    majority orientation; then pieces that are inside out are turned over."""
    count = len(faces)
    edges, face_edge, forward = edge_table(faces)
    a, b, agree, _ = manifold_pairs(face_edge, forward, len(edges))
    # parity relative to a root per piece: a breadth-first tree from a virtual root joined to
    # one triangle of every piece, then parities accumulated up the tree by pointer jumping
    graph = sparse.coo_matrix((np.ones(len(a)), (a, b)), shape=(count, count)).tocsr()
    pieces, label = csgraph.connected_components(graph, directed=False)
    firsts = np.unique(label, return_index=True)[1]
    root = count
    rows = np.concatenate([a, np.full(len(firsts), root)])
    cols = np.concatenate([b, firsts])
    tree_graph = sparse.coo_matrix((np.ones(len(rows)), (rows, cols)), shape=(count + 1, count + 1)).tocsr()
    _, predecessor = csgraph.breadth_first_order(tree_graph, root, directed=False, return_predecessors=True)
    parent = predecessor[:count].astype(np.int64)
    # disagreement of each triangle with its parent
    key_pairs = np.concatenate([a * (count + 1) + b, b * (count + 1) + a])
    key_flip = np.concatenate([~agree, ~agree])
    order = np.argsort(key_pairs)
    key_pairs, key_flip = key_pairs[order], key_flip[order]
    parity = np.zeros(count + 1, dtype=bool)
    child = np.flatnonzero(parent != root)
    position = np.searchsorted(key_pairs, child * (count + 1) + parent[child])
    parity[child] = key_flip[position]
    jump = np.append(parent, root)
    jump[jump < 0] = root
    while np.any(jump[:count] != root):
        parity = parity ^ parity[jump]
        jump = jump[jump]
    flip = parity[:count]
    # keep the orientation most of each piece's triangles had
    turned = np.bincount(label, weights=flip, minlength=pieces)
    sizes = np.bincount(label, minlength=pieces)
    flip ^= (turned > sizes / 2.0)[label]
    faces = np.where(flip[:, None], faces[:, ::-1], faces)
    flipped = int(flip.sum())

    turn = _nesting_turns(vertices, faces, label, pieces)
    faces = np.where(turn[:, None], faces[:, ::-1], faces)
    flipped += int(turn.sum())
    return faces, flipped


#: Pieces whose nesting is worked out one by one (pieces x pieces winding-number queries);
#: beyond this, only pieces enclosing negative volume outside all material are turned over.
MAX_NESTED_PIECES = 64
#: Points of each piece (area-weighted triangle centroids) that vote on which pieces enclose it.
NESTING_SAMPLES = 15


def _nesting_turns(vertices, faces, label, pieces) -> np.ndarray:
    """Triangles to turn over so that every piece faces out of the material.

    Only unbranched pieces (each of their edges used by at most two triangles, or by exactly two
    of their own; holes are fine, they are closed later) are turned or count as enclosing: a piece enclosed by
    an even number of others bounds a solid (it encloses positive volume); by an odd number, a
    cavity (negative volume). Enclosure is decided by most of a piece's sample points, so shells
    that merely overlap (a union written as two shells) do not count as nested. Branched pieces
    (cut off by edges of three or more of their triangles) keep the orientation most of their
    triangles had. Two closed bodies that share an edge are each unbranched: an edge of four
    triangles, two of each (counted over all triangles, the second of two tetrahedra sharing an
    edge, written inside out, stayed so and was dropped as outside the solid: half the volume).
    """
    normals, areas = face_normals(vertices, faces)
    volume = enclosed_volume(vertices, faces, label, pieces)
    centroid = vertices[faces].mean(axis=1)
    edges, face_edge, _ = edge_table(faces)
    # an edge of two triangles, or of more with two of them this piece's: a body sharing an edge
    # with another (not a patch cut off where shells cross, which uses its edge there once)
    piece_edge = label[:, None].astype(np.int64) * np.int64(len(edges)) + face_edge
    _, inverse, own = np.unique(piece_edge.reshape(-1), return_inverse=True, return_counts=True)
    everyone = np.bincount(face_edge.reshape(-1), minlength=len(edges))[face_edge]
    unbranched = ((everyone <= 2) | (own[inverse.reshape(-1, 3)] == 2)).all(axis=1)
    closed = np.bincount(label, weights=~unbranched, minlength=pieces) == 0
    if pieces == 1:
        return np.full(len(faces), bool(volume[0] < 0 and closed[0]))
    if pieces > MAX_NESTED_PIECES:
        # a negative piece is a cavity when it lies inside material (just behind its largest
        # triangle), else a solid written inside out
        negative = np.flatnonzero((volume < 0) & closed)
        largest = np.zeros(pieces, dtype=np.int64)
        order = np.lexsort((areas, label))
        largest[label[order]] = order  # the last write per label is its largest triangle
        probe = largest[negative]
        step = 1e-3 * np.sqrt(np.maximum(areas[probe], 1e-300))
        behind = centroid[probe] - step[:, None] * normals[probe]
        inside_out = winding_numbers(vertices, faces, behind) < 0.5
        return np.isin(label, negative[inside_out])
    rng = np.random.default_rng(0)
    samples, owner = [], []
    for piece in range(pieces):  # one query per pair of pieces, not per triangle
        members = np.flatnonzero(label == piece)
        weights = areas[members] / max(float(areas[members].sum()), 1e-300)
        chosen = rng.choice(members, NESTING_SAMPLES, p=weights) if weights.sum() > 0 else members[:NESTING_SAMPLES]
        samples.append(centroid[chosen])
        owner.append(np.full(len(chosen), piece))
    samples, owner = np.concatenate(samples), np.concatenate(owner)
    depth = np.zeros(pieces, dtype=np.int64)
    for piece in np.flatnonzero(closed):
        others = owner != piece
        w = np.abs(winding_numbers(vertices, faces[label == piece], samples[others]))
        votes = np.bincount(owner[others], weights=(w > 0.5).astype(float), minlength=pieces)
        counts = np.bincount(owner[others], minlength=pieces)
        depth += (votes > counts / 2).astype(np.int64)
    want_outward = depth % 2 == 0
    return (closed & ((volume > 0) != want_outward))[label]


#: Triangles whose two sides' fast winding numbers differ by less than 1/2 are checked again with
#: the exact winding number, smallest first, up to this many (the fast approximation errs at
#: tiny slivers; the inner walls of overlapping shells are the rest).
EXACT_RECHECK = 1000


#: Triangles that cross another shell (their corners on different sides of it) are split this
#: many times (4 pieces each time) and the pieces inside dropped: the kept surface then pokes
#: into the solid by at most 1/16 of a triangle along the seams of overlapping shells.
SEAM_LEVELS = 4


#: Pieces a surface needs before its winding number is summed piece by piece (see
#: :func:`_piecewise_winding`); with fewer, one query over all triangles is as fast.
PIECEWISE_WINDING = 8


def _piecewise_winding(vertices: np.ndarray, faces: np.ndarray):
    """The winding number of ``faces`` as a function of points, summed over its pieces, each
    closed piece asked only at the points inside its box.

    A closed, consistently oriented piece has winding number exactly 0 outside its box, so
    a point is asked of the few bodies around it, not of all: on an assembly of a hundred
    bodies that is ten times faster. Pieces that are open or inconsistent are asked everywhere.
    """
    edges, face_edge, forward = edge_table(faces)
    owner = np.repeat(np.arange(len(faces)), 3)
    manifold = (np.bincount(face_edge.reshape(-1), minlength=len(edges)) == 2)[face_edge.reshape(-1)]
    # pieces joined across edges of two triangles: bodies that touch along an edge stay apart
    graph = sparse.coo_matrix((np.ones(int(manifold.sum())), (owner[manifold], face_edge.reshape(-1)[manifold])),
                              shape=(len(faces), len(edges))).tocsr()
    pieces, label = csgraph.connected_components(graph @ graph.T, directed=False)
    if pieces < PIECEWISE_WINDING:
        return lambda points: winding_numbers(vertices, faces, points)
    # a piece is closed when each of its edges is used twice by it, once each way
    keys, inverse = np.unique(label[owner] * np.int64(len(edges)) + face_edge.reshape(-1), return_inverse=True)
    uses = np.bincount(inverse, minlength=len(keys))
    turns = np.bincount(inverse, weights=np.where(forward, 1.0, -1.0).reshape(-1), minlength=len(keys))
    sealed = ((uses == 2) & (turns == 0))[inverse.reshape(-1, 3)].all(axis=1)
    closed = np.bincount(label, weights=~sealed, minlength=pieces) == 0
    order = np.argsort(label, kind="stable")
    starts = np.searchsorted(label[order], np.arange(pieces + 1))
    corners = vertices[faces[order]]
    pad = 1e-9 * float(np.linalg.norm(vertices.max(axis=0) - vertices.min(axis=0)))
    boxes = [(corners[a:b].min(axis=(0, 1)) - pad, corners[a:b].max(axis=(0, 1)) + pad) for a, b in zip(starts[:-1], starts[1:])]
    loose = faces[~closed[label]]

    def winding(points: np.ndarray) -> np.ndarray:
        w = winding_numbers(vertices, loose, points) if len(loose) else np.zeros(len(points))
        # the points in a piece's box: a slice of the points sorted along x, then y and z tested
        # (testing every point against every box took a quarter of ogre.obj's 28 s read)
        by_x = np.argsort(points[:, 0], kind="stable")
        xs = points[by_x, 0]
        for piece in np.flatnonzero(closed):
            lower, upper = boxes[piece]
            slab = by_x[np.searchsorted(xs, lower[0], "left"):np.searchsorted(xs, upper[0], "right")]
            inside = ((points[slab, 1:] >= lower[1:]) & (points[slab, 1:] <= upper[1:])).all(axis=1)
            near = np.sort(slab[inside])  # ascending, as a mask's indices
            if len(near):
                w[near] += winding_numbers(vertices, faces[order[starts[piece]:starts[piece + 1]]], points[near])
        return w

    return winding


def _sides(vertices, faces, centres, normals, sizes, winding=None, level=0.5):
    """Whether the solid (winding number above ``level``) is in front of and behind each centre
    (``winding``: the surface's winding number as a function of points, if prepared)."""
    step = 1e-3 * sizes[:, None] * normals
    probes = np.concatenate([centres + step, centres - step])
    w = winding(probes) if winding is not None else winding_numbers(vertices, faces, probes)
    count = len(centres)
    doubtful = np.flatnonzero(np.abs(w[:count] - w[count:]) < 0.5)
    if len(doubtful):
        import igl

        doubtful = doubtful[np.argsort(sizes[doubtful], kind="stable")[:EXACT_RECHECK]]
        exact = np.asarray(igl.winding_number(vertices, faces, np.concatenate([probes[doubtful], probes[count + doubtful]])))
        w[doubtful], w[count + doubtful] = exact[: len(doubtful)], exact[len(doubtful) :]
    return w[:count] > level, w[count:] > level


def _longest_side(corners: np.ndarray) -> np.ndarray:
    return np.linalg.norm(corners - np.roll(corners, 1, axis=-2), axis=-1).max(axis=-1)


def _split(corners: np.ndarray, levels: int) -> np.ndarray:
    """Each triangle (m, 3, 3) split into 4**levels by its side midpoints, orientation kept."""
    for _ in range(levels):
        a, b, c = corners[:, 0], corners[:, 1], corners[:, 2]
        ab, bc, ca = (a + b) / 2, (b + c) / 2, (c + a) / 2
        corners = np.stack(
            [np.stack(t, axis=1) for t in ((a, ab, ca), (ab, b, bc), (ca, bc, c), (ab, bc, ca))], axis=1
        ).reshape(-1, 3, 3)
    return corners


def _drop_internal(vertices: np.ndarray, faces: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, int, int]:
    """Drop triangles with the same side of the solid in front and behind (split those crossing
    a seam first); turn over those with the solid in front. Also returns the input triangle each
    output triangle comes from."""
    normals, areas = face_normals(vertices, faces)
    corners = vertices[faces]
    centroid = corners.mean(axis=1)
    sizes = _longest_side(corners)
    winding = _piecewise_winding(vertices, faces)
    front, back = _sides(vertices, faces, centroid, normals, sizes, winding)
    separating = (front != back) | (areas == 0)
    backwards = front & ~back
    if separating.all():
        origin = np.arange(len(faces))
        return vertices, np.where(backwards[:, None], faces[:, ::-1], faces), origin, 0, int(backwards.sum())
    near_corner = (0.9 * corners + 0.1 * centroid[:, None]).reshape(-1, 3)
    corner_front, corner_back = _sides(vertices, faces, near_corner, np.repeat(normals, 3, axis=0), np.repeat(sizes, 3),
                                       winding)
    corner_separating = (corner_front != corner_back).reshape(-1, 3)
    straddle = (corner_separating != separating[:, None]).any(axis=1) & (areas > 0)
    keep = separating & ~straddle
    kept_faces = np.where(backwards[:, None], faces[:, ::-1], faces)[keep]
    pieces = _split(corners[straddle], SEAM_LEVELS)
    parent = np.repeat(np.flatnonzero(straddle), 4**SEAM_LEVELS)
    piece_front, piece_back = _sides(vertices, faces, pieces.mean(axis=1), normals[parent], _longest_side(pieces), winding)
    piece_keep = piece_front != piece_back
    pieces = np.where((piece_front & ~piece_back)[:, None, None], pieces[:, ::-1], pieces)[piece_keep]
    piece_faces = len(vertices) + np.arange(3 * len(pieces)).reshape(-1, 3)
    vertices = np.concatenate([vertices, pieces.reshape(-1, 3)])
    faces = np.concatenate([kept_faces, piece_faces])
    origin = np.concatenate([np.flatnonzero(keep), parent[piece_keep]])
    return vertices, faces, origin, int((~keep).sum()), int((backwards & keep).sum())


def _crossing_check(vertices: np.ndarray, faces: np.ndarray) -> tuple[bool, Any]:
    """Whether two triangles that share no vertex cross (a closed piece whose parts pass through
    one another: a graphics model's tail through its leg; the parts inside the other's solid do
    not separate inside from outside), and the hierarchy built to find out."""
    from .bvh import TriangleTree
    from .self_crossing import crossing_triangles

    tree = TriangleTree(vertices, faces)
    return len(crossing_triangles(vertices, faces, tree)) > 0, tree


def _pieces(faces: np.ndarray) -> int:
    """Number of edge-connected pieces."""
    edges, face_edge, _ = edge_table(faces)
    owners = np.repeat(np.arange(len(faces)), 3)
    incidence = sparse.coo_matrix((np.ones(len(owners)), (owners, face_edge.reshape(-1))), shape=(len(faces), len(edges)))
    return int(csgraph.connected_components((incidence @ incidence.T).tocsr(), directed=False)[0])


def _even_edges(faces: np.ndarray) -> bool:
    """Every edge in an even number of triangles: two, or four where bodies touch along an edge
    (whatever their orientation)."""
    edges, face_edge, _ = edge_table(faces)
    return bool(len(faces)) and bool(np.all(np.bincount(face_edge.reshape(-1), minlength=len(edges)) % 2 == 0))


def _is_closed(faces: np.ndarray) -> bool:
    if len(faces) == 0:
        return False
    edges, face_edge, forward = edge_table(faces)
    counts = np.bincount(face_edge.reshape(-1), minlength=len(edges))
    if not np.all(counts == 2):
        return False
    ups = np.bincount(face_edge.reshape(-1), weights=forward.reshape(-1), minlength=len(edges))
    return bool(np.all(ups == 1))


def _closed_oriented(faces: np.ndarray) -> bool:
    """Every directed edge once and its reverse once (as :func:`_is_closed`, from two sorted key
    arrays instead of an edge table: a few hundred megabytes less on millions of triangles)."""
    if len(faces) == 0:
        return False
    count = np.int64(faces.max()) + 1
    forward = faces.reshape(-1) * count + faces[:, [1, 2, 0]].reshape(-1)
    forward.sort()
    if np.any(forward[1:] == forward[:-1]):
        return False
    backward = faces[:, [1, 2, 0]].reshape(-1) * count + faces.reshape(-1)
    backward.sort()
    return bool(np.array_equal(forward, backward))


def repair(vertices: np.ndarray, faces: np.ndarray, *, level_set: bool = False, coincident: bool = True) -> Repair:
    """Repair a triangle surface (see the module's description).

    ``level_set=True`` (a contoured scalar field: its triangles cannot overlap and are oriented
    alike) stops after step 1 when the surface is then closed (pairs of opposite triangles on
    the same three vertices dropped: a pocket the merge closed): the steps after it would leave
    such a surface as it is, and on millions of triangles they cost gigabytes. With
    ``coincident=False`` as well (no grid node exactly on the level: no two crossings meet, so
    no vertex repeats and no triangle collapses) step 1 is skipped too, unless a triangle has two
    corners at one position anyway: a node a hair off the level puts the crossings of its edges
    at the node once rounded to float32 coordinates.

    Examples
    --------
    >>> import numpy as np, pyvista as pv
    >>> cube = pv.Cube().triangulate().clean()
    >>> faces = cube.faces.reshape(-1, 4)[:, 1:].copy()
    >>> faces[0] = faces[0, ::-1]                      # one triangle flipped
    >>> fixed = repair(np.asarray(cube.points, float), faces)
    >>> fixed.flipped, fixed.closed
    (1, True)
    """
    vertices = np.asarray(vertices, dtype=np.float64)
    faces = np.asarray(faces, dtype=np.int64)
    if level_set and not coincident and not _collapsed(vertices, faces) and _closed_oriented(faces):
        return Repair(vertices=vertices, faces=faces, merged=0, degenerate=0, duplicates=0, flipped=0, holes=0,
                      hole_area=0.0, internal=0, open_edges=0, closed=True, filled=np.zeros(len(faces), dtype=bool))
    vertices, faces, merged = _merge_vertices(vertices, faces, weld=not level_set)
    cancelled = 0
    if level_set:
        faces, cancelled = _drop_cancelling_pairs(faces)
    faces, degenerate, duplicates = _drop_degenerate_and_duplicates(faces)
    duplicates += cancelled
    if level_set and _closed_oriented(faces):
        return Repair(vertices=vertices, faces=faces, merged=merged, degenerate=degenerate, duplicates=duplicates,
                      flipped=0, holes=0, hole_area=0.0, internal=0, open_edges=0, closed=True,
                      filled=np.zeros(len(faces), dtype=bool))
    faces, flipped = _orient(vertices, faces)
    faces, contacts = _drop_contacts(vertices, faces)
    if contacts:
        faces, turned = _orient(vertices, faces)  # the union's boundary is one surface now
        flipped += turned
    original = len(faces)
    holes = fill_holes(vertices, faces)
    vertices, faces, open_edges = holes.vertices, holes.faces, holes.open_edges
    filled = np.arange(len(faces)) >= original
    crosses, tree = _crossing_check(vertices, faces) if _is_closed(faces) and _pieces(faces) == 1 else (True, None)
    if not crosses:
        internal = backwards = 0  # one closed, consistently oriented piece: every triangle separates
    else:
        tree = None
        vertices, faces, origin, internal, backwards = _drop_internal(vertices, faces)
        filled = filled[origin]
    return Repair(
        vertices=vertices,
        faces=faces,
        merged=merged,
        degenerate=degenerate,
        duplicates=duplicates,
        flipped=flipped + backwards,
        holes=holes.holes,
        hole_area=holes.area,
        internal=internal,
        contacts=contacts,
        open_edges=open_edges,
        closed=_is_closed(faces),
        filled=filled,
        flat_holes=holes.flat,
        hole_bulge=holes.bulge,
        cut_holes=holes.cut,
        tree=tree,
    )
