"""Quadratic (10-node) tetrahedra with curved boundaries.

Each edge gets a midside node. A boundary edge's midside node is projected onto the model's zero
set (Newton steps of :meth:`fepre.sdf.SDF.project`), so the element faces follow curved surfaces;
a boundary edge along a feature curve (its two boundary faces on different patches of the model,
both its ends on both patches) gets its midside node on that curve, where the two patches meet,
so a flat face bounded by a circle keeps the circle's area. Interior midside nodes stay at edge
midpoints. The Jacobian determinant of every element with a
moved node is then checked: at the four Gauss points of C3D10 (where solvers integrate) it must be
at least ``MIN_JACOBIAN_RATIO`` times that of the straight-sided element, and at the four corners
it must stay positive (no inversion anywhere at the nodes). A bad element's moved nodes go back to
their midpoints, repeated until no element is bad (this ends: the straight-sided mesh is valid).

Node order is VTK's (and Abaqus/CalculiX C3D10's): corners 0-3, then edges (0,1), (1,2), (2,0),
(0,3), (1,3), (2,3).
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass
from typing import Any

import numpy as np

from ..errors import ConvergenceWarning
from ..features.newton import solve_on_patches
from ..quality import signed_volumes

__all__ = ["QuadraticMesh", "quadratic_tetrahedra", "jacobian_ratios", "TET10_EDGES", "MIN_JACOBIAN_RATIO",
           "MIN_CORNER_JACOBIAN_RATIO"]

TET10_EDGES = np.array([[0, 1], [1, 2], [2, 0], [0, 3], [1, 3], [2, 3]], dtype=np.int64)
MIN_JACOBIAN_RATIO = 0.1  # at the Gauss points
MIN_CORNER_JACOBIAN_RATIO = 1e-3  # at the corners: positive with a margin for round-off
# Largest move of a projected midside node, as a fraction of its edge length; a longer move means
# the projection jumped to another part of the surface.
MAX_MOVE_FRACTION = 0.5

_GAUSS_A, _GAUSS_B = 0.5854101966249685, 0.1381966011250105
# Barycentric coordinates (L0, L1, L2, L3) of the check points: 4 Gauss points, then the corners.
CHECK_POINTS = np.vstack(
    [np.full((4, 4), _GAUSS_B) + np.eye(4) * (_GAUSS_A - _GAUSS_B), np.eye(4)]
)
_GRAD_L = np.array([[-1.0, -1.0, -1.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]])


@dataclass(frozen=True)
class QuadraticMesh:
    """Nodes (N + E, 3) and 10-node cells (M, 10) of a quadratic tetrahedral mesh.

    ``curved`` counts midside nodes moved onto the model surface; ``straightened`` counts those
    put back at their midpoint because an element's Jacobian went bad.
    """

    points: np.ndarray
    cells: np.ndarray
    curved: int
    straightened: int


def _shape_gradients(barycentric: np.ndarray) -> np.ndarray:
    """Gradients (Q, 10, 3) of the tet10 shape functions w.r.t. reference coordinates."""
    L = barycentric
    corner = (4.0 * L - 1.0)[:, :, None] * _GRAD_L[None, :, :]
    i, j = TET10_EDGES[:, 0], TET10_EDGES[:, 1]
    edge = 4.0 * (L[:, j, None] * _GRAD_L[None, i, :] + L[:, i, None] * _GRAD_L[None, j, :])
    return np.concatenate([corner, edge], axis=1)


_DN = _shape_gradients(CHECK_POINTS)


def jacobian_ratios(points: np.ndarray, cells10: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """det(J) / det(J of the straight element), smallest over the Gauss points and over the corners.

    Examples
    --------
    >>> import numpy as np
    >>> corners = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1.0]])
    >>> mids = (corners[TET10_EDGES[:, 0]] + corners[TET10_EDGES[:, 1]]) / 2
    >>> gauss, corner = jacobian_ratios(np.vstack([corners, mids]), np.arange(10)[None])
    >>> float(gauss[0]), float(corner[0])
    (1.0, 1.0)
    """
    nodes = points[cells10]  # (M, 10, 3)
    jac = np.einsum("mak,qal->mqkl", nodes, _DN)
    ratio = np.linalg.det(jac) / (6.0 * signed_volumes(points, cells10[:, :4]))[:, None]
    return ratio[:, :4].min(axis=1), ratio[:, 4:].min(axis=1)


# An edge end counts as on a patch within this fraction of the edge's length.
ON_PATCH_FRACTION = 1e-3


def crease_midpoints(
    model: Any, points: np.ndarray, triangles: np.ndarray, first: np.ndarray, second: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """Midside nodes on feature curves for the boundary edges ``first[i]``-``second[i]``.

    An edge lies along a feature curve when its two boundary triangles decide the model's value on
    two different patches (:meth:`fepre.sdf.SDF.patch_labels` at their centroids) and both its
    ends lie on both patches. Its midside node is the point where the two patches meet nearest
    the chord's midpoint (:func:`fepre.features.newton.solve_on_patches`).

    Returns
    -------
    on_crease : (E,) bool
        Edges whose midside node was placed on a feature curve.
    crease_points : (on_crease.sum(), 3) float array

    Examples
    --------
    >>> import numpy as np
    >>> from fepre import sdf
    >>> cube = sdf.box(2.0)
    >>> points = np.array([[1.0, 1.0, -0.5], [1.0, 1.0, 0.5], [0.0, 1.0, 0.0], [1.0, 0.0, 0.0]])
    >>> ok, where = crease_midpoints(cube, points, np.array([[0, 1, 2], [1, 0, 3]]), np.array([0]), np.array([1]))
    >>> ok.tolist(), where.tolist()
    ([True], [[1.0, 1.0, 0.0]])
    """
    on_crease = np.zeros(first.size, dtype=bool)
    if getattr(model, "patch_count", 1) < 2 or first.size == 0 or triangles.size == 0:
        return on_crease, np.zeros((0, 3))
    n_points = points.shape[0]
    _, triangle_patch = model.patch_labels(points[triangles].mean(axis=1))
    pairs = np.sort(triangles[:, [[0, 1], [1, 2], [2, 0]]], axis=2).reshape(-1, 2)
    keys = pairs[:, 0] * n_points + pairs[:, 1]
    order = np.argsort(keys, kind="stable")
    keys, owner = keys[order], np.repeat(np.arange(triangles.shape[0]), 3)[order]
    wanted = np.minimum(first, second) * n_points + np.maximum(first, second)
    start = np.searchsorted(keys, wanted)
    two_sided = (start + 1 < keys.size) & (keys[np.minimum(start + 1, keys.size - 1)] == wanted)
    two_sided &= keys[np.minimum(start, keys.size - 1)] == wanted
    candidates = np.flatnonzero(two_sided)
    patch_a = triangle_patch[owner[start[candidates]]]
    patch_b = triangle_patch[owner[start[candidates] + 1]]
    different = patch_a != patch_b
    candidates, patch_a, patch_b = candidates[different], patch_a[different], patch_b[different]
    if candidates.size == 0:
        return on_crease, np.zeros((0, 3))
    ends_a, ends_b = points[first[candidates]], points[second[candidates]]
    length = np.linalg.norm(ends_b - ends_a, axis=1)
    tolerance = ON_PATCH_FRACTION * length
    on_both = np.ones(candidates.size, dtype=bool)
    for end in (ends_a, ends_b):
        for patch in (patch_a, patch_b):
            on_both &= np.abs(model.patch_values(patch, end)) <= tolerance
    candidates, patch_a, patch_b = candidates[on_both], patch_a[on_both], patch_b[on_both]
    if candidates.size == 0:
        return on_crease, np.zeros((0, 3))
    length = length[on_both]
    chord_middle = 0.5 * (points[first[candidates]] + points[second[candidates]])
    solved, converged = solve_on_patches(
        model,
        np.column_stack([patch_a, patch_b]),
        chord_middle,
        tol=1e-10 * float(length.max()),
        step=1e-6 * float(length.max()),
        reach=MAX_MOVE_FRACTION * float(length.max()),  # per edge: quadratic_tetrahedra's check
    )
    on_crease[candidates[converged]] = True
    return on_crease, solved[converged]


def quadratic_tetrahedra(
    points: np.ndarray, cells: np.ndarray, boundary_triangles: np.ndarray, model: Any = None
) -> QuadraticMesh:
    """Add midside nodes; project boundary ones onto ``model`` (straight if ``model`` is None)."""
    n_points = points.shape[0]
    pairs = np.sort(cells[:, TET10_EDGES], axis=2)  # (M, 6, 2)
    keys = pairs[:, :, 0] * n_points + pairs[:, :, 1]
    unique_keys, edge_index = np.unique(keys.ravel(), return_inverse=True)
    edge_index = edge_index.reshape(cells.shape[0], 6)
    a, b = unique_keys // n_points, unique_keys % n_points
    midpoints = 0.5 * (points[a] + points[b])
    mids = midpoints.copy()
    moved = np.zeros(unique_keys.size, dtype=bool)
    if model is not None and boundary_triangles.size:
        tri_pairs = np.sort(boundary_triangles[:, [[0, 1], [1, 2], [2, 0]]], axis=2).reshape(-1, 2)
        boundary_edges = np.unique(
            np.searchsorted(unique_keys, tri_pairs[:, 0] * n_points + tri_pairs[:, 1])
        )
        with warnings.catch_warnings():  # nodes that do not get there stay straight, below
            warnings.simplefilter("ignore", ConvergenceWarning)
            projected = np.asarray(model.project(midpoints[boundary_edges]), dtype=np.float64)
        on_crease, crease_points = crease_midpoints(model, points, boundary_triangles, a[boundary_edges], b[boundary_edges])
        projected[on_crease] = crease_points
        move = np.linalg.norm(projected - midpoints[boundary_edges], axis=1)
        length = np.linalg.norm(points[a[boundary_edges]] - points[b[boundary_edges]], axis=1)
        accept = np.isfinite(move) & (move <= MAX_MOVE_FRACTION * length) & (move > 0)
        chosen = boundary_edges[accept]
        mids[chosen] = projected[accept]
        moved[chosen] = True
    cells10 = np.hstack([cells, n_points + edge_index])
    curved = int(moved.sum())
    straightened = 0
    while moved.any():
        touched = np.flatnonzero(moved[edge_index].any(axis=1))
        nodes = np.vstack([points, mids])
        gauss, corner = jacobian_ratios(nodes, cells10[touched])
        bad = touched[(gauss < MIN_JACOBIAN_RATIO) | (corner < MIN_CORNER_JACOBIAN_RATIO)]
        if bad.size == 0:
            break
        revert = np.unique(edge_index[bad][moved[edge_index[bad]]])
        mids[revert] = midpoints[revert]
        moved[revert] = False
        straightened += int(revert.size)
    return QuadraticMesh(np.vstack([points, mids]), cells10, curved - straightened, straightened)
