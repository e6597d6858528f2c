"""Bars of a tetrahedral mesh and their spring forces (DistMesh's force law)."""

from __future__ import annotations

import numpy as np

__all__ = ["bars_of", "bar_forces"]


def bars_of(tets: np.ndarray, n_points: int) -> np.ndarray:
    """Unique bars (E, 2) of ``tets``, first index < second, sorted.

    Edges are grouped by their lower end and each group sorted and thinned in place by a
    compiled kernel (:func:`~fepre.distmesh._bar_kernels.unique_bars`), no per-edge Python work.

    Examples
    --------
    >>> bars_of(np.array([[0, 1, 2, 3], [1, 2, 3, 4]]), 5).shape
    (9, 2)
    """
    from .._cell_kernels import _EDGES
    from ._bar_kernels import unique_bars

    return unique_bars(tets, n_points, _EDGES)


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
    if lengths.size == 0:  # no cell of this triangulation inside the part: nothing pushes
        return np.zeros_like(points, dtype=np.float64), lengths
    if hbars is None:
        l0 = fscale * np.cbrt(np.mean(lengths**3))
    else:
        l0 = hbars * (fscale * np.cbrt(np.sum(lengths**3) / np.sum(hbars**3)))
    return assemble_forces(ends, vectors, lengths, l0, nonlinear, points.shape[0]), lengths
