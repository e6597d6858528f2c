"""Streaming a chunked surface to a file: each chunk's triangles written as the chunk finishes.

The surface is never held whole. Each chunk's piece is cleaned where the chunk runs, by rules
every chunk applies alike (:func:`file_piece`), and handed to a *sink* that appends it to the
file: binary STL (a record per triangle) or binary PLY (shared vertices; the vertices on chunk
seams are matched across chunks by their float32 coordinates in a table of seam vertices only).
Each chunk also reports the edges its triangles use once; matched across chunks at the end, they
tell whether the written surface is closed and manifold without reading it back.
"""

from __future__ import annotations

import os
import shutil
import tempfile
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Callable

import numpy as np

from .chunk_surface import ChunkSurface, row_hash
from .cluster import in_completion_order

__all__ = ["StreamedSurface", "FilePiece", "file_piece", "stream_surface", "FORMATS"]

#: streamable file kinds by suffix
FORMATS = {".stl": "stl", ".ply": "ply"}


@dataclass
class StreamedSurface:
    """What :func:`stream_surface` wrote: counts and whether the seams close.

    Attributes
    ----------
    path : pathlib.Path
    n_triangles : int
    n_vertices : int or None
        Vertices written (PLY; None for STL, which has none).
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
    n_vertices: int | None
    chunks: int
    seam_edges: int
    open_edges: int
    nonmanifold_edges: int
    seconds: float

    @property
    def closed(self) -> bool:
        return self.open_edges == 0 and self.nonmanifold_edges == 0


_STL_RECORD = np.dtype([("normal", "<f4", (3,)), ("corners", "<f4", (3, 3)), ("attribute", "<u2")])
_PLY_FACE = np.dtype([("count", "u1"), ("vertices", "<u4", (3,))])
#: a binary STL counts triangles, a PLY (as written here) numbers vertices, in a uint32
_UINT32_LIMIT = 2**32 - 1


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
    from ..surface.weld import drop_unused
    from ..surface.zero_area import flip_zero_area

    units = (piece.points - origin) / spacing
    node = np.rint(units)
    at_node = np.all(np.abs(units - node) <= _NODE_TOLERANCE, axis=1)
    points = piece.points.copy()
    points[at_node] = origin + node[at_node] * spacing  # the crossings of a node on the level, onto it
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
    used, triangles = drop_unused(len(points), triangles)  # vertices whose triangles all collapsed
    return points[used], triangles, names[used]


def _unique_rows(rows: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """First index of each distinct row of an (n, 3) uint32 array and each row's group.

    Rows are grouped by a 64-bit hash (a sort of one column instead of three); a collision (two
    distinct rows, one hash) is detected and then the exact row sort is used."""
    _, first, inverse = np.unique(row_hash(rows), return_index=True, return_inverse=True)
    inverse = inverse.ravel()
    if not np.array_equal(rows[first][inverse], rows):  # pragma: no cover - a 64-bit collision
        _, first, inverse = np.unique(rows, axis=0, return_index=True, return_inverse=True)
        inverse = inverse.ravel()
    return first, inverse


@dataclass
class FilePiece:
    """One chunk, ready for a sink.

    Attributes
    ----------
    payload : np.ndarray or tuple
        STL: the triangle records. PLY: ``(points, triangles, shared)``: float32 vertices, their
        triangles, and which vertices lie on once-used edges (may belong to other chunks too).
    once : (E, 6) int64
        The edges the chunk's triangles use once, as the float32 bits of both ends.
    nonmanifold : int
        Edges of the chunk used by more than two of its triangles.
    n_triangles : int
    """

    payload: object
    once: np.ndarray
    nonmanifold: int
    n_triangles: int


def file_piece(piece: ChunkSurface, method: str, origin: np.ndarray, spacing: np.ndarray, kind: str) -> FilePiece:
    """What a ``kind`` (``"stl"`` or ``"ply"``) sink writes and checks of one chunk."""
    points, triangles, names = _clean_chunk(piece, method, origin, spacing)
    written = points.astype(np.float32)
    if triangles.shape[0] == 0:
        empty = np.zeros(0, dtype=_STL_RECORD) if kind == "stl" else (written, triangles, np.zeros(len(written), bool))
        return FilePiece(empty, np.zeros((0, 6), dtype=np.int64), 0, 0)
    once, over, shared = _chunk_edges(triangles, names)
    if kind == "ply":
        return FilePiece((written + np.float32(0.0), triangles, shared), once, over, len(triangles))
    corners = points[triangles]
    normal = np.cross(corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0])
    length = np.linalg.norm(normal, axis=1, keepdims=True)
    records = np.zeros(len(corners), dtype=_STL_RECORD)
    records["normal"] = np.divide(normal, length, out=np.zeros_like(normal), where=length > 0)
    records["corners"] = corners
    return FilePiece(records, once, over, len(triangles))


def _chunk_edges(triangles: np.ndarray, names: np.ndarray) -> tuple[np.ndarray, int, np.ndarray]:
    """The directed edges a chunk's triangles use once, as (E, 6) names of their ends, the
    number of edges used more than twice, and which vertices end a once-used edge."""
    n = np.int64(names.shape[0])
    a = np.concatenate([triangles[:, 0], triangles[:, 1], triangles[:, 2]])
    b = np.concatenate([triangles[:, 1], triangles[:, 2], triangles[:, 0]])
    undirected = np.minimum(a, b) * n + np.maximum(a, b)
    _, inverse, count = np.unique(undirected, return_inverse=True, return_counts=True)
    once = count[inverse.ravel()] == 1
    shared = np.zeros(names.shape[0], dtype=bool)
    shared[a[once]] = True
    shared[b[once]] = True
    return np.concatenate([names[a[once]], names[b[once]]], axis=1), int(np.count_nonzero(count > 2)), shared


class _StlSink:
    """Triangle records appended after an 80-byte header; the count is written at the end."""

    def __init__(self, stream, folder: Path) -> None:
        self.stream = stream
        self.triangles = 0
        stream.write(b"fepre chunked isosurface".ljust(80, b" "))
        stream.write(np.uint32(0).tobytes())

    def add(self, piece: FilePiece) -> None:
        _check_limit(self.triangles + piece.n_triangles, "triangles", "a binary STL file can count")
        piece.payload.tofile(self.stream)
        self.triangles += piece.n_triangles

    def finish(self) -> int | None:
        self.stream.seek(80)
        self.stream.write(np.uint32(self.triangles).tobytes())
        return None

    def close(self) -> None:
        pass


class _PlySink:
    """Vertices and faces appended to two scratch files beside the output, joined under the
    header (which needs both counts) at the end.

    A vertex on a once-used edge may be written by a neighbouring chunk too: such vertices are
    kept in a table (their float32 coordinates' bytes to their number) and numbered once; the
    table holds the seam vertices only (about 1% of the vertices at 128-node chunks). It is a
    dict: exact, and its lookups cost about a microsecond per seam vertex.
    """

    def __init__(self, stream, folder: Path) -> None:
        self.stream = stream
        self.vertex_file = tempfile.TemporaryFile(dir=folder)
        self.face_file = tempfile.TemporaryFile(dir=folder)
        self.table: dict[bytes, int] = {}
        self.vertices = 0
        self.triangles = 0

    def add(self, piece: FilePiece) -> None:
        points, triangles, shared = piece.payload
        number = np.empty(len(points), dtype=np.int64)
        fresh = np.ones(len(points), dtype=bool)
        rows = np.flatnonzero(shared)
        keys = np.ascontiguousarray(points[rows]).view("V12").ravel().tolist()
        known = [self.table.get(key, -1) for key in keys]
        number[rows] = known
        fresh[rows] = np.asarray(known, dtype=np.int64) < 0
        new = np.flatnonzero(fresh)
        number[new] = self.vertices + np.arange(new.size)
        _check_limit(self.vertices + new.size, "vertices", "this PLY writer can number")
        self.vertices += new.size
        for key, row, found in zip(keys, rows.tolist(), known):
            if found < 0:
                self.table[key] = int(number[row])
        points[new].astype("<f4").tofile(self.vertex_file)
        faces = np.empty(len(triangles), dtype=_PLY_FACE)
        faces["count"] = 3
        faces["vertices"] = number[triangles]
        faces.tofile(self.face_file)
        self.triangles += len(triangles)

    def finish(self) -> int:
        header = (
            "ply\nformat binary_little_endian 1.0\ncomment fepre chunked isosurface\n"
            f"element vertex {self.vertices}\nproperty float x\nproperty float y\nproperty float z\n"
            f"element face {self.triangles}\nproperty list uchar uint vertex_indices\nend_header\n"
        )
        self.stream.write(header.encode("ascii"))
        for scratch in (self.vertex_file, self.face_file):
            scratch.seek(0)
            shutil.copyfileobj(scratch, self.stream, 1 << 24)
        return self.vertices

    def close(self) -> None:
        self.vertex_file.close()
        self.face_file.close()


def _check_limit(count: int, what: str, where: str) -> None:
    if count > _UINT32_LIMIT:
        raise ValueError(f"the surface has more than {_UINT32_LIMIT:,} {what}, the most {where}; use a larger spacing")


def stream_surface(
    pieces: list,
    path: Path,
    *,
    window: int,
    log: Callable[[str], None] | None = None,
) -> StreamedSurface:
    """Write the chunks' pieces (delayed :class:`FilePiece` objects for the file's kind) to
    ``path`` as they finish: written beside it under a temporary name, renamed when complete."""
    kind = FORMATS[path.suffix.lower()]
    start = time.perf_counter()
    handle, temporary = tempfile.mkstemp(prefix=".fepre-surface-", suffix=path.suffix, dir=path.parent)
    seams: list[np.ndarray] = []
    nonmanifold = 0
    done = 0
    sink = None
    try:
        with os.fdopen(handle, "wb") as stream:
            sink = (_StlSink if kind == "stl" else _PlySink)(stream, path.parent)
            for piece in in_completion_order(pieces, window):
                done += 1
                sink.add(piece)
                seams.append(piece.once)
                nonmanifold += piece.nonmanifold
                if log is not None:
                    log(f"chunk {done}/{len(pieces)}: {sink.triangles:,} triangles written")
            vertices = sink.finish()
        seam_edges, open_edges, seam_nonmanifold = _match_seams(seams)
        os.replace(temporary, path)
    except BaseException:
        Path(temporary).unlink(missing_ok=True)
        raise
    finally:
        if sink is not None:
            sink.close()
    return StreamedSurface(
        path, sink.triangles, vertices, done, seam_edges, open_edges, nonmanifold + seam_nonmanifold,
        time.perf_counter() - start,
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
