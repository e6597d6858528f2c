"""fepre's dual contouring (Ju, Losasso, Schaefer, Warren 2002): sharp edges and corners from a grid.

Connectivity is surface nets' (:mod:`fepre.surface.dual_cells`): one vertex per active cell, one
quad per crossing grid edge, so the surface is closed, manifold and outward wherever surface
nets' is. Only the vertices differ: each sits at the minimiser of its cell's quadratic error
function (:mod:`fepre.surface.qef`), built from the Hermite data of its cut edges
(:mod:`fepre.surface.hermite`), so a cell cut by a crease gets a vertex on the crease and a cell
holding a corner gets the corner.

Steps, all vectorised over the active cells:

1. Hermite data: crossings refined on the model, normals from its gradient (or, for a grid
   without a model, linear crossings and the grid's gradient).
2. One QEF per cell, solved about the mass point with eigenvalues below ``truncation`` times the
   largest dropped (rank 1 on smooth surface, 2 on a crease, 3 at a corner). In a free
   direction where a cell's crossings do not spread (a grid node or line on the surface), the
   vertex moves half way to the cell centre so that neighbouring cells do not share a point.
3. With a model, smooth-surface vertices (rank 1) take one Newton step onto the level set, and
   crease and corner cells (rank 2 or 3) are solved again, in four passes, from the model's
   tangent planes at probes between the vertex and each sample: half, a fifth, then a
   twentieth of the way (twice). A probe's plane replaces its sample only when it belongs to
   the same face (normals within ~37 degrees): a vertex still off the crease finds only the
   nearer face close by, hence far probes first. Planes taken at the crossings of a curved
   face (a hole meeting a flat face) put the vertex off the crease by about ``h^2 / (2 R)``;
   planes a twentieth of the way away by four hundred times less.
4. Each vertex is kept in its cell grown by ``margin`` cells: a crease vertex slides along its
   crease into the cell, others are clamped to the box.
5. Each quad is split along the diagonal that gives the better triangles: never one of zero
   area when the other split has none, then the one joining two crease vertices (so the
   surface folds along the crease, not across it), then the larger smallest triangle quality.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from .dual_cells import DualCells, dual_cells, split_quads
from .hermite import Hermite, hermite_from_grid, hermite_from_model
from .qef import accumulate_qef, sample_spread

__all__ = ["dual_contouring"]

#: probes for the re-solves of crease and corner cells: these fractions of the way to each sample,
#: one pass each (far first: a vertex still off the crease would find only the nearer face close by)
_PROBE_FRACTIONS = (0.5, 0.2, 0.05, 0.05)
#: a probe's plane replaces its sample only when their normals' cosine is above this
_SAME_FACE_COSINE = 0.8
#: a corner found by a neighbour is given to the cell holding it when that cell's own planes
#: pass within this many cells of it
_DONATION = 0.05
#: a corner in a cell without a vertex is kept by a neighbour up to this many cells outside it
_TIP_REACH = 0.5
#: crossings of one cell all within this many cells of each other count as one point
_PINCH = 1e-3
#: a triangle of smaller quality (4 sqrt(3) area / sum of squared sides) counts as degenerate
_DEGENERATE_QUALITY = 1e-6


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
) -> tuple[np.ndarray, np.ndarray]:
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
        return np.empty((0, 3)), np.empty((0, 3), dtype=np.int64)
    if model is None:
        hermite = hermite_from_grid(dual, values, level, origin, spacing)
    else:
        hermite = hermite_from_model(dual, values, level, origin, spacing, model)
    nz, ny, nx = values.shape
    k, rest = np.divmod(dual.scan.cells, nx * ny)
    j, i = np.divmod(rest, nx)
    low = origin + np.stack([i, j, k], axis=1) * spacing
    centre = low + 0.5 * spacing
    box = (low - margin * spacing, low + (1 + margin) * spacing)
    rows_cell, rows_crossing = dual.cell, dual.crossing  # the Hermite samples of each cell
    qef = accumulate_qef(rows_cell, hermite.points[rows_crossing], hermite.normals[rows_crossing], centre)
    points, rank, free, corners = _solve_in_cells(qef, truncation, *box)
    donated = _donated_corners(corners, rank, rows_cell, rows_crossing, hermite, dual, origin, spacing, values.shape)
    widened = _widened_for_tips(corners, dual, origin, spacing, values.shape, box)
    if donated is not None:
        order = np.argsort(np.concatenate([rows_cell, donated[0]]), kind="stable")
        rows_cell = np.concatenate([rows_cell, donated[0]])[order]
        rows_crossing = np.concatenate([rows_crossing, donated[1]])[order]
        qef = accumulate_qef(rows_cell, hermite.points[rows_crossing], hermite.normals[rows_crossing], centre)
    if widened is not None:
        box = widened
    if donated is not None or widened is not None:
        points, rank, free, _ = _solve_in_cells(qef, truncation, *box)
    points = _unpinch(points, free, qef, rows_cell, rows_crossing, hermite, origin, spacing)
    points = _keep_in_cells(points, rank, free, *box)
    if model is not None:
        points = _project_smooth(model, level, points, rank, box)
        points, rank = _refine_features(rows_cell, rows_crossing, hermite, model, level, points, rank, centre, box, truncation)
    facing = np.stack(
        [np.bincount(rows_cell, weights=hermite.normals[rows_crossing, a], minlength=dual.n_cells) for a in range(3)],
        axis=1,
    )
    along02 = _better_diagonal(points, dual.quads, rank >= 2, facing)
    return points, split_quads(dual.quads, along02)


def _donated_corners(
    corners: tuple[np.ndarray, np.ndarray],
    rank: np.ndarray,
    rows_cell: np.ndarray,
    rows_crossing: np.ndarray,
    hermite: Hermite,
    dual: DualCells,
    origin: np.ndarray,
    spacing: np.ndarray,
    shape: tuple[int, int, int],
) -> tuple[np.ndarray, np.ndarray] | None:
    """Samples to give to the cell that holds a corner but sees only two of its faces.

    Where a corner's tip pokes into a cell, the cell's cut edges may cross only two of the three
    faces, while a neighbour's cross all three and put their corner outside the neighbour. If
    the corner lies in an active cell whose own planes all pass within ``_DONATION`` cells of
    it, that cell also gets the neighbour's samples (its QEF then finds the corner). Returns
    ``(cell, crossing)`` rows to add, or None. A tip in a cell with no inside node is lost: the
    dual grid has no vertex there.
    """
    donor, point = corners
    if donor.size == 0:
        return None
    nz, ny, nx = shape
    ijk = np.floor((point - origin) / spacing).astype(np.int64)
    inside_grid = np.all((ijk >= 0) & (ijk < np.array([nx - 1, ny - 1, nz - 1])), axis=1)
    ids = ijk @ np.array([1, nx, nx * ny])
    target = np.minimum(np.searchsorted(dual.scan.cells, ids), dual.n_cells - 1)
    usable = inside_grid & (dual.scan.cells[target] == ids) & (rank[target] < 3)
    donor, point, target = donor[usable], point[usable], target[usable]
    target, first = np.unique(target, return_index=True)  # one donor per target
    donor, point = donor[first], point[first]
    if target.size == 0:
        return None
    # the target's own planes must pass through the corner
    start, end = np.searchsorted(rows_cell, target), np.searchsorted(rows_cell, target, side="right")
    pair = np.repeat(np.arange(target.size), end - start)
    row = np.arange(pair.size) - np.repeat(np.cumsum(end - start) - (end - start), end - start) + start[pair]
    crossing = rows_crossing[row]
    miss = np.abs(np.einsum("ij,ij->i", hermite.normals[crossing], point[pair] - hermite.points[crossing]))
    worst = np.zeros(target.size)
    np.maximum.at(worst, pair, miss)
    keep = worst < _DONATION * float(np.min(spacing))
    donor, target = donor[keep], target[keep]
    if target.size == 0:
        return None
    start, end = np.searchsorted(rows_cell, donor), np.searchsorted(rows_cell, donor, side="right")
    pair = np.repeat(np.arange(donor.size), end - start)
    row = np.arange(pair.size) - np.repeat(np.cumsum(end - start) - (end - start), end - start) + start[pair]
    return target[pair], rows_crossing[row]


def _widened_for_tips(
    corners: tuple[np.ndarray, np.ndarray],
    dual: DualCells,
    origin: np.ndarray,
    spacing: np.ndarray,
    shape: tuple[int, int, int],
    box: tuple[np.ndarray, np.ndarray],
) -> tuple[np.ndarray, np.ndarray] | None:
    """Boxes grown to take a corner whose tip lies in a cell with no vertex (no inside node).

    No vertex of the dual grid can sit in such a cell, so the neighbour that found the corner
    keeps it when it lies within ``_TIP_REACH`` cells of the neighbour's own box; of several
    such neighbours, the nearest. Returns the new ``(low, high)`` or None.
    """
    donor, point = corners
    if donor.size == 0:
        return None
    nz, ny, nx = shape
    ijk = np.floor((point - origin) / spacing).astype(np.int64)
    ijk = np.clip(ijk, 0, np.array([nx - 2, ny - 2, nz - 2]))
    ids = ijk @ np.array([1, nx, nx * ny])
    where = np.minimum(np.searchsorted(dual.scan.cells, ids), dual.n_cells - 1)
    low, high = box
    gap = np.maximum(np.maximum(low[donor] - point, point - high[donor]), 0.0) / spacing
    tip = (dual.scan.cells[where] != ids) & (gap.max(axis=1) < _TIP_REACH)
    donor, point, ids, distance = donor[tip], point[tip], ids[tip], np.linalg.norm(gap[tip], axis=1)
    if donor.size == 0:
        return None
    order = np.lexsort((distance, ids))
    first = order[np.r_[True, ids[order][1:] != ids[order][:-1]]]  # the nearest donor per tip cell
    donor, point = donor[first], point[first]
    low, high = low.copy(), high.copy()
    low[donor] = np.minimum(low[donor], point)
    high[donor] = np.maximum(high[donor], point)
    return low, high


def _unpinch(
    points: np.ndarray,
    free: np.ndarray,
    qef,
    rows_cell: np.ndarray,
    rows_crossing: np.ndarray,
    hermite: Hermite,
    origin: np.ndarray,
    spacing: np.ndarray,
) -> np.ndarray:
    """In the directions a cell's QEF leaves free, move half way to the centre where the crossings do not spread.

    A grid node or grid line lying on the surface (value exactly ``level``, so outside) with
    inside neighbours holds the crossings of all their edges; the cells around it would all get
    the same mass point, hence the same vertex, and the quads between them zero area. Along a
    free direction in which a cell's crossings spread less than a thousandth of a cell, the
    vertex moves half way to the centre's coordinate (the centres differ; half way, so that it
    does not land on the mass point of a neighbour whose crossings do spread). Crossings only
    fail to spread when they all sit on grid nodes along a grid line or at one node, so only
    such cells are examined.
    """
    count = points.shape[0]
    grid_units = (hermite.points - origin) / spacing
    off_node = (np.abs(grid_units - np.rint(grid_units)) > _PINCH).any(axis=1)
    candidates = np.flatnonzero(np.bincount(rows_cell, weights=off_node[rows_crossing], minlength=count) == 0)
    if candidates.size == 0:
        return points
    # of those, the cells whose crossings lie on a grid line or at one node (two or three axes flat)
    chosen = np.zeros(count, dtype=bool)
    chosen[candidates] = True
    rows = chosen[rows_cell]  # rows_cell is sorted, so each candidate's rows are contiguous
    position = hermite.points[rows_crossing[rows]]
    starts = np.searchsorted(rows_cell[rows], candidates)
    extent = np.maximum.reduceat(position, starts, axis=0) - np.minimum.reduceat(position, starts, axis=0)
    candidates = candidates[(extent < _PINCH * spacing).sum(axis=1) >= 2]
    if candidates.size == 0:
        return points
    chosen[:] = False
    chosen[candidates] = True
    rows = chosen[rows_cell]
    compact = np.searchsorted(candidates, rows_cell[rows])
    spread = sample_spread(compact, hermite.points[rows_crossing[rows]], candidates.size)
    limit = (_PINCH * float(np.min(spacing))) ** 2
    big = float(np.max(spacing)) ** 2
    projector = free[candidates]
    restricted = projector @ spread @ projector + big * (np.eye(3) - projector)  # constrained directions: big
    values, directions = np.linalg.eigh(restricted)
    pinched = directions * (values < limit)[:, None, :]
    # the centre is the reference: the mass point relative to it is qef.mass
    shift = -0.5 * np.einsum("cik,cjk,cj->ci", pinched, pinched, qef.mass[candidates])
    points = points.copy()
    points[candidates] += shift
    return points


def _crease_interval(
    points: np.ndarray, free: np.ndarray, low: np.ndarray, high: np.ndarray
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Direction (C, 3) of each crease line ``points + s u`` and the interval of ``s`` inside the box.

    ``free`` holds the projectors ``u u^T`` onto the creases; an empty interval has enter > leave.
    """
    column = np.argmax(np.einsum("cii->ci", free), axis=1)
    u = free[np.arange(free.shape[0]), :, column]
    u /= np.linalg.norm(u, axis=1, keepdims=True)
    lo, hi = low - points, high - points
    with np.errstate(divide="ignore", invalid="ignore"):
        a, b = lo / u, hi / u
    flat = np.abs(u) < 1e-12
    enter = np.where(flat, np.where(lo <= 0, -np.inf, np.inf), np.minimum(a, b)).max(axis=1)
    leave = np.where(flat, np.where(hi >= 0, np.inf, -np.inf), np.maximum(a, b)).min(axis=1)
    return u, enter, leave


