"""How many tetrahedra a mesh of a part will have, before meshing it.

DistMesh's meshes hold about ``CELLS_PER_H3`` cells per ``h^3`` of volume (measured: a revolved
shaft, 17,760 cells in 17,090 mm^3 at h = 2; a sphere, a box with holes and a gyroid block fall
within 10% of it). For a size field the count is the integral of ``CELLS_PER_H3 / size^3`` over
the part, summed over the nodes of a 48^3 grid, each weighted by the share of its cell inside the
part (``1/2 - value / spacing``, clipped to [0, 1]). Counting only the nodes inside left walls a
few grid cells thick short by up to 18% (a housing with 3 mm walls: 0.817 of its volume, now
1.000); the 14 CAD parts of :mod:`fepre.cad_parts` now come within 1%.
"""

from __future__ import annotations

import numpy as np

__all__ = ["estimated_cells", "CELLS_PER_H3"]

CELLS_PER_H3 = 8.3


def estimated_cells(model, size, h: float, lower: np.ndarray, upper: np.ndarray, absolute: bool,
                    ceiling: float = 0.0) -> float:
    """About how many cells a mesh of ``model`` in the box gets at edge length ``h`` (or ``size``).

    With ``ceiling``, an upper bound (the whole box at the smallest size) is returned instead
    when it is below ``ceiling``: the caller only asks whether the mesh is too big.

    Examples
    --------
    >>> import numpy as np
    >>> from fepre import sdf
    >>> round(estimated_cells(sdf.box(2.0), None, 0.5, -np.ones(3), np.ones(3), False) / 1000, 1)
    0.5
    """
    from .field import SizeField

    smallest = max(float(size.hmin), h) if absolute and isinstance(size, SizeField) else h
    if size is None or isinstance(size, SizeField):
        bound = CELLS_PER_H3 * float(np.prod(upper - lower)) / smallest**3
        if bound <= ceiling:  # the whole box at the smallest size: no need to look closer
            return bound
    counts = 48
    axes = [np.linspace(lower[k], upper[k], counts) for k in range(3)]
    cell = np.prod((upper - lower) / (counts - 1))
    values = model.values_on_axes(*axes, dtype=np.float64)
    share = np.clip(0.5 - values / cell ** (1.0 / 3.0), 0.0, 1.0)  # of each node's cell inside the part
    if not share.any():
        return 0.0
    if size is None:
        return float(CELLS_PER_H3 * share.sum() * cell / h**3)
    z, y, x = np.nonzero(share)
    points = np.stack([axes[0][x], axes[1][y], axes[2][z]], axis=1)
    sizes = np.asarray(size(points), dtype=np.float64)
    if not absolute:
        sizes = h * sizes / sizes.min()
    return float(CELLS_PER_H3 * cell * np.sum(share[z, y, x] * np.maximum(sizes, h) ** -3.0))
