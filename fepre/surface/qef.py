"""Quadratic error functions of many cells at once: the point nearest to a set of tangent planes.

For one cell with Hermite samples ``(p_i, n_i)`` the QEF is ``E(x) = sum_i (n_i . (x - p_i))^2 =
|A x - b|^2`` with rows ``n_i`` of ``A`` and ``b_i = n_i . p_i``. Its minimiser is found about the
mass point ``m`` (the mean of the ``p_i``): ``x = m + (A^T A)^+ (A^T b - A^T A m)``, where the
pseudo-inverse drops the eigenvalues of ``A^T A`` below ``truncation`` times the largest (Ju et
al. 2002; Lindstrom 2000). The number of eigenvalues kept is the cell's rank: 1 on a smooth
surface (the vertex moves from the mass point along the normal only), 2 on a crease (the vertex
is the point of the crease nearest the mass point), 3 at a corner.

All cells are solved at once. Eigenvalues come from the closed form for symmetric 3x3 matrices;
a rank-1 cell (most of them) needs only its dominant eigenvector, a column of
``(A^T A - l1)(A^T A - l2)``; the others (creases, corners, cells without normals) go through a
batched LAPACK eigen-decomposition.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

__all__ = ["QEF", "accumulate_qef", "incidence", "sample_spread", "symmetric_eigenvalues"]

_UPPER = ((0, 0), (0, 1), (0, 2), (1, 1), (1, 2), (2, 2))


def symmetric_eigenvalues(matrices: np.ndarray) -> np.ndarray:
    """Ascending eigenvalues (C, 3) of symmetric 3x3 matrices (C, 3, 3), in closed form.

    Examples
    --------
    >>> import numpy as np
    >>> symmetric_eigenvalues(np.diag([3.0, 1.0, 2.0])[None]).round(12).tolist()
    [[1.0, 2.0, 3.0]]
    """
    a = matrices
    q = np.trace(a, axis1=1, axis2=2) / 3
    off = a[:, 0, 1] ** 2 + a[:, 0, 2] ** 2 + a[:, 1, 2] ** 2
    centred = a - q[:, None, None] * np.eye(3)
    p = np.sqrt((np.einsum("cii->ci", centred) ** 2).sum(axis=1) / 6 + off / 3)
    safe = np.where(p > 0, p, 1.0)
    b = centred / safe[:, None, None]
    det = (
        b[:, 0, 0] * (b[:, 1, 1] * b[:, 2, 2] - b[:, 1, 2] * b[:, 2, 1])
        - b[:, 0, 1] * (b[:, 1, 0] * b[:, 2, 2] - b[:, 1, 2] * b[:, 2, 0])
        + b[:, 0, 2] * (b[:, 1, 0] * b[:, 2, 1] - b[:, 1, 1] * b[:, 2, 0])
    )
    r = np.clip(det / 2, -1.0, 1.0)
    phi = np.arccos(r) / 3
    largest = q + 2 * p * np.cos(phi)
    smallest = q + 2 * p * np.cos(phi + 2 * np.pi / 3)
    middle = 3 * q - largest - smallest
    values = np.stack([smallest, middle, largest], axis=1)
    return np.sort(values, axis=1)  # rounding can swap near-equal ones


def _dominant_vector(a: np.ndarray, values: np.ndarray) -> np.ndarray:
    """Unit eigenvectors (C, 3) of the largest eigenvalue of symmetric (C, 3, 3) ``a``.

    ``(a - l0)(a - l1) = a^2 - (l0 + l1) a + l0 l1`` is the largest eigenvalue's projector up to
    a factor, so its longest column is the eigenvector; written out, not a batched matmul.
    """
    a00, a01, a02, a11, a12, a22 = (a[:, i, j] for i, j in _UPPER)
    total, product = values[:, 0] + values[:, 1], values[:, 0] * values[:, 1]
    m00 = a00 * a00 + a01 * a01 + a02 * a02 - total * a00 + product
    m11 = a01 * a01 + a11 * a11 + a12 * a12 - total * a11 + product
    m22 = a02 * a02 + a12 * a12 + a22 * a22 - total * a22 + product
    m01 = a00 * a01 + a01 * a11 + a02 * a12 - total * a01
    m02 = a00 * a02 + a01 * a12 + a02 * a22 - total * a02
    m12 = a01 * a02 + a11 * a12 + a12 * a22 - total * a12
    n0, n1, n2 = m00 * m00 + m01 * m01 + m02 * m02, m01 * m01 + m11 * m11 + m12 * m12, m02 * m02 + m12 * m12 + m22 * m22
    first, second = (n0 >= n1) & (n0 >= n2), n1 >= n2
    v = np.empty((a.shape[0], 3))
    v[:, 0] = np.where(first, m00, np.where(second, m01, m02))
    v[:, 1] = np.where(first, m01, np.where(second, m11, m12))
    v[:, 2] = np.where(first, m02, np.where(second, m12, m22))
    return v / np.linalg.norm(v, axis=1, keepdims=True)


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

    def subset(self, cells: np.ndarray) -> "QEF":
        """The QEFs of the cells ``cells`` only."""
        return QEF(self.ata[cells], self.atb[cells], self.mass[cells], self.reference[cells])

    def solve(self, truncation: float = 0.1, max_rank: int = 3) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Minimisers (C, 3) in world coordinates, ranks (C,) and free projectors (C, 3, 3).

        The free projector of a cell projects onto the directions its QEF leaves free (the
        eigenvectors whose eigenvalues were dropped): the plane of a smooth surface, the line
        of a crease, nothing at a corner. ``max_rank`` keeps at most that many of the largest
        eigenvalues (2: the crease through the mass point's side of a corner; 1: the plane).

        Examples
        --------
        >>> import numpy as np
        >>> normals = np.eye(3)  # three faces of a box corner at (1, 2, 3)
        >>> points = np.array([[1.0, 2.2, 3.3], [1.4, 2.0, 3.1], [1.2, 2.1, 3.0]])
        >>> qef = accumulate_qef(np.zeros(3, dtype=np.int64), points, normals, np.zeros((1, 3)))
        >>> x, rank, free = qef.solve()
        >>> x.round(12).tolist(), rank.tolist(), bool(np.allclose(free, 0))
        ([[1.0, 2.0, 3.0]], [3], True)
        """
        count = self.ata.shape[0]
        values = symmetric_eigenvalues(self.ata)
        largest = values[:, 2]
        keep = (values > truncation * largest[:, None]) & (largest[:, None] > 0)
        keep[:, : 3 - max_rank] = False
        rank = keep.sum(axis=1)
        residual = self.atb - np.einsum("cij,cj->ci", self.ata, self.mass)
        step = np.zeros((count, 3))
        free = np.zeros((count, 3, 3))
        # rank 1 with a clear gap: the dominant eigenvector from the spectral projector
        simple = np.flatnonzero((rank == 1) & (values[:, 1] < 0.5 * truncation * largest))
        if simple.size:
            v = _dominant_vector(self.ata[simple], values[simple])
            step[simple] = v * (np.einsum("ci,ci->c", v, residual[simple]) / largest[simple])[:, None]
            free[simple] = np.eye(3) - v[:, :, None] * v[:, None, :]
        is_simple = np.zeros(count, dtype=bool)
        is_simple[simple] = True
        other = np.flatnonzero(~is_simple)
        if other.size:
            lam, vectors = np.linalg.eigh(self.ata[other])
            kept = keep[other]
            inverse = np.divide(1.0, lam, out=np.zeros_like(lam), where=kept)
            coefficients = np.einsum("cji,cj->ci", vectors, residual[other]) * inverse
            step[other] = np.einsum("cij,cj->ci", vectors, coefficients)
            dropped = vectors * (~kept)[:, None, :]
            free[other] = np.einsum("cik,cjk->cij", dropped, dropped)
        return self.reference + self.mass + step, rank, free


