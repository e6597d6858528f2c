"""fepre's dual contouring (Ju, Losasso, Schaefer, Warren 2002): sharp edges and corners from a grid.

Connectivity is surface nets' (:mod:`fepre.surface.dual_cells`): one vertex per piece of surface
in an active cell, one quad per crossing grid edge, so the surface is closed, manifold and outward wherever surface
nets' is. Only the vertices differ: each sits at the minimiser of its cell's quadratic error
function (:mod:`fepre.surface.qef`), built from the Hermite data of its cut edges
(:mod:`fepre.surface.hermite`), so a cell cut by a crease gets a vertex on the crease and a cell
holding a corner gets the corner.

Steps, all vectorised over the active cells:

1. Hermite data: crossings refined on the model, normals from its gradient (or, for a grid
   without a model, linear crossings and the grid's gradient).
2. One QEF per cell, solved about the mass point with eigenvalues below ``truncation`` times the
   largest dropped (rank 1 on smooth surface, 2 on a crease, 3 at a corner).
3. Vertices kept in their cells (:mod:`fepre.surface.cell_vertices`): a corner found outside its
   cell is handed to the cell holding it and the finder falls back to its crease; a crease
   vertex slides along its crease into the cell grown by ``margin`` cells, the rest are
   clamped; vertices whose crossings sit at one grid node or along one grid line move off the
   point their neighbours share.
4. With a model, smooth-surface vertices (rank 1) take one Newton step onto the level set, and
   crease and corner cells (rank 2 or 3) are solved again, in four passes, from the model's
   tangent planes at probes between the vertex and each sample: half, a fifth, then a
   twentieth of the way (twice). A probe's plane replaces its sample only when it belongs to
   the same face (normals within ~37 degrees): a vertex still off the crease finds only the
   nearer face close by, hence far probes first. Planes taken at the crossings of a curved
   face (a hole meeting a flat face) put the vertex off the crease by about ``h^2 / (2 R)``;
   planes a twentieth of the way away by four hundred times less.
5. Each quad is split along the better diagonal (:mod:`fepre.surface.quad_split`).

Limits: a cell holding two pieces of surface (an ambiguous face, e.g. along a crease at an angle
to the grid) gives each piece a vertex from its own samples, so the surface stays manifold but the
crease is chamfered in that cell; a corner whose tip lies in a cell with no inside node more
than half a cell from a neighbour's box is cut off.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from .cell_vertices import donated_corners, keep_in_cells, solve_in_cells, unpinch, widened_for_tips
from .dual_cells import dual_cells, dual_keys, empty_dual_result, split_quads
from .hermite import Hermite, hermite_from_grid, hermite_from_model
from .qef import accumulate_qef, incidence
from .quad_split import better_diagonal

__all__ = ["dual_contouring"]

#: probes for the re-solves of crease and corner cells: these fractions of the way to each sample,
#: one pass each (far first: a vertex still off the crease would find only the nearer face close by)
_PROBE_FRACTIONS = (0.5, 0.2, 0.05, 0.05)
#: a probe's plane replaces its sample only when their normals' cosine is above this
_SAME_FACE_COSINE = 0.8


def dual_contouring(
    values: np.ndarray,
    level: float,
    origin: np.ndarray,
    spacing: np.ndarray,
    workers: int | None = None,
    *,
    model: Any = None,
    truncation: float = 0.1,
    margin: float = 0.01,
    first_node: np.ndarray | None = None,
    keys: bool = False,
):
    """Points (one per active cell) and outward triangles of the ``level`` set, sharp features kept.

    Parameters
    ----------
    values : (nz, ny, nx) array
        Samples in VTK order (x fastest).
    level : float
        Iso value; a node with ``value >= level`` is outside.
    origin, spacing : (3,) arrays
        Grid geometry.
    workers : int, optional
        Threads for the grid scan.
    model : fepre.sdf.SDF, optional
        The model the samples came from: gives exact crossings and normals (sharp features).
        Without it the normals come from the samples' gradient and creases are only as sharp
        as the grid resolves them.
    truncation : float
        Eigenvalues of a cell's ``A^T A`` below this fraction of its largest are dropped.
    margin : float
        How far (in cells) a vertex may leave its cell.
    first_node : (3,) int, optional
        The (i, j, k) index of ``values[0, 0, 0]`` in the grid that ``origin`` belongs to (a
        chunk of a larger grid): every coordinate is computed from whole-grid indices.
    keys : bool
        Also return :func:`fepre.surface.dual_cells.dual_keys`.

    Returns
    -------
    points : (C, 3) float64
    triangles : (T, 3) int64

    Examples
    --------
    >>> import numpy as np
    >>> from fepre import sdf
    >>> cube = sdf.box((1.0, 1.0, 1.0))
    >>> axis = np.linspace(-0.77, 0.77, 12)
    >>> values = cube.values_on_axes(axis, axis, axis)
    >>> origin, spacing = np.full(3, -0.77), np.full(3, axis[1] - axis[0])
    >>> points, triangles = dual_contouring(values, 0.0, origin, spacing, model=cube)
    >>> corner = np.linalg.norm(points - 0.5, axis=1).min()
    >>> bool(corner < 1e-9), triangles.shape[1]
    (True, 3)
    """
    origin = np.asarray(origin, dtype=float)
    spacing = np.asarray(spacing, dtype=float)
    dual = dual_cells(values, level, workers)
    if dual is None:
        return empty_dual_result(keys)
    first = np.zeros(3, dtype=np.int64) if first_node is None else np.asarray(first_node, dtype=np.int64)
    if model is None:
        hermite = hermite_from_grid(dual, values, level, origin, spacing, first)
    else:
        hermite = hermite_from_model(dual, values, level, origin, spacing, model, first_node=first)
    nz, ny, nx = values.shape
    k, rest = np.divmod(dual.vertex_grid_cell, nx * ny)
    j, i = np.divmod(rest, nx)
    low = origin + (np.stack([i, j, k], axis=1) + first) * spacing
    centre = low + 0.5 * spacing
    box = (low - margin * spacing, low + (1 + margin) * spacing)
    rows_cell, rows_crossing = dual.cell, dual.crossing  # the Hermite samples of each cell
    qef = accumulate_qef(rows_cell, hermite.points, hermite.normals, centre, rows_crossing)
    points, rank, free, corners = solve_in_cells(qef, truncation, *box)
    donated = donated_corners(corners, rank, rows_cell, rows_crossing, hermite, dual, origin, spacing, values.shape, first)
    widened = widened_for_tips(corners, dual, origin, spacing, values.shape, box, first)
    if donated is not None:
        order = np.argsort(np.concatenate([rows_cell, donated[0]]), kind="stable")
        rows_cell = np.concatenate([rows_cell, donated[0]])[order]
        rows_crossing = np.concatenate([rows_crossing, donated[1]])[order]
        qef = accumulate_qef(rows_cell, hermite.points, hermite.normals, centre, rows_crossing)
    if widened is not None:
        box = widened
    if donated is not None or widened is not None:
        points, rank, free, _ = solve_in_cells(qef, truncation, *box)
    points = unpinch(points, free, qef, rows_cell, rows_crossing, hermite, origin, spacing)
    points = keep_in_cells(points, rank, free, *box)
    if model is not None:
        points = _project_smooth(model, level, points, rank, box)
        points, rank = _refine_features(rows_cell, rows_crossing, hermite, model, level, points, rank, centre, box, truncation)
    facing = incidence(rows_cell, rows_crossing, dual.n_cells, dual.n_crossings) @ hermite.normals
    along02 = better_diagonal(points, dual.quads, rank >= 2, facing)
    triangles = split_quads(dual.quads, along02)
    return (points, triangles, dual_keys(dual)) if keys else (points, triangles)


def _project_smooth(
    model: Any, level: float, points: np.ndarray, rank: np.ndarray, box: tuple[np.ndarray, np.ndarray]
) -> np.ndarray:
    """One Newton step of each smooth-surface vertex (rank 1) onto the level set, kept in its cell.

    On a curved surface the tangent planes of a cell's crossings meet off the surface by about
    ``h^2 / (8 R)``; the step removes that to second order.
    """
    smooth = np.flatnonzero(rank == 1)
    if smooth.size == 0:
        return points
    value, gradient = model.value_and_gradient(points[smooth])
    norm2 = np.einsum("ij,ij->i", gradient, gradient)
    step = np.divide(value - level, norm2, out=np.zeros_like(norm2), where=norm2 > 0)
    points = points.copy()
    points[smooth] = np.clip(points[smooth] - step[:, None] * gradient, box[0][smooth], box[1][smooth])
    return points


def _refine_features(
    rows_cell: np.ndarray,
    rows_crossing: np.ndarray,
    hermite: Hermite,
    model: Any,
    level: float,
    points: np.ndarray,
    rank: np.ndarray,
    centre: np.ndarray,
    box: tuple[np.ndarray, np.ndarray],
    truncation: float,
) -> tuple[np.ndarray, np.ndarray]:
    """Solve crease and corner cells again from the model's tangent planes close to their vertex."""
    feature = np.flatnonzero(rank >= 2)
    if feature.size == 0:
        return points, rank
    compact = np.full(rank.size, -1, dtype=np.int64)
    compact[feature] = np.arange(feature.size)
    rows = compact[rows_cell] >= 0
    cell = compact[rows_cell[rows]]
    sample_points = hermite.points[rows_crossing[rows]]
    sample_normals = hermite.normals[rows_crossing[rows]]
    low, high = box[0][feature], box[1][feature]
    vertex = points[feature]
    for fraction in _PROBE_FRACTIONS:
        probe = vertex[cell] + fraction * (sample_points - vertex[cell])
        value, gradient = model.value_and_gradient(probe)
        norm2 = np.einsum("ij,ij->i", gradient, gradient)
        safe = np.where(norm2 > 0, norm2, 1.0)
        normal = gradient / np.sqrt(safe)[:, None]
        same_face = (norm2 > 0) & (np.einsum("ij,ij->i", normal, sample_normals) > _SAME_FACE_COSINE)
        on_surface = probe - ((value - level) / safe)[:, None] * gradient
        plane_points = np.where(same_face[:, None], on_surface, sample_points)
        plane_normals = np.where(same_face[:, None], normal, sample_normals)
        qef = accumulate_qef(cell, plane_points, plane_normals, centre[feature])
        vertex, feature_rank, free, _ = solve_in_cells(qef, truncation, low, high)
        vertex = keep_in_cells(vertex, feature_rank, free, low, high)
    points = points.copy()
    rank = rank.copy()
    points[feature] = vertex
    rank[feature] = feature_rank
    return points, rank
