"""Shape of candidate tetrahedra: signed volume, smallest dihedral angle, radius ratio, vectorised.

The quality stage evaluates thousands of candidate tetrahedra (moved vertices, flipped
configurations) per round. It needs only the orientation, the smallest dihedral angle and the
radius ratio of each, so these kernels compute just those from stacked corner coordinates; the
full set of reported metrics comes from :mod:`fepre.quality`.

The dihedral extremes and the radius ratio come from one compiled pass over the cells
(:func:`fepre._cell_kernels.shape_extremes`, bit-identical to the array form it replaced and
3.3 times faster), and so do the ideal vertex positions
(:func:`fepre._cell_kernels.ideal_positions`, bit-identical to the array form, which ran over
blocks of 8192 cells to keep its temporaries in the CPU cache; the relaxation's 2.6M cells:
0.23 s a call in blocks, on one core).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

__all__ = [
    "signed_volume",
    "min_dihedral",
    "tet_min_dihedral",
    "radius_ratio",
    "shape_measures",
    "dihedral_extremes",
    "ShapeTargets",
    "ideal_vertex_positions",
]

#: Height of a regular tetrahedron over its base, per unit edge length.
REGULAR_HEIGHT = float(np.sqrt(2.0 / 3.0))
#: Orientation below this fraction of (mean edge length)^3 counts as flat (invalid).
FLAT_VOLUME = 1e-9


def signed_volume(corners: np.ndarray) -> np.ndarray:
    """Signed volume of tetrahedra given as (..., 4, 3) corners; positive in VTK's convention.

    Examples
    --------
    >>> import numpy as np
    >>> unit = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1.0]])
    >>> float(signed_volume(unit))
    0.16666666666666666
    """
    a = corners[..., 0, :]
    u = corners[..., 1, :] - a
    v = corners[..., 2, :] - a
    w = corners[..., 3, :] - a
    return (
        u[..., 0] * (v[..., 1] * w[..., 2] - v[..., 2] * w[..., 1])
        + u[..., 1] * (v[..., 2] * w[..., 0] - v[..., 0] * w[..., 2])
        + u[..., 2] * (v[..., 0] * w[..., 1] - v[..., 1] * w[..., 0])
    ) / 6.0


def _columns(corners: np.ndarray) -> list[list[np.ndarray]]:
    """Corner coordinates as 4 x 3 contiguous 1D arrays (flattened over leading axes)."""
    flat = corners.reshape(-1, 12).T.copy()  # (12, K): row 3*i + k is corner i, axis k
    return [[flat[3 * i + k] for k in range(3)] for i in range(4)]


def _cross(u, v):
    return (u[1] * v[2] - u[2] * v[1], u[2] * v[0] - u[0] * v[2], u[0] * v[1] - u[1] * v[0])


def _dot(u, v):
    return u[0] * v[0] + u[1] * v[1] + u[2] * v[2]


def _sub(u, v):
    return (u[0] - v[0], u[1] - v[1], u[2] - v[2])


def min_dihedral(corners: np.ndarray) -> np.ndarray:
    """Smallest dihedral angle in degrees of tetrahedra given as (..., 4, 3) corners.

    A tetrahedron that is inverted or flat (volume below ``1e-9`` times its mean edge length
    cubed) gets ``-1``, so that any valid shape compares better than any invalid one.

    Examples
    --------
    >>> import numpy as np
    >>> regular = np.array([[1, 1, 1], [-1, 1, -1], [1, -1, -1], [-1, -1, 1.0]])
    >>> round(float(min_dihedral(regular)), 2)
    70.53
    """
    return dihedral_extremes(corners)[0]


def tet_min_dihedral(points: np.ndarray, tets: np.ndarray) -> np.ndarray:
    """:func:`min_dihedral` of the tetrahedra ``tets`` (M, 4) over ``points`` (N, 3)."""
    return min_dihedral(points[tets])


def shape_measures(corners: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Smallest dihedral angle (degrees) and radius ratio of tetrahedra given as (..., 4, 3) corners.

    The two share their edge vectors, face normals and volume, so this costs little more than
    :func:`min_dihedral` alone. Inverted and flat cells (as in :func:`min_dihedral`) get ``-1``
    for both.

    Examples
    --------
    >>> import numpy as np
    >>> regular = np.array([[1, 1, 1], [-1, 1, -1], [1, -1, -1], [-1, -1, 1.0]])
    >>> angle, ratio = shape_measures(regular)
    >>> round(float(angle), 2), round(float(ratio), 12)
    (70.53, 1.0)
    """
    smallest, _, ratio = dihedral_extremes(corners)
    return smallest, ratio


