"""Initial points for a size field: a lattice per octave of sizes, only where those sizes are.

One lattice at the smallest size over the whole box holds ``(hmax / hmin)^3`` times the points
the mesh needs (a part with one thin wall and a bulky core: billions). Here sizes are split into
octaves ``[h 2^k, h 2^(k+1))``; octave ``k`` lays a lattice of spacing ``h 2^k`` over the blocks
of the box where the field has sizes of that octave (blocks of ``BLOCK`` lattice cells, found
from the size field's grid), and keeps each of its points whose own size is in the octave with
probability ``(h 2^k / size)^3`` (Persson's rejection within an octave, so the kept density is
``1 / size^3`` everywhere). Every octave's lattice is anchored at the box's corner, so blocks
tile without seams.
"""

from __future__ import annotations

import numpy as np

__all__ = ["graded_lattice"]

#: lattice cells along a block's side
BLOCK = 6


def _per_block(values: np.ndarray, axes: list[np.ndarray], lower: np.ndarray, side: float, count: np.ndarray,
               reduce: np.ufunc, empty: float) -> np.ndarray:
    """``reduce`` (min or max) of the (nz, ny, nx) node ``values`` over each block, axis by axis
    (blocks are boxes, so three ``reduceat`` passes); ``empty`` where a block holds no node."""
    result = values
    for axis, (coords, n) in enumerate(zip(axes, count)):
        block = np.clip(np.floor((coords - lower[axis]) / side).astype(np.int64), 0, n - 1)
        present, starts = np.unique(block, return_index=True)
        reduced = reduce.reduceat(result, starts, axis=2 - axis)
        shape = list(result.shape)
        shape[2 - axis] = int(n)
        full = np.full(shape, empty)
        index = [slice(None)] * 3
        index[2 - axis] = present
        full[tuple(index)] = reduced
        result = full
    return result.transpose(2, 1, 0).reshape(-1)  # x slowest, as np.ravel_multi_index over (cx, cy, cz)


def _block_ranges(field, low: np.ndarray, high: np.ndarray, lower: np.ndarray, side: float,
                  count: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Smallest and largest size of the field over each block; ``low``/``high`` are the node
    values filtered over a node's neighbours (a margin for the interpolation)."""
    axes = [field.origin[k] + field.spacing[k] * np.arange(n) for k, n in enumerate(field.shape)]
    smallest = _per_block(low, axes, lower, side, count, np.minimum, np.inf)
    largest = _per_block(high, axes, lower, side, count, np.maximum, -np.inf)
    # blocks holding no field node (blocks smaller than the field's spacing) take their centre's size
    empty = ~np.isfinite(smallest)
    if empty.any():
        centres = lower + (np.stack(np.unravel_index(np.flatnonzero(empty), tuple(count)), axis=1) + 0.5) * side
        at = field(centres)
        smallest[empty] = at
        largest[empty] = at
    return smallest, largest


def graded_lattice(field, lower: np.ndarray, upper: np.ndarray, h: float, cell: float,
                   basis: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Lattice points over the box, each octave's where the field has sizes of that octave.

    Returns the points, the size of each one's octave (its lattice spacing over ``cell``) and
    the field's size there; the caller keeps a point with probability ``(octave / size)^3``.
    ``cell`` is the lattice constant per unit size and ``basis`` the lattice's points per cell
    (as :func:`fepre.distmesh.initial_points.lattice`).
    """
    from scipy.ndimage import maximum_filter, minimum_filter

    extent = upper - lower
    low = minimum_filter(field.values, size=3, mode="nearest")
    high = maximum_filter(field.values, size=3, mode="nearest")
    top = max(float(field.hmax), h)
    octaves = max(1, int(np.ceil(np.log2(top / h) + 1e-9)) + 1)
    steps = np.arange(BLOCK)
    local_grid = np.stack(np.meshgrid(steps, steps, steps, indexing="ij"), axis=-1).reshape(-1, 3)
    chunks, octave_sizes, sizes = [], [], []
    for k in range(octaves):
        size = h * 2.0**k
        a = cell * size
        side = BLOCK * a
        count = np.maximum(np.ceil(extent / side - 1e-9).astype(np.int64), 1)
        smallest, largest = _block_ranges(field, low, high, lower, side, count)
        last = k == octaves - 1
        # blocks with sizes of this octave: not all below it (the first takes everything
        # smaller), not all above it (the last takes everything larger)
        wanted = np.ones(smallest.size, bool)
        if k > 0:
            wanted &= largest >= size / 1.05
        if not last:
            wanted &= smallest < 2.0 * size * 1.05
        active = np.flatnonzero(wanted)
        if active.size == 0:
            continue
        corner = lower + np.stack(np.unravel_index(active, tuple(count)), axis=1) * side
        local = (local_grid[None, :, :] + basis[:, None, :]).reshape(-1, 3) * a
        points = (corner[:, None, :] + local[None, :, :]).reshape(-1, 3)
        points = points[np.all(points <= upper + 1e-9 * a, axis=1)]
        at = field(points)
        mine = np.ones(len(points), bool)
        if k > 0:
            mine &= at >= size
        if not last:
            mine &= at < 2.0 * size
        chunks.append(points[mine])
        octave_sizes.append(np.full(int(mine.sum()), size))
        sizes.append(at[mine])
    if not chunks:
        return np.zeros((0, 3)), np.zeros(0), np.zeros(0)
    return np.concatenate(chunks), np.concatenate(octave_sizes), np.concatenate(sizes)
