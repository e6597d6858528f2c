"""Stitching chunk surfaces into one: vertices merged by key, triangles put in whole-grid order."""

from __future__ import annotations

from typing import Sequence

import numpy as np

from .chunk_surface import ChunkSurface

__all__ = ["stitch"]


def stitch(pieces: Sequence[ChunkSurface]) -> tuple[np.ndarray, np.ndarray, bool]:
    """Points, triangles and whether any node is on the level.

    Vertices with the same key are one vertex (its coordinates taken from the first chunk that
    has it, the same bits in every chunk); negative keys are a chunk's own vertices, kept as they
    are (after the others). Vertices come
    sorted by key and triangles by order key (stable), which for fepre's own methods is the
    single-grid extraction's order.
    """
    pieces = [p for p in pieces if p.triangles.shape[0]]
    on_level = any(p.on_level for p in pieces)
    if not pieces:
        return np.empty((0, 3)), np.empty((0, 3), dtype=np.int64), on_level
    keys = np.concatenate([p.keys for p in pieces])
    points = np.concatenate([p.points for p in pieces])
    shift = np.cumsum([0] + [p.keys.size for p in pieces[:-1]])
    triangles = np.concatenate([p.triangles + s for p, s in zip(pieces, shift)])
    shared = keys >= 0  # negative keys name a chunk's own vertices: no other chunk has them
    unique, first, inverse = np.unique(keys[shared], return_index=True, return_inverse=True)
    rows = np.flatnonzero(shared)
    own = np.flatnonzero(~shared)
    index = np.empty(keys.size, dtype=np.int64)
    index[rows] = inverse.ravel()
    index[own] = unique.size + np.arange(own.size)
    merged = np.concatenate([points[rows[first]], points[own]])
    triangles = index[triangles]
    if all(p.order is not None for p in pieces):
        order = np.argsort(np.concatenate([p.order for p in pieces]), kind="stable")
        triangles = triangles[order]
    return merged, triangles, on_level
