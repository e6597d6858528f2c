"""Lazy chunked sampling: one dask task per chunk, with chunks far from the surface skipped.

Each task evaluates the model on its chunk's slice of the grid's own axes, so a chunk's values
are bit for bit those of :func:`fepre.sample` on the whole grid. With a narrow band, a chunk
whose centre value ``c`` satisfies ``|c| > r + w`` (``r`` its half-diagonal, ``w`` the band) is
filled with ``±w`` without evaluating anything (models are 1-Lipschitz); the chunks left are
sampled in the band block by block as :func:`fepre.sample` does.
"""

from __future__ import annotations

import os
import shutil
import tempfile
import uuid
from pathlib import Path
from typing import Any

import numpy as np

from ..arguments import nonnegative_float
from .grid import ChunkedGrid
from .layout import ChunkLayout

__all__ = ["sample_model", "sample_chunked", "sample_nodes", "check_store"]


def _axes(origin: np.ndarray, step: np.ndarray, lo: np.ndarray, hi: np.ndarray) -> list[np.ndarray]:
    """The whole grid's axes (as :func:`fepre.sample` computes them) restricted to ``[lo, hi)``."""
    return [origin[a] + step[a] * np.arange(lo[a], hi[a]) for a in range(3)]


def sample_nodes(model, origin, step, lo, hi, band: float | None, dtype) -> np.ndarray:
    """Samples (z, y, x) of the nodes ``[lo, hi)`` of the grid; banded when ``band`` is given."""
    from ..sampling import _sample_band

    axes = _axes(origin, step, lo, hi)
    if band is None:
        return model.values_on_axes(*axes, dtype=dtype, workers=1)
    far = far_value(model, axes, band)
    if far is not None:
        return np.full(tuple(int(h - l) for l, h in zip(lo[::-1], hi[::-1])), far, dtype=dtype)
    return _sample_band(model, axes, step, band, np.dtype(dtype), 1)[0]


def far_value(model, axes: list[np.ndarray], band: float) -> float | None:
    """``±band`` when every node on ``axes`` is farther than ``band`` from the surface, else None."""
    low = np.array([a[0] for a in axes], dtype=np.float64)
    high = np.array([a[-1] for a in axes], dtype=np.float64)
    centre = 0.5 * (low + high)
    radius = 0.5 * float(np.linalg.norm(high - low))
    value = float(np.asarray(model(centre[None, :]), dtype=np.float64)[0])
    margin = radius + band + 1e-6 * (radius + band)
    if abs(value) <= margin:
        return None
    return band if value > 0 else -band


def check_store(store: Any, overwrite: bool) -> Path:
    """The store path, checked before any work: its folder exists, and it does not unless
    ``overwrite``."""
    if not isinstance(store, (str, os.PathLike)):
        raise TypeError(f"store must be a path (str or os.PathLike); got {type(store).__name__}")
    path = Path(store)
    if not path.parent.is_dir():
        raise FileNotFoundError(f"store: folder {str(path.parent)!r} does not exist (for {str(path)!r})")
    if path.exists() and not overwrite:
        raise FileExistsError(f"store: {str(path)!r} already exists; pass overwrite=True to replace it")
    return path


def sample_model(model, *, spacing, shape, bounds, padding, dtype, band, chunks, store, overwrite) -> ChunkedGrid:
    """``fepre.sample(model, ..., chunks=)``, its arguments checked by :func:`fepre.sample`:
    dask and the chunks checked, the grid laid out as the single grid is, the lazy grid made."""
    from ..sampling import grid_geometry
    from .cluster import require_dask
    from .layout import as_chunks

    require_dask("sample(chunks=...)")
    as_chunks(chunks)
    origin, step, counts = grid_geometry(model, spacing=spacing, shape=shape, bounds=bounds, padding=padding)
    if band is not None:
        band = max(nonnegative_float(band, "band"), float(np.linalg.norm(step)))
    return sample_chunked(model, origin, step, counts, chunks, dtype=dtype, band=band, store=store, overwrite=overwrite)


def sample_chunked(
    model,
    origin: np.ndarray,
    step: np.ndarray,
    counts: np.ndarray,
    chunks: Any,
    *,
    dtype: Any = "float32",
    band: float | None = None,
    store: Any = None,
    overwrite: bool = False,
) -> ChunkedGrid:
    """The lazy chunked grid of ``model``; computed into a zarr ``store`` when one is given."""
    import dask
    import dask.array as da

    from .cluster import check_picklable, needs_pickling

    layout = ChunkLayout.of(counts, chunks)
    dtype = np.dtype(dtype)
    path = check_store(store, overwrite) if store is not None else None
    if needs_pickling():
        check_picklable(model)
    shared = dask.delayed(model, pure=True, name=f"fepre-model-{uuid.uuid4().hex}")
    task = dask.delayed(sample_nodes, pure=True)
    blocks = np.empty([len(s) for s in layout.dask_chunks], dtype=object)
    for index, lo, hi in layout:
        shape = tuple(int(h - l) for l, h in zip(lo[::-1], hi[::-1]))
        blocks[index] = da.from_delayed(task(shared, origin, step, lo, hi, band, dtype), shape, dtype=dtype)
    values = da.block(blocks.tolist())
    grid = ChunkedGrid(values, origin, step, layout, band=band, model=model)
    if path is None:
        return grid
    return _write_store(grid, path)


def _write_store(grid: ChunkedGrid, path: Path) -> ChunkedGrid:
    """Compute ``grid`` into a zarr store at ``path``: written in a staging folder beside it and
    moved into place once complete (a failed run leaves nothing behind)."""
    import dask.array as da
    import zarr

    from .grid import open_grid

    stage = Path(tempfile.mkdtemp(prefix=".fepre-store-", dir=path.parent))
    try:
        staged = stage / path.name
        da.to_zarr(grid.values, str(staged))
        array = zarr.open_array(str(staged), mode="r+")
        array.attrs.update(
            {
                "fepre": "sdf-grid",
                "origin": [float(v) for v in grid.origin],
                "spacing": [float(v) for v in grid.spacing],
                "chunk_sizes": [list(s) for s in grid.layout.sizes],
                "band": grid.band,
            }
        )
        if path.exists():
            old = stage / (path.name + ".old")
            os.replace(path, old)
        os.replace(staged, path)
    finally:
        shutil.rmtree(stage, ignore_errors=True)
    opened = open_grid(path)
    opened.model = grid.model
    return opened