def incidence(cell: np.ndarray, sample: np.ndarray, cells: int, samples: int):
    """The sparse (cells x samples) matrix with a one where sample ``sample[i]`` belongs to ``cell[i]``.

    Per-cell sums of per-sample quantities are then one sparse product: each sample's terms are
    computed once, however many cells share it (a crossing belongs to up to four).

    Examples
    --------
    >>> import numpy as np
    >>> matrix = incidence(np.array([0, 0, 1]), np.array([0, 1, 1]), 2, 2)
    >>> (matrix @ np.array([10.0, 1.0])).tolist()
    [11.0, 1.0]
    """
    from scipy.sparse import csr_matrix

    if cell.size > 1 and np.any(cell[1:] < cell[:-1]):
        order = np.argsort(cell, kind="stable")
        cell, sample = cell[order], sample[order]
    indptr = np.searchsorted(cell, np.arange(cells + 1))
    return csr_matrix((np.ones(cell.size), sample, indptr), shape=(cells, samples))


def accumulate_qef(
    cell: np.ndarray,
    points: np.ndarray,
    normals: np.ndarray,
    reference: np.ndarray,
    sample: np.ndarray | None = None,
) -> QEF:
    """Sum the samples into the QEF of their cells: row ``i`` adds sample ``sample[i]`` to cell ``cell[i]``.

    Parameters
    ----------
    cell : (K,) int
        Cell of each row; every cell ``0 <= c < len(reference)`` has at least one row.
    points, normals : (S, 3)
        Sample positions and unit normals (a zero normal adds only to the mass point).
    reference : (C, 3)
        A point in or near each cell (its centre), the origin of the cell's relative coordinates.
    sample : (K,) int, optional
        Sample of each row (default: row ``i`` is sample ``i``). Each row's terms are taken about
        its own cell's reference, so a cell's sums depend on its own samples only.
    """
    count = reference.shape[0]
    if sample is not None:
        points, normals = points[sample], normals[sample]
    # each row about its own cell's reference: a cell's sums then depend on its samples only
    # (not on which other cells are in the batch, so a chunk of a grid solves as the whole does)
    position = points - reference[cell]
    offset = np.einsum("ij,ij->i", normals, position)
    terms = np.empty((points.shape[0], 13))
    terms[:, 0] = 1.0
    terms[:, 1:4] = position
    for k, (a, b) in enumerate(_UPPER):
        terms[:, 4 + k] = normals[:, a] * normals[:, b]
    terms[:, 10:13] = normals * offset[:, None]
    sums = incidence(cell, np.arange(cell.size), count, cell.size) @ terms
    mass = sums[:, 1:4] / sums[:, 0:1]
    ata = np.empty((count, 3, 3))
    for k, (a, b) in enumerate(_UPPER):
        ata[:, a, b] = ata[:, b, a] = sums[:, 4 + k]
    return QEF(ata, sums[:, 10:13], mass, reference)


