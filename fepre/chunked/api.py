"""The chunked entry points: ``fepre.isosurface(..., chunks=)`` and :func:`write_isosurface`."""

from __future__ import annotations

from pathlib import Path
from typing import Any, Callable

import numpy as np

from ..arguments import choice, finite_float, nonnegative_float, positive_int, shown
from ..sdf.core import SDF
from .cluster import check_picklable, needs_pickling, require_dask
from .grid import ChunkedGrid
from .layout import ChunkLayout
from .stream import FORMATS, StreamedSurface, stream_surface
from .surface import chunk_tasks, file_pieces, surface_in_memory

__all__ = ["isosurface_chunked", "write_isosurface"]


def _default_band(level: float, step: np.ndarray) -> float:
    """Two cell diagonals beyond the level: every crossing and its cells are sampled exactly."""
    return abs(level) + 2.0 * float(np.linalg.norm(step))


def _plan(source, *, method, level, chunks, spacing, shape, bounds, band, model, dtype="float32"):
    """Check everything and return what the tasks need, before any chunk is computed."""
    from ..sampling import grid_geometry
    from ..surface.extract import METHODS

    require_dask("chunked grids")
    method = choice(method, "method", METHODS)
    level = finite_float(level, "level")
    if isinstance(source, ChunkedGrid):
        for option, value in (("spacing", spacing), ("shape", shape), ("bounds", bounds), ("band", band)):
            if value is not None:
                raise ValueError(f"{option} applies only when source is a model; the ChunkedGrid is already sampled")
        if chunks is not None and ChunkLayout.of(source.layout.counts, chunks) != source.layout:
            raise ValueError(
                f"chunks={shown(chunks)} differs from the ChunkedGrid's chunks {source.chunks}; omit chunks "
                f"(the grid's are used) or sample the grid with these chunks"
            )
        if model is None:
            model = source.model
        if source.band is not None and abs(level) > source.band - float(np.linalg.norm(source.spacing)):
            raise ValueError(
                f"level {level:g} is not inside the sampled band (half-width {source.band:g}); sample with a wider band"
            )
        layout, origin, step = source.layout, source.origin, source.spacing
        dtype = source.values.dtype
    elif isinstance(source, SDF):
        if model is not None:
            raise ValueError("model applies only when source is a ChunkedGrid; the source is already a model")
        if source.dim != 3:
            raise ValueError(f"model must be 3D to sample onto an image grid; got a {source.dim}D model")
        if chunks is None:
            raise ValueError("chunks is required to extract a model chunk by chunk (nodes per chunk, e.g. 128)")
        origin, step, counts = grid_geometry(source, spacing=spacing, shape=shape, bounds=bounds)
        layout = ChunkLayout.of(counts, chunks)
        if band is None:
            band = _default_band(level, step)
        else:
            band = max(nonnegative_float(band, "band"), float(np.linalg.norm(step)))
            if abs(level) > band - float(np.linalg.norm(step)):
                raise ValueError(f"band {band:g} does not contain level {level:g}; use band > |level| + one cell diagonal")
        model = source
    else:
        raise TypeError(f"source must be a fepre.sdf.SDF or a fepre.chunked.ChunkedGrid; got {type(source).__name__}")
    if model is not None and needs_pickling():
        check_picklable(model)
    return method, level, layout, origin, step, band, np.dtype(dtype), model


def isosurface_chunked(
    source: Any,
    *,
    method: str,
    level: float,
    chunks: Any,
    spacing: Any,
    shape: Any,
    bounds: Any,
    band: float | None,
    model: SDF | None,
    normals: bool,
    progress: bool = False,
):
    """The single-grid surface, computed chunk by chunk on dask and stitched (see
    :func:`fepre.isosurface`)."""
    from ..surface.extract import clean_triangles, surface_dataset

    method, level, layout, origin, step, band, dtype, model = _plan(
        source, method=method, level=level, chunks=chunks, spacing=spacing, shape=shape, bounds=bounds,
        band=band, model=model,
    )
    tasks = chunk_tasks(
        source, method=method, level=level, layout=layout, origin=origin, step=step, band=band, dtype=dtype,
        model=model,
    )
    points, triangles, on_level = surface_in_memory(tasks, progress)
    points, triangles = clean_triangles(points, triangles, method, on_level, step, origin)

    def value_range():
        if isinstance(source, ChunkedGrid):
            return float(source.values.min().compute()), float(source.values.max().compute())
        return (-band, band)  # a banded sampling holds at most the band

    surface = surface_dataset(
        points, triangles, method=method, level=level, grid=(origin, step, layout.counts), normals=normals,
        model=model, value_range=value_range,
    )
    surface.field_data["surface_chunks"] = np.array([len(s) for s in layout.sizes], dtype=np.int64)
    return surface


