"""Chunked isosurfaces: one dask task per chunk, stitched in memory or streamed to an STL file.

Each task extracts its chunk's owned triangles (:mod:`fepre.chunked.chunk_surface`) from the
nodes it reads: sampled by the task itself from a model (halo included, so no task waits for
another), or read with its halo from a :class:`~fepre.chunked.grid.ChunkedGrid` (dask's
``overlap``). In memory, the pieces are stitched by key and cleaned exactly as the single-grid
surface is, so the result is the single-grid surface (fepre's methods: the same arrays; flying
edges: the same vertices and triangles in another order). Streamed, each chunk's triangles are
written as soon as they are made; the seams are checked closed from each chunk's open edges,
without holding the surface.
"""

from __future__ import annotations

import os
import sys
import time
import uuid
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Callable, Iterable

import numpy as np

from .chunk_surface import ChunkSurface, extract_chunk
from .grid import ChunkedGrid
from .layout import HALO, ChunkLayout
from .sampling import sample_nodes

__all__ = ["chunk_tasks", "file_pieces", "surface_in_memory", "stream_stl", "StreamedSurface", "FilePiece"]


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

    points, triangles, on_level, _ = stitch(_compute_all(tasks, progress))
    return points, triangles, on_level


def file_pieces(tasks: list, method: str, origin: np.ndarray, spacing: np.ndarray) -> list:
    """Each chunk task followed by its :func:`file_piece` (run where the chunk runs)."""
    import dask

    follow = dask.delayed(file_piece, pure=True)
    return [follow(task, method, origin, spacing) for task in tasks]


def _in_completion_order(tasks: list, window: int) -> Iterable:
    """Chunk results as they finish, with at most ``window`` chunks in flight (bounded memory)."""
    import dask

    from .cluster import distributed_client

    client = distributed_client()
    if client is not None:
        from distributed import as_completed

        pending = iter(tasks)
        futures = as_completed([client.compute(t) for t in _take(pending, window)])
        for future in futures:
            result = future.result()
            future.release()
            for t in _take(pending, 1):
                futures.add(client.compute(t))
            yield result
        return
    if dask.config.get("scheduler", None) not in (None, "threads", "threading"):
        for start in range(0, len(tasks), window):  # the user's own scheduler, in waves
            yield from dask.compute(*tasks[start : start + window])
        return
    # dask's threads, as a sliding window: a new chunk starts as soon as one finishes
    from concurrent.futures import FIRST_COMPLETED, ThreadPoolExecutor, wait

    workers = int(dask.config.get("num_workers", None) or os.cpu_count() or 1)
    pending = iter(tasks)
    with ThreadPoolExecutor(max_workers=workers) as pool:
        running = {pool.submit(dask.compute, t, scheduler="sync") for t in _take(pending, window)}
        while running:
            done, running = wait(running, return_when=FIRST_COMPLETED)
            running |= {pool.submit(dask.compute, t, scheduler="sync") for t in _take(pending, len(done))}
            for future in done:
                yield future.result()[0]


def _take(iterator, count: int) -> list:
    out = []
    for _ in range(count):
        try:
            out.append(next(iterator))
        except StopIteration:
            break
    return out


@dataclass
class StreamedSurface:
    """What :func:`stream_stl` wrote: counts and whether the seams close.

    Attributes
    ----------
    path : pathlib.Path
    n_triangles : int
    chunks : int
        Chunks extracted (those with no surface included).
    seam_edges : int
        Edges on chunk faces (used by triangles of two chunks).
    open_edges : int
        Edges used once in all (0 for a closed surface).
    nonmanifold_edges : int
        Edges used by more than two triangles.
    seconds : float
    """

    path: Path
    n_triangles: int
    chunks: int
    seam_edges: int
    open_edges: int
    nonmanifold_edges: int
    seconds: float

    @property
    def closed(self) -> bool:
        return self.open_edges == 0 and self.nonmanifold_edges == 0