def _solve_in_cells(qef, truncation: float, low: np.ndarray, high: np.ndarray):
    """Solve, then drop a rank where the solution cannot lie in its cell (box ``low``-``high``).

    A cell next to a corner may see all three faces; their corner lies in another cell, and
    clamping it into this one would put the vertex off the surface. Such a cell is solved again
    with two eigenvalues (the crease nearest its mass point), and a crease missing the box with
    one (the face). Returns points, ranks, free projectors and the corners found outside their
    cells (cell indices and points).
    """
    points, rank, free = qef.solve(truncation)
    corner = np.flatnonzero(rank == 3)
    away = corner[np.any((points[corner] < low[corner]) | (points[corner] > high[corner]), axis=1)]
    corners = (away, points[away].copy())
    if away.size:
        points[away], rank[away], free[away] = qef.subset(away).solve(truncation, max_rank=2)
    crease = np.flatnonzero(rank == 2)
    if crease.size:
        _, enter, leave = _crease_interval(points[crease], free[crease], low[crease], high[crease])
        away = crease[enter > leave]
        if away.size:
            points[away], rank[away], free[away] = qef.subset(away).solve(truncation, max_rank=1)
    return points, rank, free, corners


def _keep_in_cells(
    points: np.ndarray, rank: np.ndarray, free: np.ndarray, low: np.ndarray, high: np.ndarray
) -> np.ndarray:
    """Slide crease vertices along their crease into the box, then clamp every vertex to it."""
    points = points.copy()
    crease = np.flatnonzero(rank == 2)
    if crease.size:
        u, enter, leave = _crease_interval(points[crease], free[crease], low[crease], high[crease])
        meets = enter <= leave
        shift = np.clip(0.0, enter, leave)
        points[crease[meets]] += shift[meets, None] * u[meets]
    return np.clip(points, low, high)


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
        vertex, feature_rank, free, _ = _solve_in_cells(qef, truncation, low, high)
        vertex = _keep_in_cells(vertex, feature_rank, free, low, high)
    points = points.copy()
    rank = rank.copy()
    points[feature] = vertex
    rank[feature] = feature_rank
    return points, rank