def _segment_sums(cell: np.ndarray, rows: np.ndarray, count: int) -> np.ndarray:
    """Per-cell sums (count, m) of the columns of ``rows`` (m, K); every cell present, sorted or not."""
    if cell.size > 1 and np.any(cell[1:] < cell[:-1]):
        order = np.argsort(cell, kind="stable")
        cell, rows = cell[order], rows[:, order]
    starts = np.searchsorted(cell, np.arange(count))
    return np.add.reduceat(rows, starts, axis=1).T


def sample_spread(cell: np.ndarray, points: np.ndarray, count: int) -> np.ndarray:
    """Second moments (count, 3, 3) of each cell's sample positions about their mean.

    Examples
    --------
    >>> import numpy as np
    >>> spread = sample_spread(np.zeros(2, dtype=np.int64), np.array([[0.0, 0, 0], [2.0, 0, 0]]), 1)
    >>> spread[0].tolist()
    [[1.0, 0.0, 0.0], [0.0, 0.0, 0.0], [0.0, 0.0, 0.0]]
    """
    rows = np.empty((10, cell.size))
    rows[0] = 1.0
    rows[1:4] = points.T
    for k, (a, b) in enumerate(_UPPER):
        rows[4 + k] = points[:, a] * points[:, b]
    sums = _segment_sums(cell, rows, count)
    mean = sums[:, 1:4] / sums[:, 0:1]
    spread = np.empty((count, 3, 3))
    for k, (a, b) in enumerate(_UPPER):
        spread[:, a, b] = spread[:, b, a] = sums[:, 4 + k] / sums[:, 0] - mean[:, a] * mean[:, b]
    return spread