def _extremes(corners: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Smallest and largest dihedral angle (degrees) and radius ratio of (K, 4, 3) corners; -1
    for all three where the cell is inverted or flat (one compiled pass, :mod:`fepre._cell_kernels`)."""
    from .._cell_kernels import shape_extremes

    return shape_extremes(corners, FLAT_VOLUME)


def dihedral_extremes(corners: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Smallest and largest dihedral angle (degrees) and radius ratio of (..., 4, 3) corners.

    All three are ``-1`` for inverted and flat cells (as in :func:`min_dihedral`).

    Examples
    --------
    >>> import numpy as np
    >>> right = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1.0]])
    >>> [round(float(x), 2) for x in dihedral_extremes(right)]
    [54.74, 90.0, 0.73]
    """
    corners = np.asarray(corners, dtype=np.float64)
    return tuple(column.reshape(corners.shape[:-2]) for column in _extremes(corners))


@dataclass(frozen=True)
class ShapeTargets:
    """The quality stage's targets, and the one score that measures a cell against all three.

    A cell's *score* is its worst measure expressed as a smallest dihedral angle (degrees):
    ``min(smallest angle, (180 - largest angle) * a, radius ratio * b)`` with ``a`` and ``b``
    chosen so that each target maps to ``min_dihedral``. A cell meets all three targets
    exactly when its score is at least ``min_dihedral``; flips and smoothing raise the worst
    score, so they improve whichever measure is worst. Inverted and flat cells score ``-1``.

    Attributes
    ----------
    min_dihedral : float
        Smallest dihedral angle wanted, degrees.
    max_dihedral : float
        Largest dihedral angle wanted, degrees.
    min_radius_ratio : float
        Smallest radius ratio ``3 r_in / R_circ`` wanted.

    Examples
    --------
    >>> import numpy as np
    >>> targets = ShapeTargets(25.0, 150.0, 0.25)
    >>> right = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1.0]])
    >>> round(float(targets.score(right)), 2)   # limited by its 54.7 deg angle
    54.74
    >>> cap = np.array([[1, 0, 0], [-0.5, 0.87, 0], [-0.5, -0.87, 0], [0, 0, 0.2]])
    >>> [round(float(x), 3) for x in dihedral_extremes(cap)], round(float(targets.score(cap)), 1)  # a cap: radius ratio worst
    ([21.734, 142.636, 0.111], 11.1)
    """

    min_dihedral: float = 25.0
    max_dihedral: float = 150.0
    min_radius_ratio: float = 0.25

    @property
    def max_weight(self) -> float:
        """Degrees of score per degree of ``180 - largest angle``."""
        return self.min_dihedral / (180.0 - self.max_dihedral)

    @property
    def ratio_weight(self) -> float:
        """Degrees of score per unit of radius ratio."""
        return self.min_dihedral / self.min_radius_ratio

    def score_of(self, smallest: np.ndarray, largest: np.ndarray, ratio: np.ndarray) -> np.ndarray:
        """The score from the three measures (``-1`` where ``smallest`` is ``-1``)."""
        score = np.minimum(smallest, self.max_weight * (180.0 - largest))
        score = np.minimum(score, self.ratio_weight * ratio)
        return np.where(smallest < 0, -1.0, score)

    def score(self, corners: np.ndarray) -> np.ndarray:
        """Score (degrees) of tetrahedra given as (..., 4, 3) corners."""
        return self.score_and_ratio(corners)[0]

    def score_and_ratio(self, corners: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Score (degrees) and radius ratio of tetrahedra given as (..., 4, 3) corners."""
        smallest, largest, ratio = dihedral_extremes(corners)
        return self.score_of(smallest, largest, ratio), ratio


def radius_ratio(corners: np.ndarray) -> np.ndarray:
    """Radius ratio ``3 r_in / R_circ`` of tetrahedra given as (..., 4, 3) corners (see
    :func:`shape_measures`); ``-1`` for inverted and flat cells.

    Examples
    --------
    >>> import numpy as np
    >>> regular = np.array([[1, 1, 1], [-1, 1, -1], [1, -1, -1], [-1, -1, 1.0]])
    >>> round(float(radius_ratio(regular)), 12)
    1.0
    """
    return shape_measures(corners)[1]


def ideal_vertex_positions(points: np.ndarray, tets: np.ndarray) -> np.ndarray:
    """For each cell and vertex, where that vertex would make the cell regular: (4, 3, M).

    Entry ``[i, :, k]`` is the point above the centroid of the face of cell ``k`` opposite its
    vertex ``i``, on the vertex's side, at the height of a regular tetrahedron whose edge is
    that face's mean edge length. Its mean over a vertex's cells is the vertex's smoothing
    target.

    Examples
    --------
    >>> import numpy as np
    >>> flat = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0.3, 0.3, 0.01]])
    >>> ideal_vertex_positions(flat, np.array([[0, 1, 2, 3]]))[3, :, 0].round(3).tolist()
    [0.333, 0.333, 0.929]
    """
    from .._cell_kernels import ideal_positions

    return ideal_positions(points, tets, REGULAR_HEIGHT)
