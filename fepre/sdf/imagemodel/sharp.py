"""Sharp edges of a label image's surface where two large voxel-aligned planes meet.

A label boundary is made of voxel faces. Where a long run of them is flat (the face of a
machined block, the border of a SIMP domain) and meets another flat run at a straight line, the
segmented part has a sharp edge there; the smoothed indicators of :mod:`.multilabel` round it by
about half a voxel, and DistMesh, which sees no crease, then leaves cells of 5 degrees along it
at h of 4 voxels. Here the surface-nets cells are sorted by the axes of their crossed edges: a
cell whose crossings are all along one axis lies on a plane, and a connected set of such cells
in one slab of the grid with at least ``MIN_INNER_CELLS`` cells inside it (all four in-slab
neighbours in the set: a run at least 3 voxels wide) is a large plane. A cell crossed along two
(three) axes next to large planes of those axes is an edge (corner) cell: its vertex is put on
the planes' line (point), and the cells of the planes that meet at such an edge are put on their
plane. Those vertices are held while the rest relax, so the edges stay sharp and the planes
exactly flat, and every vertex carries the planes it lies on (for the models' patches). The
steps of a staircase are not planes: a run with a larger one in a neighbouring slab beside it
(a terrace), or with steps beside it on opposite sides (a crest: the pole of a ball, the widest
terrace of a cylinder's side, every terrace of a face at an angle to the axes). Every other large
run is held flat, whether it meets another or not (a cylinder's cap, its rim rounded alike all
round: held sharp where the widest terraces met it, the rim jumped by 0.2 voxel 5 degrees off
the axes, and cells there were of 26 degrees).
"""

from __future__ import annotations

import numpy as np
from scipy import sparse
from scipy.sparse import csgraph

__all__ = ["MIN_INNER_CELLS", "sharp_planes"]

#: the fewest inner cells (all four in-slab neighbours on it) of a connected run of one slab's
#: cells that make a plane: a 4 x 4 voxel face has 4
MIN_INNER_CELLS = 4


def _neighbours(used: np.ndarray, coords: np.ndarray, cells: tuple[int, ...]) -> dict:
    """(axis, step) -> index into ``used`` of each cell's neighbour that way, or -1."""
    shape = np.array(cells)
    found = {}
    for axis in range(3):
        for step in (-1, 1):
            other = coords.copy()
            other[:, axis] += step
            inside = (other[:, axis] >= 0) & (other[:, axis] < shape[axis])
            flat = np.ravel_multi_index(tuple(np.clip(other, 0, shape - 1).T), cells)
            position = np.minimum(np.searchsorted(used, flat), len(used) - 1)
            found[axis, step] = np.where(inside & (used[position] == flat), position, -1)
    return found


#: in-plane reach (cells) within which two planes of neighbouring slabs are steps of one staircase
TERRACE_REACH = 2


def _terraces(k: int, big: np.ndarray, component: np.ndarray, coords: np.ndarray, used: np.ndarray,
              cells: tuple[int, ...]) -> np.ndarray:
    """(components,) True for the planes of axis ``k`` that are a step of a staircase: a larger
    plane lies in a neighbouring slab, within ``TERRACE_REACH`` cells in-plane, beside it (the
    two do not overlap, as the faces of a plate one voxel thick do). A voxelised curved surface
    is such a staircase: at 256^3 the terraces of a cylinder of 32 voxels next to its widest one
    are 3 voxels wide, large planes that met its flat caps, so they were held flat a voxel
    below their neighbour: a kink of 26 degrees, and the cells filling it were of 22 degrees."""
    rows = np.flatnonzero(big)
    count = int(component.max()) + 1
    sizes = np.bincount(component[rows], minlength=count)
    shape = np.array(cells)
    pairs, overlaps, sides = [], [], []
    span = range(-TERRACE_REACH, TERRACE_REACH + 1)
    for step in (-1, 1):
        for du in span:
            for dv in span:
                other = coords[rows].copy()
                other[:, k] += step
                other[:, (k + 1) % 3] += du
                other[:, (k + 2) % 3] += dv
                inside = np.all((other >= 0) & (other < shape), axis=1)
                flat = np.ravel_multi_index(tuple(np.clip(other, 0, shape - 1).T), cells)
                position = np.minimum(np.searchsorted(used, flat), len(used) - 1)
                hit = inside & (used[position] == flat)
                hit[hit] = big[position[hit]]
                pairs.append(np.column_stack([component[rows[hit]], component[position[hit]]]))
                overlaps.append(np.full(int(hit.sum()), du == 0 and dv == 0))
                # the in-plane side the step lies on: bit 0/1 for -u/+u, 2/3 for -v/+v
                side = (1 << 0 if du < 0 else 0) | (1 << 1 if du > 0 else 0) | (1 << 2 if dv < 0 else 0) | (1 << 3 if dv > 0 else 0)
                sides.append(np.full(int(hit.sum()), side, dtype=np.int64))
    pairs, overlaps, sides = np.concatenate(pairs), np.concatenate(overlaps), np.concatenate(sides)
    terrace = np.zeros(count, dtype=bool)
    if len(pairs) == 0:
        return terrace
    keys, inverse = np.unique(pairs, axis=0, return_inverse=True)
    overlapping = np.zeros(len(keys), dtype=bool)
    np.logical_or.at(overlapping, inverse.reshape(-1), overlaps)
    beside = keys[~overlapping & (sizes[keys[:, 1]] > sizes[keys[:, 0]])]
    terrace[beside[:, 0]] = True
    # a crest: steps beside it on opposite sides (the widest terrace of a cylinder's side, any
    # terrace of a face at an angle to the axes, the pole of a ball)
    apart = ~overlapping[inverse.reshape(-1)]
    reach = np.zeros(count, dtype=np.int64)
    np.bitwise_or.at(reach, pairs[apart, 0], sides[apart])
    terrace |= ((reach & 3) == 3) | ((reach & 12) == 12)
    return terrace


