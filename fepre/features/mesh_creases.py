"""Creases of a triangle-surface model read from its triangles, not from a resampled surface.

:func:`fepre.features.detect.find_creases` samples a model on a grid of ``h/4`` and contours it
to find where its patches meet. For a model whose value is the distance to triangles that carry
patch labels (a label image's region, :class:`fepre.sdf.imagemodel.LabelModel`, or a closed
triangle-mesh model, :class:`fepre.sdf.meshmodel.MeshModel`: 7.4 of 21 s of a graded mesh of an
STL hub), that is one
exact distance query per grid node over the whole volume (108 of 216 s of a 256^3 label image's
mesh at 500k cells), and it only finds again what the triangles already hold: a crease is a run
of triangle edges whose two triangles lie on different patches, a corner a vertex where
creases of three patches meet. Here they are taken from the edges directly, in time linear in
the number of triangles.
"""

from __future__ import annotations

import numpy as np

from ..sdf.meshmodel.patches import flattest_neighbour_groups
from ..sdf.meshmodel.tables import edge_table, face_normals, manifold_pairs
from ..sdf.transforms import Affine
from .detect import Creases
from .newton import crease_angles

__all__ = ["triangle_creases", "from_triangles"]


def _source(model):
    """The model whose triangles hold the creases and the rigid map onto ``model`` ((4, 4) or
    None), or None when the triangles cannot be read."""
    if getattr(model, "creases_from_triangles", False):
        return model, None
    if isinstance(model, Affine) and getattr(model.children[0], "creases_from_triangles", False):
        linear = model.matrix[:3, :3]
        if np.allclose(linear @ linear.T, np.eye(3), rtol=0.0, atol=1e-12):
            return model.children[0], model.matrix
    return None


def from_triangles(model) -> bool:
    """True when ``model``'s creases are read from its triangles: a model that says so
    (``creases_from_triangles``, a label image's region), or one moved rigidly (the local frame
    :func:`fepre.features` moves a part far from the origin into)."""
    return _source(model) is not None


def _triangle_patches(model) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    source, matrix = _source(model)
    vertices, faces, normals, patch = source.triangle_patches()
    if matrix is not None:
        vertices = vertices @ matrix[:3, :3].T + matrix[:3, 3]
        normals = normals @ matrix[:3, :3].T
    return vertices, faces, normals, patch


def _points_along(vertices: np.ndarray, edges: np.ndarray, step: float) -> tuple[np.ndarray, np.ndarray]:
    """Points on each edge (E, 2) no more than ``step`` apart, its ends included; returns the
    points and the edge each came from. An end shared by edges is given once per edge."""
    start, end = vertices[edges[:, 0]], vertices[edges[:, 1]]
    pieces = np.maximum(1, np.ceil(np.linalg.norm(end - start, axis=1) / step)).astype(np.int64)
    owner = np.repeat(np.arange(len(edges)), pieces + 1)
    first = np.concatenate([[0], np.cumsum(pieces + 1)[:-1]])
    t = (np.arange(len(owner)) - first[owner]) / pieces[owner]
    return start[owner] + t[:, None] * (end - start)[owner], owner


def _corners(edges: np.ndarray, pairs: np.ndarray, vertex_count: int) -> tuple[np.ndarray, np.ndarray]:
    """Vertices where sharp creases of three or more patches meet, and their labels: the three
    patches, or -1 each where more than three meet (matched to every curve, as a singular point)."""
    ends = edges.reshape(-1)
    labels = np.repeat(pairs, 2, axis=0).reshape(-1, 2)
    rows = np.unique(np.column_stack([np.repeat(ends, 2), labels.reshape(-1)]), axis=0)
    counts = np.bincount(rows[:, 0], minlength=vertex_count)
    corner = np.flatnonzero(counts >= 3)
    starts = np.searchsorted(rows[:, 0], corner)
    triple = np.stack([rows[starts + k, 1] for k in range(3)], axis=1) if len(corner) else np.zeros((0, 3), np.int64)
    triple = np.where((counts[corner] > 3)[:, None], -1, triple)
    return corner, triple.astype(np.int64)