def _cross(u: tuple, v: tuple) -> tuple:
    """Cross products of vectors given as (x, y, z) component arrays."""
    return (u[1] * v[2] - u[2] * v[1], u[2] * v[0] - u[0] * v[2], u[0] * v[1] - u[1] * v[0])


def _dot(u: tuple, v: tuple) -> np.ndarray:
    return u[0] * v[0] + u[1] * v[1] + u[2] * v[2]


def _better_diagonal(points: np.ndarray, quads: np.ndarray, crease: np.ndarray, facing: np.ndarray) -> np.ndarray:
    """True where a quad is better split along 0-2 than along 1-3.

    First no zero-area triangle, then no triangle facing against the summed normals of the
    quad's cells (a quad folded over itself by vertices moved onto a crease has one good
    split), then the diagonal joining two crease vertices, then the larger smallest quality
    ``4 sqrt(3) area / sum of squared sides`` (1 for an equilateral triangle).
    """
    corners = [tuple(points[quads[:, c], a] for a in range(3)) for c in range(4)]

    def minus(i: int, j: int) -> tuple:
        return tuple(corners[i][a] - corners[j][a] for a in range(3))

    e01, e12, e23, e30, e02, e13 = minus(1, 0), minus(2, 1), minus(3, 2), minus(0, 3), minus(2, 0), minus(3, 1)
    s01, s12, s23, s30, s02, s13 = (_dot(e, e) for e in (e01, e12, e23, e30, e02, e13))
    # twice the area vectors of the four triangles, oriented like the quad
    n012, n023 = _cross(e01, e02), _cross(e02, minus(3, 0))
    n013, n123 = _cross(e01, minus(3, 0)), _cross(e12, e13)
    quad_facing = tuple(facing[quads, a].sum(axis=1) for a in range(3))
    scale = 2 * np.sqrt(3)

    def quality(n: tuple, squares: np.ndarray) -> np.ndarray:
        return np.divide(scale * np.sqrt(_dot(n, n)), squares, out=np.zeros_like(squares), where=squares > 0)

    q02 = np.minimum(quality(n012, s01 + s12 + s02), quality(n023, s02 + s23 + s30))
    q13 = np.minimum(quality(n013, s01 + s13 + s30), quality(n123, s12 + s23 + s13))
    good02 = 2 * (q02 > _DEGENERATE_QUALITY) + ((_dot(n012, quad_facing) > 0) & (_dot(n023, quad_facing) > 0))
    good13 = 2 * (q13 > _DEGENERATE_QUALITY) + ((_dot(n013, quad_facing) > 0) & (_dot(n123, quad_facing) > 0))
    crease02 = crease[quads[:, 0]] & crease[quads[:, 2]]
    crease13 = crease[quads[:, 1]] & crease[quads[:, 3]]
    return np.where(good02 != good13, good02 > good13, np.where(crease02 != crease13, crease02, q02 >= q13))
