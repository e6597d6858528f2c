"""Graded sizes on a grid: the smallest of ``h_s + (gradation - 1) * |x - x_s|`` over the seeds.

Each seed (a surface point with the size it needs) raises a cone of slope ``gradation - 1``;
the field is their lower envelope, so neighbouring elements differ in size by at most about the
factor ``gradation``. Seeds are grouped into levels of sizes a factor ``LEVEL_RATIO`` apart
(rounded down, so no size comes out larger than asked), and each level's cones come from one
exact Euclidean distance transform of the grid (``scipy.ndimage.distance_transform_edt``).
"""

from __future__ import annotations

import numpy as np

__all__ = ["graded_sizes"]

#: sizes of neighbouring levels differ by this factor
LEVEL_RATIO = 1.1


def graded_sizes(shape: tuple[int, int, int], spacing: np.ndarray, seed_nodes: np.ndarray, seed_sizes: np.ndarray,
                 slope: float, largest: float) -> np.ndarray:
    """(nz, ny, nx) sizes: ``min(largest, min over seeds of size + slope * distance)``.

    ``seed_nodes`` are flat node ids (x fastest), ``spacing`` is (dx, dy, dz).

    Examples
    --------
    >>> import numpy as np
    >>> sizes = graded_sizes((1, 1, 11), np.ones(3), np.array([0]), np.array([1.0]), 0.3, 2.0)
    >>> np.round(sizes.ravel(), 2).tolist()
    [1.0, 1.3, 1.6, 1.9, 2.0, 2.0, 2.0, 2.0, 2.0, 2.0, 2.0]
    """
    from scipy.ndimage import distance_transform_edt

    values = np.full(shape, float(largest))
    if seed_nodes.size == 0:
        return values
    smallest = float(seed_sizes.min())
    level = np.floor(np.log(seed_sizes / smallest) / np.log(LEVEL_RATIO) + 1e-9).astype(np.int64)
    sampling = tuple(float(s) for s in np.asarray(spacing)[::-1])
    for k in np.unique(level):
        size = smallest * LEVEL_RATIO ** int(k)
        if size >= largest:
            break
        free = np.ones(shape, dtype=bool)
        free.reshape(-1)[seed_nodes[level == k]] = False
        reach = (largest - size) / slope  # beyond this distance the cone is above ``largest``
        distance = distance_transform_edt(free, sampling=sampling)
        near = distance < reach
        np.minimum(values, np.where(near, size + slope * distance, largest), out=values)
    return values
