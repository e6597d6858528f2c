"""How a grid is cut into chunks: node ranges per axis, the halo each method needs, ownership.

A chunk *owns* the nodes ``[start, stop)`` along each axis; the chunks of an axis tile its nodes.
Extraction reads more than it owns: the cells of its nodes need the next node plane (a halo of
one node on the high side: marching cubes, marching tetrahedra, flying edges), and the dual
methods need the cells around every owned crossing edge and their neighbours (three nodes on each
side: a vertex's cell, the neighbour it may hand a corner to or share a tunnel with, and that
neighbour's own neighbour).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Iterator

import numpy as np

from ..arguments import int_triple

__all__ = ["ChunkLayout", "as_chunks", "HALO", "MIN_CHUNK"]

#: nodes each method reads beyond the ones a chunk owns, on (the low side, the high side)
HALO = {
    "flying_edges": (0, 1),
    "marching_cubes": (0, 1),
    "marching_tetrahedra": (0, 1),
    "surface_nets": (3, 3),
    "dual_contouring": (3, 3),
}
#: fewest nodes a chunk may own along an axis (more than any halo, so a halo never spans chunks)
MIN_CHUNK = 8


def as_chunks(chunks: Any, name: str = "chunks") -> np.ndarray:
    """Nodes per chunk along x, y, z from an int or three ints (at least ``MIN_CHUNK`` each).

    Examples
    --------
    >>> as_chunks(64).tolist()
    [64, 64, 64]
    """
    return int_triple(chunks, name, MIN_CHUNK, " (the dual methods read 3 nodes beyond each side of a chunk)")


def _axis_sizes(count: int, size: int) -> tuple[int, ...]:
    """Chunk sizes along one axis; a remainder below ``MIN_CHUNK`` joins the last chunk."""
    if count <= size:
        return (count,)
    full, rest = divmod(count, size)
    sizes = [size] * full
    if rest >= MIN_CHUNK or rest == 0:
        sizes += [rest] if rest else []
    else:
        sizes[-1] += rest
    return tuple(sizes)


@dataclass(frozen=True)
class ChunkLayout:
    """The chunks of a grid of ``counts = (nx, ny, nz)`` nodes.

    Attributes
    ----------
    counts : (3,) int
        Nodes per axis (x, y, z).
    sizes : tuple of three tuples
        Nodes owned by each chunk along x, y and z.

    Examples
    --------
    >>> layout = ChunkLayout.of((20, 10, 10), (8, 8, 8))
    >>> layout.sizes[0], layout.n_chunks
    ((8, 12), 2)
    """

    counts: tuple[int, int, int]
    sizes: tuple[tuple[int, ...], tuple[int, ...], tuple[int, ...]]

    @classmethod
    def of(cls, counts: Any, chunks: Any) -> "ChunkLayout":
        chunks = as_chunks(chunks)
        counts = tuple(int(c) for c in counts)
        return cls(counts, tuple(_axis_sizes(n, int(c)) for n, c in zip(counts, chunks)))

    @property
    def n_chunks(self) -> int:
        return int(np.prod([len(s) for s in self.sizes]))

    @property
    def dask_chunks(self) -> tuple[tuple[int, ...], ...]:
        """Chunk sizes in array order (z, y, x), as dask takes them."""
        return tuple(reversed(self.sizes))

    def starts(self, axis: int) -> np.ndarray:
        return np.concatenate([[0], np.cumsum(self.sizes[axis])])

    def __iter__(self) -> Iterator[tuple[tuple[int, int, int], np.ndarray, np.ndarray]]:
        """``(block index (z, y, x), owned start (x, y, z), owned stop (x, y, z))`` per chunk."""
        edges = [self.starts(a) for a in range(3)]
        for bz in range(len(self.sizes[2])):
            for by in range(len(self.sizes[1])):
                for bx in range(len(self.sizes[0])):
                    lo = np.array([edges[0][bx], edges[1][by], edges[2][bz]])
                    hi = np.array([edges[0][bx + 1], edges[1][by + 1], edges[2][bz + 1]])
                    yield (bz, by, bx), lo, hi

    def read_range(self, lo: np.ndarray, hi: np.ndarray, method: str) -> tuple[np.ndarray, np.ndarray]:
        """Nodes ``[read_lo, read_hi)`` a chunk owning ``[lo, hi)`` reads for ``method``."""
        below, above = HALO[method]
        return np.maximum(lo - below, 0), np.minimum(hi + above, np.array(self.counts))
