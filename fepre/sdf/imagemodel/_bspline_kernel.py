"""The compiled pass of :mod:`fepre.sdf.imagemodel.bspline`: the cubic B-spline along one axis
(numba, cached on disk; no GIL, so chunks refine on parallel threads)."""

from __future__ import annotations

from numba import njit

__all__ = ["refine_axis"]


@njit(cache=True, nogil=True)
def refine_axis(c, out, axis, start, weights):  # pragma: no cover - compiled
    """``out[..., q, ...] = sum_t weights[q, t] * c[..., start[q] + t, ...]`` along ``axis``
    (t = 0..3), the sum in that order for every node."""
    n0, n1, n2 = out.shape
    if axis == 0:
        for q in range(n0):
            s = start[q]
            w0, w1, w2, w3 = weights[q, 0], weights[q, 1], weights[q, 2], weights[q, 3]
            for j in range(n1):
                for k in range(n2):
                    out[q, j, k] = w0 * c[s, j, k] + w1 * c[s + 1, j, k] + w2 * c[s + 2, j, k] + w3 * c[s + 3, j, k]
    elif axis == 1:
        for i in range(n0):
            for q in range(n1):
                s = start[q]
                w0, w1, w2, w3 = weights[q, 0], weights[q, 1], weights[q, 2], weights[q, 3]
                for k in range(n2):
                    out[i, q, k] = w0 * c[i, s, k] + w1 * c[i, s + 1, k] + w2 * c[i, s + 2, k] + w3 * c[i, s + 3, k]
    else:
        for i in range(n0):
            for j in range(n1):
                for q in range(n2):
                    s = start[q]
                    out[i, j, q] = (weights[q, 0] * c[i, j, s] + weights[q, 1] * c[i, j, s + 1]
                                    + weights[q, 2] * c[i, j, s + 2] + weights[q, 3] * c[i, j, s + 3])