def _merge_folds(vertices, faces, normals, patch, edges, a, b, cosine) -> np.ndarray:
    """Patch labels with patches that meet only folded flat (a triangle turned over in its
    neighbour's plane, normals opposite) made one, the smallest label: their functions (the
    planes) agree on the surface, so the grid search sees one surface there
    (:func:`~fepre.features.detect.coincident_patches`), and a label change along a real crease
    would otherwise make a corner in its middle."""
    if len(edges) == 0:
        return patch
    extent = float(np.ptp(vertices[faces.reshape(-1)], axis=0).max())
    opposite = faces[b].sum(axis=1) - edges.sum(axis=1)  # b's vertex off the shared edge
    height = np.einsum("ij,ij->i", vertices[opposite] - vertices[edges[:, 0]], normals[a])
    folded = (cosine < 0.0) & (np.abs(height) <= 1e-9 * extent)
    count = int(patch.max()) + 1
    keys = np.sort(np.column_stack([patch[a], patch[b]]), axis=1)
    keys = keys[:, 0] * count + keys[:, 1]
    unfolded = np.unique(keys[~folded])
    merge = np.unique(keys[folded & ~np.isin(keys, unfolded)])  # every edge of the pair folded
    if len(merge) == 0:
        return patch
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import connected_components

    graph = coo_matrix((np.ones(len(merge)), (merge // count, merge % count)), shape=(count, count))
    _, group = connected_components(graph, directed=False)
    smallest = np.full(group.max() + 1, count)
    np.minimum.at(smallest, group, np.arange(count))
    return smallest[group][patch]


#: Patches of less area than (this many spacings)^2 join a neighbour: the grid search at that
#: spacing rarely lands a surface vertex on them (scans' specks of two or three triangles).
UNSEEN_PATCH = 2.0


def _absorb_unseen(vertices, faces, patch, a, b, cosine, spacing: float) -> np.ndarray:
    """Patch labels with each patch of less area than ``(UNSEEN_PATCH * spacing)^2`` given the
    label of the neighbour it meets across its flattest edge (``a``-``b``: the triangles across
    each manifold edge, ``cosine`` of their normals), as the grid search of that spacing finds
    no crease around it: a speck's creases, short curves a fraction of h long, cost bunny_small
    at D/50 its worst dihedral (8.7 deg, 25.2 with the grid's features). Specks that meet only
    specks join the largest of them."""
    count = int(patch.max()) + 1
    area = np.bincount(patch, weights=face_normals(vertices, faces)[1], minlength=count)
    group = flattest_neighbour_groups(patch, count, area < (UNSEEN_PATCH * spacing) ** 2, a, b, cosine)
    if group is None:
        return patch
    order = np.lexsort((area, group))  # by group, then area: each group's largest is its last
    last = np.flatnonzero(np.append(group[order][1:] != group[order][:-1], True))
    return order[last][group][patch]


def _sharp_corners(model, corners: np.ndarray, labels: np.ndarray, angle: float) -> tuple[np.ndarray, np.ndarray]:
    """The corners of three patches kept where, as in the grid search, each two of them meet at
    more than ``angle`` and less than ``180 - angle`` degrees there (by the patches' functions:
    a knife edge, whose curve is dropped, makes no corner on it); those of more patches kept."""
    three = np.flatnonzero((labels >= 0).all(axis=1))
    if len(three) == 0:
        return corners, labels
    lower, upper = (np.asarray(v, dtype=np.float64) for v in model.bounds)
    step = 1e-6 * float(np.max(upper - lower))
    pair = np.stack([crease_angles(model, labels[three][:, [i, j]], corners[three], step)
                     for i, j in ((0, 1), (1, 2), (0, 2))], axis=1)
    keep = np.ones(len(corners), dtype=bool)
    keep[three] = ((pair > angle) & (pair < 180.0 - angle)).all(axis=1)
    return corners[keep], labels[keep]


def triangle_creases(model, spacing: float, bounds, angle: float) -> Creases:
    """The creases and corners of a triangle-surface model with patch labels, from its edges.

    A crease point lies on an edge shared by two triangles of different patches whose normals
    differ by more than ``angle`` degrees (patches too small for the grid search of this
    ``spacing`` to see, and patches folded flat onto each other, are one with their neighbour);
    the edges' points are no more than ``spacing / 2`` apart (their ends, the triangles'
    vertices, are exactly on both patches). A corner is a vertex where such edges of three or
    more patches meet (of three, each two at more than ``angle`` and less than ``180 - angle``
    degrees there). Only points within ``bounds`` (a spacing beyond) are kept, as on the grid of
    :func:`~fepre.features.detect.find_creases`.

    ``model`` (or the model it moves rigidly) provides ``triangle_patches()``: vertices (V, 3),
    triangles (F, 3), unit normals (F, 3) and the patch of each triangle (F,).

    Examples
    --------
    >>> from fepre import sdf
    >>> from fepre.sdf.imagemodel.phantoms import label_image
    >>> grid = label_image([sdf.box(1.0), sdf.sphere(0.3)], (-0.6,) * 3, (0.6,) * 3, 0.05)
    >>> cube = sdf.labels(grid).part
    >>> found = triangle_creases(cube, 0.025, cube.bounds, 30.0)
    >>> len(found.corners), sorted(set(found.angles.round(6).tolist()))
    (8, [90.0])
    """
    vertices, faces, normals, patch = _triangle_patches(model)
    edges, face_edge, forward = edge_table(faces)
    a, b, _, counts = manifold_pairs(face_edge, forward, len(edges))
    shared = edges[counts == 2]
    cosine = np.clip(np.einsum("ij,ij->i", normals[a], normals[b]), -1.0, 1.0)
    sharp = np.degrees(np.arccos(cosine)) > angle
    patch = _merge_folds(vertices, faces, normals, patch, shared[sharp], a[sharp], b[sharp], cosine[sharp])
    patch = _absorb_unseen(vertices, faces, patch, a, b, cosine, spacing)
    sharp &= patch[a] != patch[b]
    edges = shared[sharp]
    pairs = np.sort(np.column_stack([patch[a[sharp]], patch[b[sharp]]]), axis=1).astype(np.int64)
    angles = np.degrees(np.arccos(cosine[sharp]))
    points, owner = _points_along(vertices, edges, 0.5 * spacing)
    # a vertex shared by edges of one pair once: rows (point, pair) made unique
    _, first = np.unique(np.column_stack([np.round(points / (1e-6 * spacing)), pairs[owner]]), axis=0, return_index=True)
    first = np.sort(first)
    points, owner = points[first], owner[first]
    corner, corner_labels = _corners(edges, pairs, len(vertices))
    corners, corner_labels = _sharp_corners(model, vertices[corner], corner_labels, angle)
    lower, upper = (np.asarray(v, dtype=np.float64) for v in bounds)
    inside = np.all((points >= lower - spacing) & (points <= upper + spacing), axis=1)
    kept = np.all((corners >= lower - spacing) & (corners <= upper + spacing), axis=1)
    return Creases(points[inside], pairs[owner[inside]], angles[owner[inside]], corners[kept], corner_labels[kept], spacing)
