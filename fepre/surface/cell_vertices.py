"""Where each dual-contouring vertex may go: in its cell, on its crease, not on a neighbour's point.

A cell's QEF minimiser (:mod:`fepre.surface.qef`) is only a good vertex when it lies in the cell.
These steps keep it there without leaving the surface:

* a corner found outside its cell demotes the cell to its crease (and a crease missing the cell
  to its face), and the corner goes to the cell that holds it: that cell gets the finder's
  samples when its own planes pass through the corner (:func:`donated_corners`), or, when no
  vertex can sit there (a corner tip in a cell without an inside node), the nearest finder keeps
  it up to half a cell outside its box (:func:`widened_for_tips`);
* a crease vertex slides along its crease into the cell, every vertex is clamped to the cell
  grown by a small margin (:func:`keep_in_cells`);
* where a cell's crossings all sit at one grid node or along one grid line (the surface passing
  through nodes), its vertex moves half way to the cell centre in the free directions, so that
  neighbouring cells do not share a point and give zero-area triangles (:func:`unpinch`).

Cells are the active cells of :mod:`fepre.surface.dual_cells`; boxes are per-cell ``(low, high)``
corner arrays; ``rows_cell``/``rows_crossing`` list each cell's Hermite samples, sorted by cell.
"""

from __future__ import annotations

import numpy as np

from .dual_cells import DualCells
from .hermite import Hermite
from .qef import QEF, incidence, sample_spread

__all__ = ["solve_in_cells", "keep_in_cells", "donated_corners", "widened_for_tips", "unpinch"]

#: a corner found by a neighbour is given to the cell holding it when that cell's own planes
#: pass within this many cells of it
_DONATION = 0.05
#: a corner in a cell without a vertex is kept by a neighbour up to this many cells outside it
_TIP_REACH = 0.5
#: crossings of one cell all within this many cells of each other count as one point
_PINCH = 1e-3


def crease_interval(
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


def solve_in_cells(
    qef: QEF, truncation: float, low: np.ndarray, high: np.ndarray
) -> tuple[np.ndarray, np.ndarray, np.ndarray, tuple[np.ndarray, np.ndarray]]:
    """Solve, then drop a rank where the solution cannot lie in its cell (box ``low``-``high``).

    A cell next to a corner may see all three faces; their corner lies in another cell, and
    clamping it into this one would put the vertex off the surface. Such a cell is solved again
    with two eigenvalues (the crease nearest its mass point), and a crease missing the box with
    one (the face). Returns points, ranks, free projectors and the corners found outside their
    cells (cell indices and points).

    Examples
    --------
    >>> import numpy as np
    >>> from fepre.surface.qef import accumulate_qef
    >>> # three faces of a corner at (1.2, 0.5, 0.5), seen from the unit cell [0, 1]^3
    >>> points = np.array([[1.2, 0.2, 0.2], [0.6, 0.5, 0.3], [0.9, 0.5, 0.2], [0.6, 0.3, 0.5], [0.9, 0.2, 0.5]])
    >>> normals = np.array([[1.0, 0, 0], [0, 1, 0], [0, 1, 0], [0, 0, 1], [0, 0, 1]])
    >>> qef = accumulate_qef(np.zeros(5, dtype=np.int64), points, normals, np.full((1, 3), 0.5))
    >>> x, rank, _, (finder, corner) = solve_in_cells(qef, 0.1, np.zeros((1, 3)), np.ones((1, 3)))
    >>> rank.tolist(), corner.round(9).tolist(), x.round(9).tolist()  # the crease along x instead
    ([2], [[1.2, 0.5, 0.5]], [[0.84, 0.5, 0.5]])
    """
    points, rank, free = qef.solve(truncation)
    corner = np.flatnonzero(rank == 3)
    away = corner[np.any((points[corner] < low[corner]) | (points[corner] > high[corner]), axis=1)]
    corners = (away, points[away].copy())
    if away.size:
        points[away], rank[away], free[away] = qef.subset(away).solve(truncation, max_rank=2)
    crease = np.flatnonzero(rank == 2)
    if crease.size:
        _, enter, leave = crease_interval(points[crease], free[crease], low[crease], high[crease])
        away = crease[enter > leave]
        if away.size:
            points[away], rank[away], free[away] = qef.subset(away).solve(truncation, max_rank=1)
    return points, rank, free, corners


def keep_in_cells(
    points: np.ndarray, rank: np.ndarray, free: np.ndarray, low: np.ndarray, high: np.ndarray
) -> np.ndarray:
    """Slide crease vertices along their crease into the box, then clamp every vertex to it.

    Examples
    --------
    >>> import numpy as np
    >>> along_x = np.diag([1.0, 0.0, 0.0])[None]  # a crease along x through (2, 0.5, 0.5)
    >>> keep_in_cells(np.array([[2.0, 0.5, 0.5]]), np.array([2]), along_x, np.zeros((1, 3)), np.ones((1, 3))).tolist()
    [[1.0, 0.5, 0.5]]
    """
    points = points.copy()
    crease = np.flatnonzero(rank == 2)
    if crease.size:
        u, enter, leave = crease_interval(points[crease], free[crease], low[crease], high[crease])
        meets = enter <= leave
        shift = np.clip(0.0, enter, leave)
        points[crease[meets]] += shift[meets, None] * u[meets]
    return np.clip(points, low, high)


def donated_corners(
    corners: tuple[np.ndarray, np.ndarray],
    rank: np.ndarray,
    rows_cell: np.ndarray,
    rows_crossing: np.ndarray,
    hermite: Hermite,
    dual: DualCells,
    origin: np.ndarray,
    spacing: np.ndarray,
    shape: tuple[int, int, int],
    first_node: np.ndarray = np.zeros(3, dtype=np.int64),
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
    ijk = np.floor((point - origin) / spacing).astype(np.int64) - first_node
    inside_grid = np.all((ijk >= 0) & (ijk < np.array([nx - 1, ny - 1, nz - 1])), axis=1)
    ids = ijk @ np.array([1, nx, nx * ny])
    cells = dual.vertex_grid_cell
    target = np.minimum(np.searchsorted(cells, ids), dual.n_cells - 1)
    usable = inside_grid & (cells[target] == ids) & (rank[target] < 3)
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


def widened_for_tips(
    corners: tuple[np.ndarray, np.ndarray],
    dual: DualCells,
    origin: np.ndarray,
    spacing: np.ndarray,
    shape: tuple[int, int, int],
    box: tuple[np.ndarray, np.ndarray],
    first_node: np.ndarray = np.zeros(3, dtype=np.int64),
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
    ijk = np.floor((point - origin) / spacing).astype(np.int64) - first_node
    ijk = np.clip(ijk, 0, np.array([nx - 2, ny - 2, nz - 2]))
    ids = ijk @ np.array([1, nx, nx * ny])
    cells = dual.vertex_grid_cell
    where = np.minimum(np.searchsorted(cells, ids), dual.n_cells - 1)
    low, high = box
    gap = np.maximum(np.maximum(low[donor] - point, point - high[donor]), 0.0) / spacing
    tip = (cells[where] != ids) & (gap.max(axis=1) < _TIP_REACH)
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


def unpinch(
    points: np.ndarray,
    free: np.ndarray,
    qef: QEF,
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
    off_count = incidence(rows_cell, rows_crossing, count, off_node.size) @ off_node.astype(float)
    candidates = np.flatnonzero(off_count == 0)
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
