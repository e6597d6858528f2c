"""Sizes at sharp feature curves that face each other closely: a shallow step, a thin rib's top.

Neither ray of :mod:`fepre.sizing.rays` sees a step ``s`` high on a flat face (both rays run
along the face's normal), yet its two edges are ``s`` apart and the mesh needs nodes on both.
For each node of a feature curve, the nearest nodes of the other curves count when the line
to them is across both curves (at more than 60 degrees to each tangent): two edges of one
corner meet at their common end and are not across each other.
"""

from __future__ import annotations

import numpy as np

__all__ = ["feature_sizes", "search"]

#: |cos| between the line joining two curve nodes and each curve's tangent, at most
ACROSS = 0.5
#: neighbours looked at per curve node
NEIGHBOURS = 12
#: two nodes within this many times their distance of the same corner converge at it (curves
#: meeting at 7 degrees or more: nodes at equal distance s are 2 s sin(angle / 2) apart)
CORNER = 8.0


def _tangents(points: np.ndarray, closed: bool) -> np.ndarray:
    if len(points) < 2:
        return np.zeros_like(points)
    if closed:
        forward, backward = np.roll(points, -1, axis=0), np.roll(points, 1, axis=0)
    else:
        forward = np.concatenate([points[1:], points[-1:]])
        backward = np.concatenate([points[:1], points[:-1]])
    tangent = forward - backward
    norm = np.linalg.norm(tangent, axis=1)
    return tangent / np.where(norm > 0, norm, 1.0)[:, None]


def search(model, hmin: float, bounds):
    """The features :func:`feature_sizes` looks at: curves and the crease search at ``hmin / 4``
    (features closer than half the sampling are merged, and a ledge a quarter of hmin wide must
    still show as two curves). The mesher's search at ``h = hmin`` is on the same grid (its
    default spacing ``h / 4``) over the same ``bounds``, so it reuses these creases."""
    from ..features import features

    return features(model, hmin / 4.0, spacing=hmin / 4.0, bounds=bounds, warn=False)


def feature_sizes(model, hmin: float, hmax: float, bounds, found=None) -> tuple[np.ndarray, np.ndarray]:
    """Curve nodes and the distance to the nearest curve across from them (below ``hmax``).

    ``found``: the model's features at ``hmin / 4`` over ``bounds`` (:func:`search`), when
    already found.

    Examples
    --------
    >>> from fepre import sdf
    >>> step = sdf.box((4.0, 4.0, 1.0)) | sdf.box((2.0, 4.0, 1.2), center=(1.0, 0.0, 0.1))
    >>> points, sizes = feature_sizes(step, 0.25, 2.0, ((-2.5, -2.5, -1.0), (2.5, 2.5, 1.0)))
    >>> round(float(sizes.min()), 2)   # the step is 0.2 high
    0.2
    """
    from scipy.spatial import cKDTree

    found = search(model, hmin, bounds) if found is None else found
    if len(found.curves) < 2:
        return np.zeros((0, 3)), np.zeros(0)
    points = np.concatenate([c.points for c in found.curves])
    tangents = np.concatenate([_tangents(c.points, c.closed) for c in found.curves])
    curve = np.repeat(np.arange(len(found.curves)), [len(c.points) for c in found.curves])
    nearest = np.full(len(points), np.inf)
    corner_distance, corner = np.full(len(points), np.inf), np.full(len(points), -1)
    if len(found.corners):
        corner_distance, corner = cKDTree(found.corners).query(points)
    for index in range(len(found.curves)):  # a tree of the other curves' nodes for each curve
        mine = np.flatnonzero(curve == index)
        others = np.flatnonzero(curve != index)
        k = min(NEIGHBOURS, others.size)
        distance, neighbour = cKDTree(points[others]).query(points[mine], k=k, distance_upper_bound=hmax)
        distance, neighbour = distance.reshape(len(mine), k), neighbour.reshape(len(mine), k)
        found_mask = np.isfinite(distance)
        target = others[np.where(found_mask, neighbour, 0)]
        line = points[target] - points[mine][:, None, :]
        length = np.linalg.norm(line, axis=2)
        unit = line / np.where(length > 0, length, 1.0)[..., None]
        across = (np.abs(np.einsum("nkj,nj->nk", unit, tangents[mine])) < ACROSS) & (
            np.abs(np.einsum("nkj,nkj->nk", unit, tangents[target])) < ACROSS
        )
        converging = ((corner[mine][:, None] == corner[target]) & (corner[target] >= 0)
                      & (np.maximum(corner_distance[mine][:, None], corner_distance[target]) <= CORNER * length))
        counted = found_mask & across & (length > 0) & ~converging
        nearest[mine] = np.where(counted, length, np.inf).min(axis=1)
    keep = np.isfinite(nearest)
    return points[keep], nearest[keep]
