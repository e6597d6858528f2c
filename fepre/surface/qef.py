"""Quadratic error functions of many cells at once: the point nearest to a set of tangent planes.

For one cell with Hermite samples ``(p_i, n_i)`` the QEF is ``E(x) = sum_i (n_i . (x - p_i))^2 =
|A x - b|^2`` with rows ``n_i`` of ``A`` and ``b_i = n_i . p_i``. Its minimiser is found about the
mass point ``m`` (the mean of the ``p_i``): ``x = m + (A^T A)^+ (A^T b - A^T A m)``, where the
pseudo-inverse drops the eigenvalues of ``A^T A`` below ``truncation`` times the largest (Ju et
al. 2002; Lindstrom 2000). The number of eigenvalues kept is the cell's rank: 1 on a smooth
surface (the vertex moves from the mass point along the normal only), 2 on a crease (the vertex
is the point of the crease nearest the mass point), 3 at a corner. Every cell is solved in one
batched 3x3 eigen-decomposition.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

__all__ = ["QEF", "accumulate_qef"]

_UPPER = ((0, 0), (0, 1), (0, 2), (1, 1), (1, 2), (2, 2))


@dataclass
class QEF:
    """Normal equations of ``C`` cells, about a reference point per cell.

    Attributes
    ----------
    ata : (C, 3, 3)
        ``A^T A`` of each cell.
    atb : (C, 3)
        ``A^T b`` with the samples relative to ``reference``.
    mass : (C, 3)
        Mass point relative to ``reference``.
    reference : (C, 3)
        Per-cell origin of the relative coordinates (keeps the sums well conditioned).
    """

    ata: np.ndarray
    atb: np.ndarray
    mass: np.ndarray
    reference: np.ndarray

    def solve(self, truncation: float = 0.1) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Minimisers (C, 3) in world coordinates, ranks (C,) and eigenvectors (C, 3, 3).

        The eigenvectors are columns in ascending order of eigenvalue, so for a cell of rank
        ``r`` the first ``3 - r`` columns span the directions the QEF leaves free.

        Examples
        --------
        >>> import numpy as np
        >>> normals = np.eye(3)  # three faces of a box corner at (1, 2, 3)
        >>> points = np.array([[1.0, 2.2, 3.3], [1.4, 2.0, 3.1], [1.2, 2.1, 3.0]])
        >>> qef = accumulate_qef(np.zeros(3, dtype=np.int64), points, normals, np.zeros((1, 3)))
        >>> x, rank, _ = qef.solve()
        >>> x.round(12).tolist(), rank.tolist()
        ([[1.0, 2.0, 3.0]], [3])
        """
        eigenvalues, vectors = np.linalg.eigh(self.ata)
        largest = eigenvalues[:, 2:3]
        keep = eigenvalues > truncation * largest
        keep &= largest > 0
        inverse = np.divide(1.0, eigenvalues, out=np.zeros_like(eigenvalues), where=keep)
        residual = self.atb - np.einsum("cij,cj->ci", self.ata, self.mass)
        step = np.einsum("cij,cj,cj->ci", vectors, inverse, np.einsum("cji,cj->ci", vectors, residual))
        return self.reference + self.mass + step, keep.sum(axis=1), vectors


def accumulate_qef(
    cell: np.ndarray, points: np.ndarray, normals: np.ndarray, reference: np.ndarray, weights: np.ndarray | None = None
) -> QEF:
    """Sum the samples ``(points[i], normals[i])`` into the QEF of cell ``cell[i]``.

    Parameters
    ----------
    cell : (K,) int
        Cell of each sample (``0 <= cell < len(reference)``; every cell needs one sample).
    points, normals : (K, 3)
        Sample positions and unit normals (a zero normal adds only to the mass point).
    reference : (C, 3)
        A point in or near each cell (its centre), the origin of the relative coordinates.
    weights : (K,), optional
        Weight of each sample in ``A^T A`` and ``A^T b`` (default 1).
    """
    count = reference.shape[0]
    relative = points - reference[cell]
    mass = np.stack([np.bincount(cell, weights=relative[:, a], minlength=count) for a in range(3)], axis=1)
    mass /= np.bincount(cell, minlength=count)[:, None]
    scaled = normals if weights is None else normals * weights[:, None]
    offset = np.einsum("ij,ij->i", normals, relative)
    ata = np.empty((count, 3, 3))
    for a, b in _UPPER:
        ata[:, a, b] = ata[:, b, a] = np.bincount(cell, weights=scaled[:, a] * normals[:, b], minlength=count)
    atb = np.stack([np.bincount(cell, weights=scaled[:, a] * offset, minlength=count) for a in range(3)], axis=1)
    return QEF(ata, atb, mass, reference)
