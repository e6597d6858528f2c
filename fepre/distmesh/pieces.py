"""Pieces of a mesh: cells joined through shared faces.

A part thinner than ``h`` somewhere along a limb can leave the limb's tip as a piece of its own
(cow.obj's ear tips at D/50: pieces of 1 to 55 cells beside 27,000). A solver sees such a piece
as a body with nothing holding it (a singular stiffness matrix), so the mesher names them, and a
plain mesh drops those under ``SMALL_PIECE`` of the cells that the model joins to the rest
(:func:`cut_off_fragments`: libigl's armadillo at D/25 was written with a lone cell by a claw).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

__all__ = ["mesh_pieces", "cut_off_pieces", "cut_off_fragments", "fragments_message", "Fragments", "pieces_message",
           "SMALL_PIECE"]

#: Pieces with fewer than this fraction of the cells (beside a larger one) are named.
SMALL_PIECE = 0.01


def mesh_pieces(tets: np.ndarray, n_points: int) -> tuple[np.ndarray, np.ndarray]:
    """Label (M,) of each cell's piece and the (K,) cell counts of the pieces, largest first.

    Examples
    --------
    >>> labels, counts = mesh_pieces(np.array([[0, 1, 2, 3], [1, 2, 3, 4], [5, 6, 7, 8]]), 9)
    >>> labels.tolist(), counts.tolist()
    ([0, 0, 1], [2, 1])
    """
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import connected_components

    from .tet_topology import face_neighbours

    tets = np.asarray(tets, dtype=np.int64)
    if len(tets) == 0:
        return np.zeros(0, np.int64), np.zeros(0, np.int64)
    mate = face_neighbours(tets, n_points)
    cell = np.repeat(np.arange(len(tets)), 4)
    other = mate.reshape(-1)
    inner = other >= 0
    graph = coo_matrix((np.ones(int(inner.sum()), np.int8), (cell[inner], other[inner])), shape=(len(tets), len(tets)))
    count, labels = connected_components(graph, directed=False)
    sizes = np.bincount(labels, minlength=count)
    order = np.argsort(-sizes, kind="stable")
    rank = np.empty(count, np.int64)
    rank[order] = np.arange(count)
    return rank[labels], sizes[order]


def cut_off_pieces(points: np.ndarray, tets: np.ndarray, labels: np.ndarray, counts: np.ndarray, model,
                   size: np.ndarray) -> np.ndarray:
    """The pieces (other than the largest) that the model joins to another piece: a boundary
    node of one within the local element size ``size`` (per point) of a boundary node of another,
    with the midpoint between them inside the model (material the mesh lost between them: a
    rib's root thinner than an element), or with the segment between them on the model's
    surface all along (both on one face). Pieces the model keeps apart (separate parts, a gap)
    are not. ``size`` is an (N,) array over ``points``.

    Examples
    --------
    >>> from fepre import sdf
    >>> tets = np.array([[0, 1, 2, 3], [4, 5, 6, 7]])
    >>> cell = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]], float)
    >>> points = np.vstack([cell, cell + [0, 0, 1.5]])       # 0.5 apart, through the box
    >>> labels, counts = mesh_pieces(tets, 8)
    >>> cut_off_pieces(points, tets, labels, counts, sdf.box(5.0), np.full(8, 1.0)).tolist()
    [1]
    >>> cut_off_pieces(points, tets, labels, counts, sdf.box(5.0) - sdf.box((9, 9, 0.4), center=(0, 0, 1.25)),
    ...                np.full(8, 1.0)).tolist()                # a gap between them in the model
    []
    >>> flat = np.array([[0, 0, 2.5], [1, 0, 2.5], [0, 1, 2.5], [0, 0, 1.5]])   # on the box's top face
    >>> points = np.vstack([flat, flat + [1.5, 0, 0]])       # 0.5 apart on the face
    >>> cut_off_pieces(points, tets, labels, counts, sdf.box(5.0), np.full(8, 1.0)).tolist()
    [1]
    """
    from scipy.spatial import cKDTree

    from .topology import boundary_faces

    if len(counts) < 2:
        return np.zeros(0, np.int64)
    nodes = np.unique(boundary_faces(tets))
    piece = np.zeros(len(points), np.int64)
    piece[tets.ravel()] = np.repeat(labels, 4)
    piece = piece[nodes]
    others = np.flatnonzero(piece > 0)
    pairs = cKDTree(points[nodes[others]]).sparse_distance_matrix(
        cKDTree(points[nodes]), float(size[nodes[others]].max()), output_type="ndarray")
    first, second = others[pairs["i"]], pairs["j"]
    keep = (piece[first] != piece[second]) & (pairs["v"] <= size[nodes[first]])
    first, second = nodes[first[keep]], nodes[second[keep]]
    if len(first) == 0:
        return np.zeros(0, np.int64)
    # inside along the segment, or on the surface all along it: nodes on one face of a part about
    # an element thick (a gear's tooth tip cut off at h = its width: the nearest nodes lie on a
    # flank, and no pair across the tooth is within the size)
    along = np.stack([np.asarray(model(points[first] + t * (points[second] - points[first])), float)
                      for t in np.arange(1, 8) / 8.0])
    # (a gap between coplanar faces is found by a sample in it: narrower than h / 8, the mesh
    # bridges it and the pieces are one)
    inside = (along[3] < -1e-3 * size[first]) | (np.abs(along).max(axis=0) <= 1e-3 * size[first])
    found = piece[np.searchsorted(nodes, first[inside])]
    return np.unique(found)


def pieces_message(points: np.ndarray, tets: np.ndarray, labels: np.ndarray, counts: np.ndarray,
                   offset: np.ndarray | None = None, cut_off: np.ndarray | None = None) -> str | None:
    """A line naming the pieces with fewer than ``SMALL_PIECE`` of the cells and the pieces
    ``cut_off`` (:func:`cut_off_pieces`) whatever their size, or None."""
    if len(counts) < 2:
        return None
    cut = np.zeros(len(counts), bool)
    if cut_off is not None:
        cut[np.asarray(cut_off, np.int64)] = True
    cut[0] = False
    named = np.flatnonzero((counts < SMALL_PIECE * counts.sum()) | cut)
    if len(named) == 0:
        return None
    shift = np.zeros(3) if offset is None else np.asarray(offset, np.float64)
    named = np.concatenate([named[cut[named]], named[~cut[named]]])  # the cut-off ones first
    places = []
    for piece in named[:3]:
        centre = points[tets[labels == piece]].reshape(-1, 3).mean(axis=0) + shift
        where = " (the model joins it to the rest)" if cut[piece] else ""
        places.append(f"{counts[piece]:,} cell(s) at ({', '.join(f'{v:.6g}' for v in centre)}){where}")
    more = f" and {len(named) - 3} more" if len(named) > 3 else ""
    if cut_off is not None and not cut[named].any():
        # a gyroid's corners in a box are pieces of the model itself: no h joins them
        why = ("no part of the model within an element joins them to the rest: the model's own pieces (or "
               "joined farther off by a part thinner than the mesh's sizes)")
    else:
        why = "where a part of the model thinner than the mesh's sizes cut them off, a smaller h (or hmin) keeps them joined"
    return (f"the mesh is in {len(counts)} pieces not joined through faces: beside the largest ({counts[0]:,} cells), "
            f"{len(named)} piece(s): {'; '.join(places)}{more}; {why}; a solver needs every piece held")


@dataclass(frozen=True)
class Fragments:
    """Pieces dropped from a mesh (:func:`cut_off_fragments`): their cells, volume and each one's
    centre and cell count."""

    cells: int
    volume: float
    centres: np.ndarray
    counts: np.ndarray

    @staticmethod
    def none() -> "Fragments":
        return Fragments(0, 0.0, np.zeros((0, 3)), np.zeros(0, np.int64))


def cut_off_fragments(points: np.ndarray, tets: np.ndarray, model, size: np.ndarray,
                      keep: np.ndarray | None = None) -> tuple[np.ndarray, Fragments]:
    """Mask (M,) of the cells to keep and the :class:`Fragments` dropped: the pieces with fewer
    than ``SMALL_PIECE`` of the cells that the model joins to another piece
    (:func:`cut_off_pieces`), unless one holds a node of ``keep`` (N,) (a user's fixed point).

    Examples
    --------
    >>> from fepre import sdf
    >>> from scipy.spatial import Delaunay
    >>> grid = np.stack(np.meshgrid(*[np.arange(5.0)] * 3, indexing="ij"), -1).reshape(-1, 3)
    >>> block = Delaunay(grid).simplices                                  # hundreds of cells
    >>> cell = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]], float) + [1, 1, 4.5]
    >>> points, tets = np.vstack([grid, cell]), np.vstack([block, [[125, 126, 127, 128]]])
    >>> kept, dropped = cut_off_fragments(points, tets, sdf.box(20.0), np.full(len(points), 1.0))
    >>> int((~kept).sum()), dropped.cells, dropped.counts.tolist(), round(dropped.volume, 4)
    (1, 1, [1], 0.1667)
    >>> kept, dropped = cut_off_fragments(points, tets, sdf.box(20.0) - sdf.box((9, 9, 0.2), center=(0, 0, 4.25)),
    ...                                   np.full(len(points), 1.0))       # a gap between them in the model
    >>> dropped.cells
    0
    """
    from ..quality import signed_volumes

    labels, counts = mesh_pieces(tets, len(points))
    if len(counts) < 2:
        return np.ones(len(tets), bool), Fragments.none()
    cut = cut_off_pieces(points, tets, labels, counts, model, size)
    cut = cut[counts[cut] < SMALL_PIECE * counts.sum()]
    if keep is not None and len(cut):
        held = np.zeros(len(counts), bool)
        held[labels[keep[tets].any(axis=1)]] = True
        cut = cut[~held[cut]]
    if len(cut) == 0:
        return np.ones(len(tets), bool), Fragments.none()
    dropped = np.isin(labels, cut)
    centroids = points[tets[dropped]].mean(axis=1)
    centres = np.stack([centroids[labels[dropped] == piece].mean(axis=0) for piece in cut])
    return ~dropped, Fragments(int(dropped.sum()), float(signed_volumes(points, tets[dropped]).sum()), centres, counts[cut])


def fragments_message(fragments: Fragments, offset: np.ndarray | None = None) -> str | None:
    """A line naming the pieces :func:`cut_off_fragments` dropped, or None."""
    if fragments.cells == 0:
        return None
    shift = np.zeros(3) if offset is None else np.asarray(offset, np.float64)
    places = "; ".join(f"{count:,} cell(s) at ({', '.join(f'{v:.6g}' for v in centre + shift)})"
                       for count, centre in zip(fragments.counts[:3], fragments.centres[:3]))
    more = f" and {len(fragments.counts) - 3} more" if len(fragments.counts) > 3 else ""
    return (f"{len(fragments.counts)} piece(s) of the mesh, {fragments.cells} cell(s) and {fragments.volume:.3g} of volume, "
            f"were cut off from the rest where the model joins them (a part thinner than the mesh's sizes between) and "
            f"were dropped, as a solver cannot hold them: {places}{more}; a smaller h (or hmin) keeps them joined, "
            "thin_parts='keep' (fepre mesh --keep-thin) keeps them as they are")
