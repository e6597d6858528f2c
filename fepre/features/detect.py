"""Where a model's patches meet: crease points and corners, found from a fine surface.

The model is sampled on a grid finer than the mesh (``spacing``) and its surface extracted by
flying edges. Each surface vertex gets the label of the patch that decides the model's value
there (:meth:`fepre.sdf.SDF.patch_labels`). A surface edge whose two ends carry different
labels crosses the line where those patches meet; Newton's method on the two patch functions
puts a point exactly on that line, and the point is kept when it lies on the model's zero set
(the patches' extensions also meet where the model has no surface) and the patches' normals
differ by more than the crease angle there (a smooth blend or a flat continuation is no
feature). Corners come the same way from three patches: near where crease points of different
pairs meet, or inside triangles whose corners carry three labels.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .newton import crease_angles, solve_on_patches

__all__ = ["Creases", "fine_surface", "find_creases"]

#: Grid nodes are placed this many spacings off the model's bounds, a fraction that keeps the
#: faces of boxes and slabs (often at round coordinates) off the grid planes.
_GRID_SHIFT = 2.371


@dataclass
class Creases:
    """Crease points (on two patches) and corners (on three), exact to Newton's tolerance.

    Attributes
    ----------
    points : (K, 3) crease points
    pairs : (K, 2) the two patch labels of each point, sorted
    angles : (K,) crease angle in degrees (angle between the two patches' outward normals)
    corners : (C, 3) corner points
    corner_labels : (C, 3) the three patch labels of each corner (-1 for a singular point)
    spacing : float
        Spacing of the fine grid the points came from.
    """

    points: np.ndarray
    pairs: np.ndarray
    angles: np.ndarray
    corners: np.ndarray
    corner_labels: np.ndarray
    spacing: float


def fine_surface(model, spacing: float, bounds) -> tuple[np.ndarray, np.ndarray]:
    """Vertices (V, 3) and triangles (T, 3) of the model's zero set sampled at ``spacing``."""
    import pyvista as pv

    from ..surface.flying_edges import flying_edges

    lower, upper = (np.asarray(b, dtype=np.float64) for b in bounds)
    origin = lower - _GRID_SHIFT * spacing
    counts = np.ceil((upper - lower) / spacing + 2 * _GRID_SHIFT).astype(np.int64) + 1
    axes = [origin[k] + spacing * np.arange(counts[k]) for k in range(3)]
    values = model.values_on_axes(*axes, dtype=np.float32)
    grid = pv.ImageData(dimensions=tuple(int(c) for c in counts), spacing=(spacing,) * 3, origin=tuple(origin))
    grid.point_data["sdf"] = values.reshape(-1)
    points, triangles = flying_edges(grid, "sdf", 0.0)
    return np.asarray(points, dtype=np.float64), np.asarray(triangles, dtype=np.int64)


def _unique_rows(keys: np.ndarray) -> np.ndarray:
    """Indices of the first occurrence of each distinct row of an int array."""
    if len(keys) == 0:
        return np.zeros(0, dtype=np.int64)
    _, first = np.unique(keys, axis=0, return_index=True)
    return np.sort(first)


def _cluster_first(points: np.ndarray, radius: float) -> np.ndarray:
    """Indices of points kept so that no two kept points are within ``radius`` (the first wins)."""
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import connected_components
    from scipy.spatial import cKDTree

    if len(points) == 0:
        return np.zeros(0, dtype=np.int64)
    pairs = cKDTree(points).query_pairs(radius, output_type="ndarray")
    graph = coo_matrix((np.ones(len(pairs)), (pairs[:, 0], pairs[:, 1])), shape=(len(points),) * 2)
    _, component = connected_components(graph, directed=False)
    _, first = np.unique(component, return_index=True)
    return np.sort(first)


#: Directions to the 26 neighbours of a grid cell, as unit vectors: probes around a candidate.
_PROBES = np.array([[i, j, k] for i in (-1, 0, 1) for j in (-1, 0, 1) for k in (-1, 0, 1) if (i, j, k) != (0, 0, 0)], float)
_PROBES /= np.linalg.norm(_PROBES, axis=1)[:, None]


def coincident_patches(model, vertices: np.ndarray, labels: np.ndarray, edges: np.ndarray, tol: float) -> np.ndarray:
    """Map (patch_count,) of each label to the smallest label of the same surface.

    Operands of a boolean often share a face (a box on a plate, a part trimmed by its bounding
    box): their labels alternate along that face. Two labels meeting across surface ``edges``
    are one surface when their functions agree at every end point of those edges.
    """
    canonical = np.arange(model.patch_count)
    if len(edges) == 0:
        return canonical
    a, b = labels[edges[:, 0]], labels[edges[:, 1]]
    ends = edges.reshape(-1)
    first = model._patch_values(np.repeat(a, 2), vertices[ends])
    second = model._patch_values(np.repeat(b, 2), vertices[ends])
    gap = np.abs(first - second).reshape(-1, 2).max(axis=1)
    pair_keys, inverse = np.unique(np.sort(np.column_stack([a, b]), axis=1), axis=0, return_inverse=True)
    worst = np.zeros(len(pair_keys))
    np.maximum.at(worst, inverse.reshape(-1), gap)
    same = pair_keys[worst <= tol]
    if len(same) == 0:
        return canonical
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import connected_components

    count = model.patch_count
    graph = coo_matrix((np.ones(len(same)), (same[:, 0], same[:, 1])), shape=(count, count))
    _, group = connected_components(graph, directed=False)
    smallest = np.full(group.max() + 1, count)
    np.minimum.at(smallest, group, np.arange(count))
    return smallest[group]


def _labels_around(model, points: np.ndarray, labels: np.ndarray, radius: float, canonical: np.ndarray) -> np.ndarray:
    """True where every label of ``labels`` (N, m) decides the model somewhere around the point.

    The patches' extensions can meet on the model's surface where the patches themselves do not
    (two planes crossing inside a flat face that a blend covers): such a point is no feature.
    """
    if len(points) == 0:
        return np.zeros(0, dtype=bool)
    probes = (points[:, None, :] + radius * _PROBES[None, :, :]).reshape(-1, 3)
    _, seen = model._patch_labels(probes)
    seen = canonical[seen].reshape(len(points), -1)
    return np.all((seen[:, None, :] == labels[:, :, None]).any(axis=2), axis=1)


def find_creases(model, spacing: float, bounds, angle: float, scale: float) -> Creases:
    """Crease points and corners of ``model`` where patches meet at more than ``angle`` degrees.

    ``scale`` is the model's size, for tolerances.
    """
    vertices, triangles = fine_surface(model, spacing, bounds)
    empty = Creases(np.zeros((0, 3)), np.zeros((0, 2), np.int64), np.zeros(0), np.zeros((0, 3)),
                    np.zeros((0, 3), np.int64), spacing)
    if len(triangles) == 0:
        return empty
    _, labels = model._patch_labels(vertices)
    tol = 1e-13 * scale
    step = 1e-6 * scale
    on_surface_tol = 1e-7 * scale

    # -- crease points: Newton from the midpoints of surface edges whose ends differ in label
    edges = np.sort(triangles[:, [0, 1, 1, 2, 2, 0]].reshape(-1, 2), axis=1)
    edges = np.unique(edges[labels[edges[:, 0]] != labels[edges[:, 1]]], axis=0)
    canonical = coincident_patches(model, vertices, labels, edges, 1e-9 * scale)
    labels = canonical[labels]
    edges = edges[labels[edges[:, 0]] != labels[edges[:, 1]]]
    pairs = np.sort(labels[edges], axis=1)
    start = vertices[edges].mean(axis=1)
    points, ok = solve_on_patches(model, pairs, start, tol=tol, step=step, reach=2.0 * spacing)
    if len(points):
        ok &= np.abs(model(points)) <= on_surface_tol
    points, pairs = points[ok], pairs[ok]
    real = _labels_around(model, points, pairs, 0.1 * spacing, canonical)
    points, pairs = points[real], pairs[real]
    angles = crease_angles(model, pairs, points, step) if len(points) else np.zeros(0)
    sharp = angles > angle
    points, pairs, angles = points[sharp], pairs[sharp], angles[sharp]
    keep = _cluster_first(points, 0.05 * spacing)  # neighbouring edges give the same point
    points, pairs, angles = points[keep], pairs[keep], angles[keep]

    # -- corners: three patches, from crease points of two pairs close together and from
    # triangles whose corners carry three labels
    triples = [np.zeros((0, 3), np.int64)]
    starts = [np.zeros((0, 3))]
    if len(points) > 1:
        from scipy.spatial import cKDTree

        close = cKDTree(points).query_pairs(3.0 * spacing, output_type="ndarray")
        close = close[np.any(pairs[close[:, 0]] != pairs[close[:, 1]], axis=1)]
        merged = np.sort(np.concatenate([pairs[close[:, 0]], pairs[close[:, 1]]], axis=1), axis=1)
        distinct = (merged[:, 1:] != merged[:, :-1]).sum(axis=1) + 1
        three = distinct == 3
        merged, close = merged[three], close[three]
        # the three distinct labels of the four (sorted): drop the repeated one
        first_of_run = np.concatenate([np.ones((len(merged), 1), bool), merged[:, 1:] != merged[:, :-1]], axis=1)
        triples.append(merged[first_of_run].reshape(-1, 3).astype(np.int64))
        starts.append(points[close].mean(axis=1))
    corner_triangles = triangles[
        (labels[triangles[:, 0]] != labels[triangles[:, 1]])
        & (labels[triangles[:, 1]] != labels[triangles[:, 2]])
        & (labels[triangles[:, 0]] != labels[triangles[:, 2]])
    ]
    triples.append(np.sort(labels[corner_triangles], axis=1))
    starts.append(vertices[corner_triangles].mean(axis=1))
    triple, start = np.concatenate(triples), np.concatenate(starts)
    corners = np.zeros((0, 3))
    corner_labels = np.zeros((0, 3), np.int64)
    if len(triple):
        # one start per triple and place suffices where starts are close; keep a few per triple
        cell = np.floor(start / spacing).astype(np.int64)
        first = _unique_rows(np.concatenate([triple, cell], axis=1))
        triple, start = triple[first], start[first]
        corners, ok = solve_on_patches(model, triple, start, tol=tol, step=step, reach=3.0 * spacing)
        ok &= np.abs(model(corners)) <= on_surface_tol
        corners, triple = corners[ok], triple[ok]
        real = _labels_around(model, corners, triple, 0.1 * spacing, canonical)
        corners, triple = corners[real], triple[real]
        if len(corners):
            pair_angles = np.stack(
                [crease_angles(model, triple[:, [i, j]], corners, step) for i, j in ((0, 1), (1, 2), (0, 2))], axis=1
            )
            # three creases meet (else: a junction of two); a pair at nearly 180 degrees is one
            # plane seen from both sides (a block standing on a plate: its bottom face, picked by
            # rounding at the foot of its walls once rotated), whose "corners" slide along a line
            sharp = ((pair_angles > angle) & (pair_angles < 180.0 - angle)).all(axis=1)
            corners, triple = corners[sharp], triple[sharp]
        keep = _cluster_first(corners, 1e-6 * scale)
        corners, corner_labels = corners[keep], triple[keep]

    # -- isolated singular points (a cone's apex) that lie on the surface
    singular = np.asarray(model.singular_points(), dtype=np.float64).reshape(-1, 3)
    if len(singular):
        singular = singular[np.abs(model(singular)) <= on_surface_tol]
        if len(corners) and len(singular):
            from scipy.spatial import cKDTree

            distance, _ = cKDTree(corners).query(singular)
            singular = singular[distance > 1e-6 * scale]
        corners = np.concatenate([corners, singular])
        corner_labels = np.concatenate([corner_labels, np.full((len(singular), 3), -1, np.int64)])
    return Creases(points, pairs, angles, corners, corner_labels, spacing)
