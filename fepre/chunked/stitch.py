"""Stitching chunk surfaces into one: vertices merged by key, triangles put in whole-grid order."""

from __future__ import annotations

import os
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
    if all(p.order is None for p in pieces):
        return (*_stitch_in_place(pieces), on_level)
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


def _stitch_in_place(pieces: Sequence[ChunkSurface]) -> tuple[np.ndarray, np.ndarray]:
    """Stitching without an order to keep (flying edges): the shared vertices (keys >= 0, those
    on chunk faces) first, then each chunk's own vertices; each chunk renumbers and copies its
    own part of the output on a thread, so only the few shared vertices are merged centrally."""
    from concurrent.futures import ThreadPoolExecutor

    shared = [np.flatnonzero(p.keys >= 0) for p in pieces]
    shared_keys = np.concatenate([p.keys[s] for p, s in zip(pieces, shared)])
    unique, first = np.unique(shared_keys, return_index=True)
    owner = np.repeat(np.arange(len(pieces)), [s.size for s in shared])[first]
    row = np.concatenate(shared)[first]
    own = [p.keys.size - s.size for p, s in zip(pieces, shared)]
    vertex_start = unique.size + np.concatenate([[0], np.cumsum(own)])
    triangle_start = np.concatenate([[0], np.cumsum([p.triangles.shape[0] for p in pieces])])
    points = np.empty((int(vertex_start[-1]), 3))
    triangles = np.empty((int(triangle_start[-1]), 3), dtype=np.int64)
    for index in np.unique(owner):
        mine = owner == index
        points[np.flatnonzero(mine)] = pieces[index].points[row[mine]]

    def place(index: int) -> None:
        piece = pieces[index]
        number = np.empty(piece.keys.size, dtype=np.int64)
        mask = piece.keys >= 0
        number[mask] = np.searchsorted(unique, piece.keys[mask])
        count = int(np.count_nonzero(~mask))
        number[~mask] = vertex_start[index] + np.arange(count)
        points[vertex_start[index] : vertex_start[index] + count] = piece.points[~mask]
        triangles[triangle_start[index] : triangle_start[index + 1]] = number[piece.triangles]

    with ThreadPoolExecutor(max_workers=min(len(pieces), os.cpu_count() or 1)) as pool:
        list(pool.map(place, range(len(pieces))))
    return points, triangles