def write_isosurface(
    source: Any,
    path: Any,
    *,
    method: str = "flying_edges",
    level: float = 0.0,
    chunks: Any = None,
    spacing: Any = None,
    shape: Any = None,
    bounds: Any = None,
    band: float | None = None,
    model: SDF | None = None,
    window: int | None = None,
    log: Callable[[str], None] | None = None,
) -> StreamedSurface:
    """Extract the ``level`` set chunk by chunk and stream it to a binary STL or PLY file.

    The surface is never held whole: each chunk's triangles are written as the chunk finishes
    (at most ``window`` chunks in flight), and the seams between chunks are checked from the
    chunks' open edges, so the result reports whether the written surface is closed and
    manifold. Triangles are those of :func:`fepre.isosurface` on the whole grid, except that
    coincident vertices and collinear triangles are cleaned per chunk (a zero-area triangle on
    a chunk face whose flip partner lies in the next chunk is kept).

    Parameters
    ----------
    source : fepre.sdf.SDF or fepre.chunked.ChunkedGrid
        A model (each chunk is sampled where dask runs it) or a chunked grid.
    path : str or os.PathLike
        The ``.stl`` or ``.ply`` file to write (replaced if it exists; written under a temporary
        name beside it and renamed when complete). PLY shares vertices (about 2.5 times smaller).
    method, level, spacing, shape, bounds, model
        As for :func:`fepre.isosurface`.
    chunks : int or (3,) ints
        Nodes per chunk along x, y, z (at least 8; required for a model).
    band : float, optional
        Narrow band half-width for a model (default two cell diagonals beyond the level):
        chunks farther from the surface are skipped without evaluating the model.
    window : int, optional
        Chunks in flight at once (default four per dask worker thread or process).
    log : callable, optional
        Called with a progress line after each chunk.

    Returns
    -------
    StreamedSurface

    Examples
    --------
    >>> import tempfile, pathlib, pyvista as pv
    >>> from fepre import sdf
    >>> from fepre.chunked import write_isosurface
    >>> path = pathlib.Path(tempfile.mkdtemp()) / "ball.stl"
    >>> written = write_isosurface(sdf.sphere(1.0), path, spacing=0.1, chunks=12)
    >>> written.closed, written.n_triangles == pv.read(path).n_cells
    (True, True)
    """
    if not isinstance(path, (str, Path)) and not hasattr(path, "__fspath__"):
        raise TypeError(f"path must be a file path; got {type(path).__name__}")
    path = Path(path)
    if path.suffix.lower() not in FORMATS:
        raise ValueError(
            f"path: a streamed surface is written as binary STL or PLY; got {str(path)!r} (use a .stl or .ply name)"
        )
    if not path.parent.is_dir():
        raise FileNotFoundError(f"path: folder {str(path.parent)!r} does not exist (for {str(path)!r})")
    method, level, layout, origin, step, band, dtype, model = _plan(
        source, method=method, level=level, chunks=chunks, spacing=spacing, shape=shape, bounds=bounds,
        band=band, model=model,
    )
    if window is None:
        window = 4 * _dask_workers()
    window = positive_int(window, "window")
    tasks = chunk_tasks(
        source, method=method, level=level, layout=layout, origin=origin, step=step, band=band, dtype=dtype,
        model=model, named=False,
    )
    pieces = file_pieces(tasks, method, origin, step, FORMATS[path.suffix.lower()])
    return stream_surface(pieces, path, window=window, log=log)


def _dask_workers() -> int:
    """Threads (or worker threads of the distributed cluster) dask will run tasks on."""
    import os

    from .cluster import distributed_client

    client = distributed_client()
    if client is not None:
        return max(1, sum(client.nthreads().values()))
    import dask

    return int(dask.config.get("num_workers", None) or os.cpu_count() or 1)
