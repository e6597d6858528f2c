"""The curvature of a faceted surface at the scale of the mesh to be made.

A triangle surface is flat on every facet, so the Hessian of any function of its smooth pieces
(:func:`fepre.sizing.curvature.max_curvature`) is zero almost everywhere and the size field saw
no curvature on tessellated or scanned models: a statue's rim of radius ``h/3`` got cells of the
size of its flat base. The curvature is in the angles between facets: across the edge shared by
facets ``f`` and ``g`` the normal turns by ``n_f - n_g`` over the step ``c_f - c_g`` between
their centroids, a normal curvature of ``|(n_f - n_g) . (c_f - c_g)| / |c_f - c_g|^2`` in that
direction (``1/R`` on a tessellated sphere of radius R, however fine, and along the circle of
a cylinder). Each facet takes the largest over
its edges inside its smooth patch (a CAD edge between patches is a crease, not curvature), and
the values are averaged, by area, over the facets within ``scale`` of each one: a scan's
facet-to-facet noise averages out, and a bend tighter than ``scale`` counts as its turning angle
spread over ``scale``.
"""

from __future__ import annotations

import numpy as np

from .tables import edge_table, manifold_pairs

__all__ = ["facet_curvatures", "NOISE_FACETS", "MAX_FACET_PAIRS"]

#: The curvature is averaged over at least this many facet widths (the median edge length).
NOISE_FACETS = 3.0
#: Above this many (estimated) pairs of facets within the scale, the facets are first summed
#: into bins of half the scale: a surface of facets 50 times finer than the scale (a winding
#: number's spans on a scanned model: 2.2e9 pairs) would not fit in memory.
MAX_FACET_PAIRS = 30_000_000
#: pairs of facets summed at a time
PAIRS_PER_BLOCK = 500_000
#: facets whose neighbours are counted to estimate the pairs
_ESTIMATE_SAMPLES = 2_000


