"""Face counts and areas of the named boundary sets, as a solver sees the faces.

A linear face's area is its triangle's. A quadratic face (a 6-node triangle, ``order=2``, whose
midside nodes may lie on a curved surface) is integrated over its curved shape by a 12-point,
degree-6 rule on the reference triangle: the area a pressure on that face acts on in CalculiX.
The areas are what fepre prints for each set (``fepre mesh``, ``fepre info``) and stores in the
tagged grid's field data ``"boundary_face_counts"`` and ``"boundary_areas"`` (one value per
``"boundary_names"`` entry; :func:`fepre.export.grid.grid_set_areas` reads them from a
tagged grid's faces).
"""

from __future__ import annotations

from typing import Any

import numpy as np

__all__ = ["face_areas", "set_areas", "AREA_FIELD", "COUNT_FIELD"]

AREA_FIELD = "boundary_areas"
COUNT_FIELD = "boundary_face_counts"

# Dunavant's 12-point rule, exact for polynomials of degree 6: (L1, L2, L3 orbits, weight);
# weights sum to 1 (multiplied by the reference area 1/2 below).
_ORBITS = (
    ((0.873821971016996, 0.063089014491502, 0.063089014491502), 0.050844906370207),
    ((0.501426509658179, 0.249286745170910, 0.249286745170910), 0.116786275726379),
    ((0.636502499121399, 0.310352451033785, 0.053145049844816), 0.082851075618374),
)


def _rule() -> tuple[np.ndarray, np.ndarray]:
    points, weights = [], []
    for (a, b, c), weight in _ORBITS:
        orbit = {(a, b, c), (b, c, a), (c, a, b), (a, c, b), (c, b, a), (b, a, c)}
        points.extend(sorted(orbit))
        weights.extend([weight] * len(orbit))
    return np.array(points), np.array(weights)


_POINTS, _WEIGHTS = _rule()


def face_areas(points: np.ndarray, faces: np.ndarray) -> np.ndarray:
    """Area of each face: (K, 3) triangles, or (K, 6) quadratic triangles (corners a, b, c, then the
    midside nodes of ab, bc, ca) integrated over their curved shape.

    Examples
    --------
    >>> import numpy as np
    >>> square = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0.0]])
    >>> face_areas(square, np.array([[0, 1, 2]])).tolist()
    [0.5]
    >>> # midside node of bc on the unit circle: the triangle plus a parabolic segment (the quarter
    >>> # disc it approximates is pi/4 = 0.785)
    >>> arc = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0.5, 0, 0], [2**-0.5, 2**-0.5, 0], [0, 0.5, 0]])
    >>> round(float(face_areas(arc, np.array([[0, 1, 2, 3, 4, 5]]))[0]), 3)
    0.776
    """
    points = np.asarray(points, dtype=np.float64)
    faces = np.asarray(faces, dtype=np.int64)
    corners = points[faces[:, :3]]
    if faces.shape[1] == 3:
        return 0.5 * np.linalg.norm(np.cross(corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0]), axis=1)
    nodes = points[faces]  # (K, 6, 3)
    total = np.zeros(len(faces))
    for (l1, l2, l3), weight in zip(_POINTS, _WEIGHTS):
        # d/d(xi) with L2 = xi, L3 = eta, L1 = 1 - xi - eta; nodes a, b, c, ab, bc, ca
        d_xi = np.array([1 - 4 * l1, 4 * l2 - 1, 0.0, 4 * (l1 - l2), 4 * l3, -4 * l3])
        d_eta = np.array([1 - 4 * l1, 0.0, 4 * l3 - 1, -4 * l2, 4 * l2, 4 * (l1 - l3)])
        tangent_xi = np.einsum("n,knj->kj", d_xi, nodes)
        tangent_eta = np.einsum("n,knj->kj", d_eta, nodes)
        total += weight * np.linalg.norm(np.cross(tangent_xi, tangent_eta), axis=1)
    return 0.5 * total


def set_areas(points: np.ndarray, faces: np.ndarray, set_ids: np.ndarray, n_sets: int) -> tuple[np.ndarray, np.ndarray]:
    """``(face counts, areas)`` of sets ``0 .. n_sets - 1`` given each face's set.

    Examples
    --------
    >>> import numpy as np
    >>> points = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1.0]])
    >>> counts, areas = set_areas(points, np.array([[0, 2, 1], [0, 1, 3]]), np.array([0, 1]), 3)
    >>> counts.tolist(), areas.tolist()
    ([1, 1, 0], [0.5, 0.5, 0.0])
    """
    set_ids = np.asarray(set_ids, dtype=np.int64)
    counts = np.bincount(set_ids, minlength=n_sets)[:n_sets]
    areas = np.bincount(set_ids, weights=face_areas(points, faces), minlength=n_sets)[:n_sets]
    return counts.astype(np.int64), areas.astype(np.float64)
