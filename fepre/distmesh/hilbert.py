"""Hilbert-curve ordering of 3D points (Skilling's transpose algorithm, vectorised)."""

from __future__ import annotations

import numpy as np

__all__ = ["hilbert_keys", "hilbert_order"]


def hilbert_keys(points: np.ndarray, bits: int = 10) -> np.ndarray:
    """Position of each point along a 3D Hilbert curve over the points' bounding box.

    Points are quantised to a ``2**bits`` grid per axis; the loops run over bits, never points.

    Examples
    --------
    >>> corners = np.array([[0, 0, 0], [0, 0, 1], [1, 1, 1], [1, 0, 0]], float)
    >>> len(set(hilbert_keys(corners, bits=1).tolist()))
    4
    """
    points = np.asarray(points, dtype=np.float64)
    lower = points.min(axis=0)
    extent = max(float((points.max(axis=0) - lower).max()), 1e-300)
    top = (1 << bits) - 1
    x = np.clip(((points - lower) / extent * top).round(), 0, top).astype(np.int64).T.copy()  # (3, N)

    # inverse undo of the Gray-code excess work (Skilling 2004, AxestoTranspose)
    m = 1 << (bits - 1)
    q = m
    while q > 1:
        p = q - 1
        for i in range(3):
            flag = (x[i] & q) != 0
            x[0] = np.where(flag, x[0] ^ p, x[0])
            t = np.where(flag, 0, (x[0] ^ x[i]) & p)
            x[0] ^= t
            x[i] ^= t
        q >>= 1
    for i in range(1, 3):
        x[i] ^= x[i - 1]
    t = np.zeros_like(x[0])
    q = m
    while q > 1:
        t = np.where((x[2] & q) != 0, t ^ (q - 1), t)
        q >>= 1
    x ^= t[None, :]

    # interleave the transposed bits into one key, most significant first
    key = np.zeros(points.shape[0], dtype=np.int64)
    for b in range(bits - 1, -1, -1):
        for i in range(3):
            key = (key << 1) | ((x[i] >> b) & 1)
    return key


def hilbert_order(points: np.ndarray, bits: int = 10) -> np.ndarray:
    """Permutation sorting ``points`` along a Hilbert curve (stable, deterministic)."""
    return np.argsort(hilbert_keys(points, bits), kind="stable")
