"""Per-bar kernels of the DistMesh loop, compiled (numba, cached on disk).

:func:`bar_vectors` runs on every core; the force assembly adds each bar's force to its two
ends in bar order, as ``np.bincount`` does, so the totals equal the array form's bit for bit.
"""

from __future__ import annotations

import numpy as np
from numba import njit, prange

__all__ = ["bar_vectors", "assemble_forces"]


@njit(cache=True, parallel=True)
def _vectors(points, ends, vectors):  # pragma: no cover - compiled
    for e in prange(ends.shape[0]):
        i, j = ends[e, 0], ends[e, 1]
        for a in range(3):
            vectors[e, a] = points[j, a] - points[i, a]


def bar_vectors(points: np.ndarray, ends: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Vectors ``points[ends[:, 1]] - points[ends[:, 0]]`` (E, 3) and their lengths (E,)."""
    vectors = np.empty((len(ends), 3))
    if len(ends):
        _vectors(np.ascontiguousarray(points, np.float64), np.ascontiguousarray(ends, np.int64), vectors)
    # numpy's einsum, not the kernel's sum of squares: its rounding is the loop's since the start
    return vectors, np.sqrt(np.einsum("ij,ij->i", vectors, vectors))


@njit(cache=True)
def _assemble(ends, vectors, lengths, l0, nonlinear, plus, minus):  # pragma: no cover - compiled
    uniform = l0.shape[0] == 1
    for e in range(ends.shape[0]):
        target = l0[0] if uniform else l0[e]
        length = lengths[e]
        magnitude = max(target - length, 0.0)
        if nonlinear:
            magnitude *= (length + target) / (2.0 * target)
        scale = magnitude / (length if length > 0 else 1.0)
        i, j = ends[e, 0], ends[e, 1]
        for a in range(3):
            component = scale * vectors[e, a]
            plus[j, a] += component
            minus[i, a] += component


def assemble_forces(
    ends: np.ndarray, vectors: np.ndarray, lengths: np.ndarray, l0: np.ndarray, nonlinear: bool, n_points: int
) -> np.ndarray:
    """Total force (N, 3) of bars that push with ``max(l0 - L, 0)`` (times ``(L + l0) / (2 l0)``
    when ``nonlinear``) along their vectors; ``l0`` of length 1 (uniform) or E."""
    plus = np.zeros((n_points, 3))
    minus = np.zeros((n_points, 3))
    if len(ends):
        _assemble(np.ascontiguousarray(ends, np.int64), vectors, lengths, np.atleast_1d(np.asarray(l0, np.float64)),
                  bool(nonlinear), plus, minus)
    return plus - minus