def _planes(axes: np.ndarray, coords: np.ndarray, near: dict, used: np.ndarray,
            cells: tuple[int, ...]) -> tuple[np.ndarray, np.ndarray]:
    """Membership (U, 3) of the large planes (-1: none) and each plane's coordinate."""
    member = np.full((len(axes), 3), -1, dtype=np.int64)
    positions = []
    for k in range(3):
        face = axes == (1 << k)
        rows, columns = [], []
        for j in range(3):
            if j == k:
                continue
            for step in (-1, 1):
                other = near[j, step]
                link = face & (other >= 0)
                link[link] = face[other[link]]
                rows.append(np.flatnonzero(link))
                columns.append(other[link])
        rows, columns = np.concatenate(rows), np.concatenate(columns)
        graph = sparse.coo_matrix((np.ones(len(rows)), (rows, columns)), shape=(len(axes), len(axes)))
        _, component = csgraph.connected_components(graph.tocsr(), directed=False)
        # a plane is wide: cells whose four in-slab neighbours are on it too (the terraces and
        # risers of a voxelised cylinder's side are long strips one or two voxels wide: as
        # planes they made its side a staircase of sharp edges)
        inner = face.copy()
        for j in range(3):
            if j != k:
                for step in (-1, 1):
                    other = near[j, step]
                    inner &= (other >= 0) & face[np.maximum(other, 0)]
        sizes = np.bincount(component[inner], minlength=component.max() + 1)
        big = face & (sizes[component] >= MIN_INNER_CELLS)
        if big.any():
            big &= ~_terraces(k, big, component, coords, used, cells)[component]
        if not big.any():
            continue
        kept, local = np.unique(component[big], return_inverse=True)
        # a label boundary is a run of voxel faces: the plane halfway between the voxel centres
        # on either side, in the middle of the cells' slab (the crossings of the smoothed
        # indicators are there too, but for those within a voxel or two of the plane's edges)
        slab = np.zeros(len(kept))
        slab[local] = coords[big, k]
        member[big, k] = sum(len(p) for p in positions) + local
        positions.append(slab + 0.5)
    return member, (np.concatenate(positions) if positions else np.zeros(0))


def sharp_planes(used: np.ndarray, axes: np.ndarray, raw: np.ndarray, cells: tuple[int, ...]):
    """Snap the edges and corners between large voxel-aligned planes (see the module).

    Parameters
    ----------
    used : (U,) int
        Flat indices (sorted) of the grid cells that hold a surface vertex.
    axes : (U,) uint8
        Bit ``k`` set where the cell has a crossed edge along axis ``k``.
    raw : (U, 3) float
        The cells' surface-nets vertices in grid coordinates.
    cells : tuple
        Shape of the cell grid.

    Returns
    -------
    points : (U, 3) float
        The vertices, those on sharp edges and their planes moved onto them.
    fixed : (U,) bool
        The moved vertices (to hold while relaxing).
    member : (U, 3) int
        Plane (a number per plane) each vertex lies on along each axis, -1 for none.

    Examples
    --------
    >>> import numpy as np
    >>> used = np.arange(3)
    >>> points, fixed, member = sharp_planes(used, np.array([1, 1, 3], np.uint8), np.zeros((3, 3)), (3, 1, 1))
    >>> int(fixed.sum())  # no plane 3 voxels wide
    0
    """
    if len(used) == 0:
        return raw.copy(), np.zeros(0, dtype=bool), np.full((0, 3), -1, dtype=np.int64)
    coords = np.column_stack(np.unravel_index(used, cells))
    near = _neighbours(used, coords, cells)
    member, positions = _planes(axes, coords, near, used, cells)
    bits = np.stack([(axes >> k) & 1 for k in range(3)], axis=1).astype(bool)
    count = bits.sum(axis=1)
    snapped = np.zeros(len(axes), dtype=bool)
    for order in (2, 3):  # edges from the planes' cells, then corners from the edges'
        chosen = count == order
        found = np.full((len(axes), 3), -1, dtype=np.int64)
        for k in range(3):
            for j in range(3):
                if j == k:
                    continue
                for step in (-1, 1):
                    other = near[j, step]
                    plane = np.where(other >= 0, member[np.maximum(other, 0), k], -1)
                    found[:, k] = np.maximum(found[:, k], np.where(chosen & bits[:, k], plane, -1))
        ok = chosen & ((found >= 0) | ~bits).all(axis=1)
        member[ok] = np.where(bits[ok], found[ok], -1)
        snapped |= ok
    points = raw.copy()
    on = member >= 0
    points[on] = positions[member[on]]
    return points, on.any(axis=1), member