_STL_RECORD = np.dtype([("normal", "<f4", (3,)), ("corners", "<f4", (3, 3)), ("attribute", "<u2")])
#: a binary STL counts its triangles in a uint32
_STL_LIMIT = 2**32 - 1


#: a vertex this close to a grid node (in cells, along every axis) is on the node: the crossings
#: of a node on the level (float32 samples put them up to ~1e-6 cells off it); the single-grid
#: weld's tolerance
_NODE_TOLERANCE = 1e-6


def _clean_chunk(piece: ChunkSurface, method: str, origin: np.ndarray, spacing: np.ndarray):
    """A chunk's triangles as a file reader sees them, cleaned as the single-grid surface is where
    a chunk can tell alone.

    Vertices are named by their position as the file holds it (float32; an STL file has only
    positions): those within ``_NODE_TOLERANCE`` cells of a grid node (the crossings of a node
    on the level) are put on it first, so vertices that coincide are one vertex in every chunk
    alike, as a reader of the file sees them; the triangles they collapse are dropped, and, for the methods that make them, triangles with
    three collinear corners are flipped away with a neighbour in the chunk. Returns the points,
    the triangles and each point's name (V, 3) int64 (the bits of its float32 coordinates).
    """
    from ..surface.extract import _COLLINEAR_METHODS
    from ..surface.zero_area import flip_zero_area

    units = (piece.points - origin) / spacing
    node = np.rint(units)
    at_node = np.all(np.abs(units - node) <= _NODE_TOLERANCE, axis=1)
    units[at_node] = node[at_node]  # the crossings at a node on the level, moved onto it exactly
    points = piece.points.copy()
    points[at_node] = origin + node[at_node] * spacing
    # as the file holds them: float32 (-0.0 read as 0.0)
    written = points.astype(np.float32) + np.float32(0.0)
    first, inverse = _unique_rows(written.view(np.uint32))
    points = points[first]
    names = written[first].view(np.int32).astype(np.int64)
    triangles = inverse[piece.triangles]
    keep = (triangles[:, 0] != triangles[:, 1]) & (triangles[:, 1] != triangles[:, 2]) & (triangles[:, 0] != triangles[:, 2])
    triangles = triangles[keep]
    if method in _COLLINEAR_METHODS and triangles.shape[0]:
        triangles = flip_zero_area(np.asarray(points, dtype=np.float64), triangles)
    return points, triangles, names


def _unique_rows(rows: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """First index of each distinct row of an (n, 3) uint32 array and each row's group.

    Rows are grouped by a 64-bit hash (a sort of one column instead of three); a collision (two
    distinct rows, one hash) is detected and then the exact row sort is used."""
    from .chunk_surface import row_hash

    _, first, inverse = np.unique(row_hash(rows), return_index=True, return_inverse=True)
    inverse = inverse.ravel()
    if not np.array_equal(rows[first][inverse], rows):  # pragma: no cover - a 64-bit collision
        _, first, inverse = np.unique(rows, axis=0, return_index=True, return_inverse=True)
        inverse = inverse.ravel()
    return first, inverse


@dataclass
class FilePiece:
    """A chunk's triangles as STL records, its once-used edges and its non-manifold edge count."""

    records: np.ndarray
    once: np.ndarray
    nonmanifold: int


def file_piece(piece: ChunkSurface, method: str, origin: np.ndarray, spacing: np.ndarray) -> FilePiece:
    """What :func:`stream_stl` writes and checks of one chunk (computed where the chunk is)."""
    points, triangles, names = _clean_chunk(piece, method, origin, spacing)
    if triangles.shape[0] == 0:
        return FilePiece(np.zeros(0, dtype=_STL_RECORD), np.zeros((0, 6), dtype=np.int64), 0)
    corners = points[triangles]
    normal = np.cross(corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0])
    length = np.linalg.norm(normal, axis=1, keepdims=True)
    records = np.zeros(len(corners), dtype=_STL_RECORD)
    records["normal"] = np.divide(normal, length, out=np.zeros_like(normal), where=length > 0)
    records["corners"] = corners
    once, over = _chunk_edges(triangles, names)
    return FilePiece(records, once, over)


