"""Bars of a tetrahedral mesh and their spring forces (DistMesh's force law)."""

from __future__ import annotations

import numpy as np

__all__ = ["bars_of", "bar_forces"]


def bars_of(tets: np.ndarray, n_points: int) -> np.ndarray:
    """Unique bars (E, 2) of ``tets``, first index < second.

    Each edge (i, j) is encoded as one int64 ``i * n + j``; one ``np.sort`` and a comparison
    of neighbours find the unique codes (no per-edge Python work, no argsort).

    Examples
    --------
    >>> bars_of(np.array([[0, 1, 2, 3], [1, 2, 3, 4]]), 5).shape
    (9, 2)
    """
    from .._cell_kernels import packed_edge_keys

    codes = np.sort(packed_edge_keys(tets, n_points))
    if len(codes):
        codes = codes[np.concatenate([[True], codes[1:] != codes[:-1]])]
    return np.stack([codes // n_points, codes % n_points], axis=1)


def bar_forces(
    points: np.ndarray,
    ends: np.ndarray,
    fscale: float,
    nonlinear: bool,
    hbars: np.ndarray | None = None,
) -> tuple[np.ndarray, np.ndarray]:
    """Total force on every point and the bar lengths.

    ``L0 = hbar * fscale * (sum L^3 / sum hbar^3)^(1/3)``, ``F = max(L0 - L, 0)`` (times
    ``(L + L0) / (2 L0)`` when ``nonlinear``); bars push their ends apart, never pull. Forces are
    assembled by a compiled loop over the bars (:mod:`._bar_kernels`), in bar order as
    ``np.bincount`` adds them. ``hbars`` None means uniform size.
    """
    from ._bar_kernels import assemble_forces, bar_vectors

    vectors, lengths = bar_vectors(points, ends)
    if hbars is None:
        l0 = fscale * np.cbrt(np.mean(lengths**3))
    else:
        l0 = hbars * (fscale * np.cbrt(np.sum(lengths**3) / np.sum(hbars**3)))
    return assemble_forces(ends, vectors, lengths, l0, nonlinear, points.shape[0]), lengths
