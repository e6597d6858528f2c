"""One pass over a sampled grid: the active cells with their corner cases, and the crossing edges.

Everything here works on the inside mask ``values < level`` (VTK's tie rule: a node with
``value >= level`` is outside) in z slabs, several slabs at a time on threads. Each slab touches
only a few cache-sized uint8 arrays; the full grid is never copied.

Ids are flat node indices in VTK order (``k*ny*nx + j*nx + i``): a cell is named by its lowest
corner, an edge by its start node and its direction.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..config import config
from ..sdf.core import thread_pool

__all__ = ["GridScan", "scan_grid", "inside_threshold", "AXIS_DIRECTIONS"]

#: unit edge directions (di, dj, dk) along x, y and z
AXIS_DIRECTIONS = ((1, 0, 0), (0, 1, 0), (0, 0, 1))
_SLAB_NODES = 1 << 18


@dataclass
class GridScan:
    """Active cells and crossing edges of one grid at one level.

    Attributes
    ----------
    cells : (C,) int64
        Sorted node ids of the lowest corner of every cell whose corners are not all on one side.
    cases : (C,) uint8
        Corner case of each active cell: bit ``di + 2*dj + 4*dk`` set when that corner is inside.
    edges : list of (E_d,) int64
        For each requested direction, the sorted start-node ids of the edges whose two ends lie on
        different sides.
    shape : (nz, ny, nx)
    """

    cells: np.ndarray
    cases: np.ndarray
    edges: list[np.ndarray]
    shape: tuple[int, int, int]


def inside_threshold(dtype: np.dtype, level: float):
    """The value ``t`` of ``dtype`` with ``value < t`` exactly when ``value < level`` (in float64).

    VTK compares in double precision; rounding ``level`` to float32 could move a node that lies
    between ``level`` and its float32 rounding to the other side.
    """
    threshold = np.dtype(dtype).type(level)
    if float(threshold) < level:
        threshold = np.nextafter(threshold, np.dtype(dtype).type(np.inf))
    return threshold


def _inside_grid(ids: np.ndarray, nx: int, ny: int, di: int, dj: int) -> np.ndarray:
    """Keep ids whose +di, +dj neighbours stay in the same row and layer (flat ops wrap)."""
    keep = np.ones(ids.size, dtype=bool)
    if di:
        keep &= ids % nx < nx - di
    if dj:
        keep &= (ids // nx) % ny < ny - dj
    return ids[keep]


def scan_grid(
    values: np.ndarray,
    level: float,
    directions=AXIS_DIRECTIONS,
    workers: int | None = None,
) -> GridScan:
    """Scan a (nz, ny, nx) array for active cells and crossing edges along ``directions``.

    ``directions`` are edge vectors with components 0 or 1 (axis edges, face and body diagonals).
    Each slab works on flat contiguous views (neighbours are flat offsets); the few entries that
    wrap around a row or layer end are dropped from the (short) lists of hits.
    """
    nz, ny, nx = values.shape
    layer = nx * ny
    thickness = max(1, _SLAB_NODES // layer)
    slabs = [(k0, min(k0 + thickness, nz - 1)) for k0 in range(0, nz - 1, thickness)]
    level_value = inside_threshold(values.dtype, level)

    def run(slab: tuple[int, int]):
        k0, k1 = slab
        base = k0 * layer
        inside = (values[k0 : k1 + 1] < level_value).view(np.uint8).reshape(-1)
        # sums of bits scaled by multiplication: numpy's uint8 shifts are not vectorised
        case = inside[:-1] + inside[1:] * np.uint8(2)
        case = case[:-nx] + case[nx:] * np.uint8(4)
        case = case[:-layer] + case[layer:] * np.uint8(16)
        active = np.flatnonzero(np.less(case - np.uint8(1), np.uint8(254)))
        active = _inside_grid(active, nx, ny, 1, 1)
        cells = active + base
        cases = case[active]
        crossings = []
        for di, dj, dk in directions:
            offset = di + dj * nx + dk * layer
            size = (k1 - k0 + (1 if k1 == nz - 1 and dk == 0 else 0)) * layer
            size = min(size, inside.size - offset)
            crossing = np.flatnonzero(np.not_equal(inside[:size], inside[offset : offset + size]))
            crossings.append(_inside_grid(crossing, nx, ny, di, dj) + base)
        return cells, cases, crossings
    workers = config.resolve_workers(workers)
    if workers == 1 or len(slabs) == 1:
        results = [run(slab) for slab in slabs]
    else:
        results = list(thread_pool(workers).map(run, slabs))
    cells = np.concatenate([r[0] for r in results])
    cases = np.concatenate([r[1] for r in results])
    edges = [np.concatenate([r[2][d] for r in results]) for d in range(len(directions))]
    return GridScan(cells, cases, edges, (nz, ny, nx))
