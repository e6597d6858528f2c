"""Chunked isosurfaces: one dask task per chunk, stitched in memory or streamed to an STL file.

Each task extracts its chunk's owned triangles (:mod:`fepre.chunked.chunk_surface`) from the
nodes it reads: sampled by the task itself from a model (halo included, so no task waits for
another), or read with its halo from a :class:`~fepre.chunked.grid.ChunkedGrid` (dask's
``overlap``). In memory, the pieces are stitched by key and cleaned exactly as the single-grid
surface is, so the result is the single-grid surface (fepre's methods: the same arrays; flying
edges: the same vertices and triangles in another order). Streamed (:mod:`fepre.chunked.stream`),
each chunk's triangles are written as soon as they are made.
"""

from __future__ import annotations

import sys
import uuid
from typing import Any

import numpy as np

from .chunk_surface import ChunkSurface, extract_chunk
from .cluster import in_completion_order  # noqa: F401  (re-exported: it was defined here)
from .grid import ChunkedGrid
from .layout import HALO, ChunkLayout
from .sampling import sample_nodes
from .stream import file_piece

__all__ = ["chunk_tasks", "file_pieces", "surface_in_memory", "in_completion_order"]


def _model_chunk(model, origin, step, counts, lo, hi, read_lo, read_hi, band, dtype, method, level, named) -> ChunkSurface:
    values = sample_nodes(model, origin, step, read_lo, read_hi, band, dtype)
    return extract_chunk(
        values, read_lo, lo, hi, method=method, level=level, origin=origin, spacing=step, counts=counts, model=model,
        named=named,
    )


def _grid_chunk(values, origin, step, counts, lo, hi, read_lo, method, level, model, named) -> ChunkSurface:
    return extract_chunk(
        np.asarray(values), read_lo, lo, hi, method=method, level=level, origin=origin, spacing=step, counts=counts,
        model=model, named=named,
    )


def chunk_tasks(
    source: Any, *, method: str, level: float, layout: ChunkLayout, origin, step, band, dtype, model, named: bool = True
):
    """One delayed :class:`ChunkSurface` per chunk of ``layout``.

    ``source`` is a model (each task samples the nodes it reads) or a :class:`ChunkedGrid`
    (each task reads its block and halo through ``dask.array.overlap``). ``named=False`` skips
    naming flying edges' vertices (a streamed file needs only the corners).
    """
    import dask

    counts = np.array(layout.counts)
    if isinstance(source, ChunkedGrid):
        import dask.array as da

        depth = max(HALO[method])
        overlapped = da.overlap.overlap(source.values, depth={0: depth, 1: depth, 2: depth}, boundary="none")
        blocks = overlapped.to_delayed()
        task = dask.delayed(_grid_chunk, pure=True)
        shared = dask.delayed(model, pure=True, name=f"fepre-model-{uuid.uuid4().hex}") if model is not None else None
        tasks = []
        for index, lo, hi in layout:
            read_lo = np.maximum(lo - depth, 0)
            tasks.append(task(blocks[index], origin, step, counts, lo, hi, read_lo, method, level, shared, named))
        return tasks
    shared = dask.delayed(source, pure=True, name=f"fepre-model-{uuid.uuid4().hex}")
    task = dask.delayed(_model_chunk, pure=True)
    tasks = []
    for _, lo, hi in layout:
        read_lo, read_hi = layout.read_range(lo, hi, method)
        tasks.append(task(shared, origin, step, counts, lo, hi, read_lo, read_hi, band, dtype, method, level, named))
    return tasks


def _compute_all(tasks: list, progress: bool) -> list[ChunkSurface]:
    import dask

    if progress:
        from .cluster import distributed_client

        if distributed_client() is None:
            from dask.diagnostics import ProgressBar

            with ProgressBar(out=sys.stderr):
                return list(dask.compute(*tasks))
    return list(dask.compute(*tasks))


def surface_in_memory(tasks: list, progress: bool = False):
    """Compute every chunk; stitch.  Returns ``(points, triangles, on_level)``."""
    from .stitch import stitch

    points, triangles, on_level = stitch(_compute_all(tasks, progress))
    return points, triangles, on_level


def file_pieces(tasks: list, method: str, origin: np.ndarray, spacing: np.ndarray, kind: str) -> list:
    """Each chunk task followed by its :func:`fepre.chunked.stream.file_piece` for a ``kind``
    (``"stl"`` or ``"ply"``) file, run where the chunk runs."""
    import dask

    follow = dask.delayed(file_piece, pure=True)
    return [follow(task, method, origin, spacing, kind) for task in tasks]