def _neighbour_estimate(tree, centroids: np.ndarray, scale: float) -> float:
    """The number of pairs of facets within ``scale``, from the neighbours of a sample."""
    sample = centroids[:: max(1, len(centroids) // _ESTIMATE_SAMPLES)]
    counts = tree.query_ball_point(sample, scale, return_length=True)
    return 0.5 * float(np.mean(counts)) * len(centroids)


def _binned_average(centroids, operators, patch, areas, scale) -> np.ndarray:
    """The area-weighted mean operator over the facets within about ``scale``, summed first
    per bin (cubes of half the scale, one per patch) and taken over the bins whose area-weighted
    centre lies within ``scale`` (a facet's own bin always does: a bin is 0.87 scale across)."""
    from scipy.sparse import coo_matrix
    from scipy.spatial import cKDTree

    cell = np.floor((centroids - centroids.min(axis=0)) / (0.5 * scale)).astype(np.int64)
    keys = np.column_stack([cell, patch.astype(np.int64)])
    bin_of = np.unique(keys, axis=0, return_inverse=True)[1].reshape(-1)
    count = int(bin_of.max()) + 1
    bin_area = np.bincount(bin_of, weights=areas, minlength=count)
    weight = np.maximum(bin_area, 1e-300)
    bin_centre = np.column_stack([np.bincount(bin_of, weights=areas * centroids[:, k], minlength=count) for k in range(3)])
    bin_centre /= weight[:, None]
    flat = operators.reshape(-1, 9)
    bin_operator = np.column_stack([np.bincount(bin_of, weights=areas * flat[:, k], minlength=count) for k in range(9)])
    bin_patch = np.zeros(count, np.int64)
    bin_patch[bin_of] = patch
    # a fourth coordinate, the patch times more than the scale, keeps other patches' bins out of
    # reach (beast.obj's seam pieces are 120,041 patches of one triangle, as dense as its facets)
    lift = 4.0 * scale
    facets = cKDTree(np.column_stack([centroids, lift * patch.astype(np.float64)]))
    bins = cKDTree(np.column_stack([bin_centre, lift * bin_patch.astype(np.float64)]))
    pairs = facets.sparse_distance_matrix(bins, scale, output_type="ndarray")
    rows, cols = np.concatenate([pairs["i"], np.arange(len(bin_of))]), np.concatenate([pairs["j"], bin_of])
    near = coo_matrix((np.ones(len(rows)), (rows, cols)), shape=(len(bin_of), count)).tocsr()
    near.data[:] = 1.0  # a facet's own bin, found twice when its centre is within the scale, counts once
    return (near @ bin_operator) / np.maximum(near @ bin_area, 1e-300)[:, None]


def _near_average(tree, centroids, operators, patch, areas, scale, per_facet: float) -> np.ndarray:
    """The area-weighted mean operator over the facets of the same patch within ``scale`` of
    each facet (itself included), summed a block of facets at a time (``per_facet``: the
    neighbours of a facet, estimated): the pairs of a whole surface at once held 3 GB on a
    sheet-metal box's 0.5 mm tessellation."""
    from scipy.spatial import cKDTree

    flat = operators.reshape(-1, 9)
    total = np.zeros((len(centroids), 9))
    weight = np.zeros(len(centroids))
    block = max(1, int(PAIRS_PER_BLOCK / max(per_facet, 1.0)))
    for start in range(0, len(centroids), block):
        rows = np.arange(start, min(start + block, len(centroids)))
        pairs = cKDTree(centroids[rows]).sparse_distance_matrix(tree, scale, output_type="ndarray")
        i, j = pairs["i"], pairs["j"]
        same = patch[rows[i]] == patch[j]
        i, j = i[same], j[same]
        weight[rows] = np.bincount(i, weights=areas[j], minlength=len(rows))
        for k in range(9):
            total[rows, k] = np.bincount(i, weights=areas[j] * flat[j, k], minlength=len(rows))
    return total / np.maximum(weight, 1e-300)[:, None]


def _shape_operators(vertices: np.ndarray, faces: np.ndarray, normals: np.ndarray, patch: np.ndarray) -> np.ndarray:
    """Per facet, the shape operator (F, 3, 3) fitted to how the normal turns towards its
    neighbours across its edges within its patch (least squares, in its tangent plane)."""
    edges, face_edge, forward = edge_table(faces)
    f, g, _, _ = manifold_pairs(face_edge, forward, len(edges))
    same = patch[f] == patch[g]
    f, g = np.concatenate([f[same], g[same]]), np.concatenate([g[same], f[same]])
    centroids = vertices[faces].mean(axis=1)
    # a tangent basis of each facet
    n = normals
    helper = np.where(np.abs(n[:, [0]]) < 0.9, [[1.0, 0.0, 0.0]], [[0.0, 1.0, 0.0]])
    u = np.cross(n, helper)
    u /= np.maximum(np.linalg.norm(u, axis=1), 1e-300)[:, None]
    v = np.cross(n, u)
    step, turn = centroids[g] - centroids[f], normals[g] - normals[f]
    du, dv = np.einsum("ij,ij->i", step, u[f]), np.einsum("ij,ij->i", step, v[f])
    tu, tv = np.einsum("ij,ij->i", turn, u[f]), np.einsum("ij,ij->i", turn, v[f])
    # least squares for the symmetric shape operator [[a, b], [b, c]]: turn = S step, per facet
    rows_u = np.stack([du, dv, np.zeros_like(du)], axis=1)
    rows_v = np.stack([np.zeros_like(du), du, dv], axis=1)
    normal_matrix = np.zeros((len(faces), 3, 3))
    right = np.zeros((len(faces), 3))
    np.add.at(normal_matrix, f, rows_u[:, :, None] * rows_u[:, None, :] + rows_v[:, :, None] * rows_v[:, None, :])
    np.add.at(right, f, rows_u * tu[:, None] + rows_v * tv[:, None])
    ridge = 1e-9 * np.maximum(np.trace(normal_matrix, axis1=1, axis2=2), 1e-300)
    normal_matrix += ridge[:, None, None] * np.eye(3)
    a, b, c = np.linalg.solve(normal_matrix, right[..., None])[..., 0].T
    # the operator in space, a u u^T + b (u v^T + v u^T) + c v v^T: averaged over neighbours
    # before its eigenvalues are taken, so a tessellation's zigzag of normals cancels
    return (a[:, None, None] * (u[:, :, None] * u[:, None, :]) + c[:, None, None] * (v[:, :, None] * v[:, None, :])
            + b[:, None, None] * (u[:, :, None] * v[:, None, :] + v[:, :, None] * u[:, None, :]))


def facet_curvatures(
    vertices: np.ndarray,
    faces: np.ndarray,
    normals: np.ndarray,
    patch: np.ndarray,
    areas: np.ndarray,
    scale: float,
) -> np.ndarray:
    """The largest principal curvature of each facet (F,), at the length ``scale``.

    Parameters
    ----------
    vertices : (V, 3) float array
    faces : (F, 3) int array
    normals : (F, 3) unit normals of the facets
    patch : (F,) int, the smooth patch of each facet (edges between patches are creases)
    areas : (F,) facet areas
    scale : float
        The facets within this distance of a facet (centroid to centroid, and at least
        ``NOISE_FACETS`` median edge lengths) in its patch are averaged.

    Examples
    --------
    A sphere of radius 2 tessellated with 7.9k facets has curvature 1/2 (2% under); a box none.

    >>> import numpy as np
    >>> import pyvista as pv
    >>> from fepre.sdf.meshmodel.patches import segment_patches
    >>> def curvature(surface):
    ...     faces = surface.faces.reshape(-1, 4)[:, 1:]
    ...     v = np.asarray(surface.points, dtype=float)
    ...     n = np.cross(v[faces[:, 1]] - v[faces[:, 0]], v[faces[:, 2]] - v[faces[:, 0]])
    ...     areas = 0.5 * np.linalg.norm(n, axis=1)
    ...     n /= 2 * areas[:, None]
    ...     return facet_curvatures(v, faces, n, segment_patches(faces, n, 30.0)[0], areas, scale=0.5)
    >>> k = curvature(pv.Sphere(radius=2.0, theta_resolution=64, phi_resolution=64))
    >>> round(float(np.median(k)), 2)
    0.49
    >>> float(curvature(pv.Box().triangulate()).max())
    0.0
    """
    from scipy.spatial import cKDTree

    operators = _shape_operators(vertices, faces, normals, patch)
    if len(faces) == 0:
        return np.zeros(0)
    centroids = vertices[faces].mean(axis=1)
    # a fit to three neighbours carries the tessellation's noise (marching cubes' facets at 45
    # deg to the grid: +28% on a ball); no curvature is measurable below a few facets
    edge = np.linalg.norm(vertices[faces[:, 0]] - vertices[faces[:, 1]], axis=1)
    scale = max(float(scale), NOISE_FACETS * float(np.median(edge)))
    tree = cKDTree(centroids)
    pairs = _neighbour_estimate(tree, centroids, scale)
    if pairs <= MAX_FACET_PAIRS:
        averaged = _near_average(tree, centroids, operators, patch, areas, scale, 2.0 * pairs / len(faces))
    else:
        averaged = _binned_average(centroids, operators, patch, areas, scale)
    eigenvalues = np.linalg.eigvalsh(averaged.reshape(-1, 3, 3))
    return np.abs(eigenvalues).max(axis=1)
