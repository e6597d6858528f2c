"""Per-bar kernels of the DistMesh loop, compiled (numba, cached on disk).

:func:`unique_bars` finds a triangulation's edges; :func:`bar_vectors` runs on every core when the
work pays for it (:mod:`fepre.kernel_threads`); the
force assembly adds each bar's force to its two ends in bar order, as ``np.bincount`` does, so
the totals equal the array form's bit for bit.
"""

from __future__ import annotations

import numpy as np
from numba import njit, prange

from .._cell_kernels import chunk_offsets
from ..kernel_threads import kernel_threads

__all__ = ["bar_vectors", "assemble_forces", "unique_bars"]


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
        with kernel_threads(len(ends), 6e-9):
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


@njit(cache=True, parallel=True)
def _edges_by_lowest(tets, edges, n_points, chunks):  # pragma: no cover - compiled
    # a stable counting sort of the cells' edges by lower end: each chunk of cells counts, then
    # fills, its own share of every group (the same result for any number of chunks)
    m = tets.shape[0]
    size = (m + chunks - 1) // chunks
    fill = np.zeros((chunks, n_points), np.int64)
    for c in prange(chunks):
        for t in range(c * size, min(m, (c + 1) * size)):
            for e in range(6):
                fill[c, min(tets[t, edges[e, 0]], tets[t, edges[e, 1]])] += 1
    start = chunk_offsets(fill)
    other = np.empty(start[n_points], np.int64)
    for c in prange(chunks):
        for t in range(c * size, min(m, (c + 1) * size)):
            for e in range(6):
                a, b = tets[t, edges[e, 0]], tets[t, edges[e, 1]]
                low = min(a, b)
                other[fill[c, low]] = max(a, b)
                fill[c, low] += 1
    return start, other


@njit(cache=True, parallel=True)
def _dedupe_buckets(start, other, unique, chunks):  # pragma: no cover - compiled
    n = start.shape[0] - 1
    for chunk in prange(chunks):
        seen = np.full(n, -1, np.int64)  # the last bucket that listed each end: no sort to find repeats
        for v in range(chunk * n // chunks, (chunk + 1) * n // chunks):
            s, e = start[v], start[v + 1]
            count = 0
            for i in range(s, e):
                x = other[i]
                if seen[x] != v:
                    seen[x] = v
                    other[s + count] = x
                    count += 1
            for i in range(s + 1, s + count):  # insertion sort of the few distinct ends
                x = other[i]
                j = i - 1
                while j >= s and other[j] > x:
                    other[j + 1] = other[j]
                    j -= 1
                other[j + 1] = x
            unique[v] = count


@njit(cache=True, parallel=True)
def _write_bars(start, other, offsets, bars):  # pragma: no cover - compiled
    for v in prange(start.shape[0] - 1):
        for k in range(offsets[v + 1] - offsets[v]):
            bars[offsets[v] + k, 0] = v
            bars[offsets[v] + k, 1] = other[start[v] + k]


def unique_bars(tets: np.ndarray, n_points: int, edges: np.ndarray) -> np.ndarray:
    """Unique edges (E, 2) of ``tets`` (``edges``: the six local vertex pairs), first index <
    second, sorted by first then second index: edges grouped by their lower end (a counting
    pass) and each group of a few dozen sorted in place, instead of one sort of all ``6 M``."""
    if len(tets) == 0:
        return np.zeros((0, 2), np.int64)
    n_points = max(int(n_points), int(tets.max()) + 1)  # the groups are indexed by vertex
    with kernel_threads(len(tets), 2.5e-8) as threads:
        start, other = _edges_by_lowest(np.ascontiguousarray(tets, np.int64), edges, np.int64(n_points),
                                        np.int64(threads))
        unique = np.empty(n_points, np.int64)
        _dedupe_buckets(start, other, unique, 4 * threads)
        offsets = np.zeros(n_points + 1, np.int64)
        np.cumsum(unique, out=offsets[1:])
        bars = np.empty((offsets[-1], 2), np.int64)
        _write_bars(start, other, offsets, bars)
    return bars