def _chunk_edges(triangles: np.ndarray, names: np.ndarray) -> tuple[np.ndarray, int]:
    """The directed edges a chunk's triangles use once, as (E, 6) names of their ends,
    and the number of edges used more than twice."""
    n = np.int64(names.shape[0])
    a = np.concatenate([triangles[:, 0], triangles[:, 1], triangles[:, 2]])
    b = np.concatenate([triangles[:, 1], triangles[:, 2], triangles[:, 0]])
    undirected = np.minimum(a, b) * n + np.maximum(a, b)
    _, inverse, count = np.unique(undirected, return_inverse=True, return_counts=True)
    once = count[inverse.ravel()] == 1
    return np.concatenate([names[a[once]], names[b[once]]], axis=1), int(np.count_nonzero(count > 2))


def stream_stl(
    tasks: list,
    path: Path,
    *,
    window: int,
    log: Callable[[str], None] | None = None,
) -> StreamedSurface:
    """Write the chunks' triangles to a binary STL at ``path`` as they finish.

    ``tasks`` give :class:`FilePiece` objects (:func:`file_pieces`). The file is written beside
    ``path`` under a temporary name and renamed when complete.
    """
    import os
    import tempfile

    start = time.perf_counter()
    handle, temporary = tempfile.mkstemp(prefix=".fepre-stl-", suffix=".stl", dir=path.parent)
    count = 0
    seams: list[np.ndarray] = []
    nonmanifold = 0
    done = 0
    try:
        with os.fdopen(handle, "wb") as stream:
            stream.write(b"fepre chunked isosurface".ljust(80, b" "))
            stream.write(np.uint32(0).tobytes())
            for piece in _in_completion_order(tasks, window):
                done += 1
                if count + len(piece.records) > _STL_LIMIT:
                    raise ValueError(
                        f"the surface has more than {_STL_LIMIT:,} triangles, the most a binary STL file can "
                        f"count; use a larger spacing"
                    )
                piece.records.tofile(stream)
                count += len(piece.records)
                seams.append(piece.once)
                nonmanifold += piece.nonmanifold
                if log is not None:
                    log(f"chunk {done}/{len(tasks)}: {count:,} triangles written")
            stream.seek(80)
            stream.write(np.uint32(count).tobytes())
        seam_edges, open_edges, seam_nonmanifold = _match_seams(seams)
        os.replace(temporary, path)
    except BaseException:
        Path(temporary).unlink(missing_ok=True)
        raise
    return StreamedSurface(
        path, count, done, seam_edges, open_edges, nonmanifold + seam_nonmanifold, time.perf_counter() - start
    )


def _match_seams(seams: list[np.ndarray]) -> tuple[int, int, int]:
    """(seam edges, open edges, non-manifold edges) from the chunks' once-used directed edges
    (rows: names of both ends). A closed surface uses each of them once more, in the
    opposite direction, in a neighbouring chunk."""
    if not seams or sum(len(e) for e in seams) == 0:
        return 0, 0, 0
    edges = np.concatenate(seams)
    start, end = edges[:, :3], edges[:, 3:]
    less = _rows_less(start, end)
    low = np.where(less[:, None], start, end)
    high = np.where(less[:, None], end, start)
    _, inverse, count = np.unique(np.concatenate([low, high], axis=1), axis=0, return_inverse=True, return_counts=True)
    inverse = inverse.ravel()
    ahead = np.bincount(inverse, weights=less.astype(float), minlength=count.size)
    paired = (count == 2) & (ahead == 1)  # once each way: consistently oriented
    return int(np.count_nonzero(paired)), int(np.count_nonzero(count == 1)), int(np.count_nonzero(count > 2))


def _rows_less(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Row-wise lexicographic ``a < b`` for (n, 3) integer arrays."""
    differs = a != b
    first = np.argmax(differs, axis=1)
    rows = np.arange(a.shape[0])
    return differs.any(axis=1) & (a[rows, first] < b[rows, first])
