"""Sample a model onto a VTK image grid: dense (chunked, threaded) or in a narrow band.

The grid is a :class:`pyvista.ImageData` with the point array ``"sdf"`` in VTK order. Dense
sampling goes through :meth:`fepre.sdf.SDF.values_on_axes`, which never materialises the
coordinates of the whole grid.

Narrow band: the grid is cut into blocks of about 8^3 nodes and the model is first evaluated at each
block's centre. Because every model is 1-Lipschitz, a block whose centre value ``c`` satisfies
``|c| > r + w`` (``r`` its half-diagonal, ``w`` the band) has ``|value| > w`` at all its nodes, all
of the sign of ``c``; such a block is filled with ``±w`` instead of being evaluated. With ``w`` at
least one cell diagonal, a cell holding a filled node has all eight corners on that node's side
in the true field as well, so the level-0 surface of a banded grid is identical to the dense one.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from .arguments import as_bounds, as_vector, domain_bounds, int_triple, nonnegative_float, shown
from .backends import provided
from .config import config
from .sdf.core import SDF, ScratchArenas, _far_for_single, give_scratch, take_scratch, thread_pool

__all__ = ["sample", "grid_geometry"]

BLOCK = 8


def _format_bytes(count: float) -> str:
    for unit in ("B", "KiB", "MiB", "GiB", "TiB"):
        if count < 1024 or unit == "TiB":
            return f"{count:.1f} {unit}"
        count /= 1024
    return f"{count:.1f} TiB"  # pragma: no cover


def _shape_vector(shape: Any) -> np.ndarray:
    return int_triple(shape, "shape", 2)


def grid_geometry(
    model: SDF | None,
    *,
    spacing: Any = None,
    shape: Any = None,
    bounds: Any = None,
    padding: float | None = None,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Origin (3,), spacing (3,) and node counts (nx, ny, nz) of the grid ``sample`` would build.

    With ``bounds`` the grid spans exactly that box; otherwise the model's bounds grown by
    ``padding`` (world units; default two cells). ``spacing`` (a number or one per axis) keeps the
    box centred and rounds the node count up; ``shape`` (an int or one per axis) fixes the counts.
    Neither: 128 cells along the longest axis.
    """
    if spacing is not None and shape is not None:
        raise ValueError("give spacing or shape, not both")
    if bounds is None:
        if model is None:
            raise ValueError("bounds is required without a model")
        lo, hi = (np.array(b, dtype=float) for b in domain_bounds(model, None))
        padded = True
    else:
        lo, hi = (np.array(b) for b in as_bounds(bounds, 3, "bounds"))
        padded = False
    if padding is not None:
        padding = nonnegative_float(padding, "padding")
    extent = hi - lo
    if shape is not None:
        counts = _shape_vector(shape)
        if padded:
            if padding is None:  # two cells of padding on each side
                if np.any(counts < 6):
                    raise ValueError(
                        f"shape must have at least 6 nodes per axis to pad the model by two cells; got {shown(shape)}"
                    )
                step = np.where(extent > 0, extent, 1.0) / (counts - 5)
                lo, hi = lo - 2 * step, hi + 2 * step
            else:
                lo, hi = lo - padding, hi + padding
        step = (hi - lo) / (counts - 1)
        return lo, step, counts
    if spacing is None:
        step = np.full(3, float(np.max(extent)) / 128.0)
    else:
        step = as_vector(spacing, 3, "spacing", allow_scalar=True)
        if np.any(step <= 0):
            raise ValueError(f"spacing must be > 0; got {shown(spacing)}")
        largest = float(np.max(extent))
        if np.any(step > largest):
            raise ValueError(
                f"spacing {shown(spacing)} is larger than the model (largest extent {largest:g}); "
                f"use a spacing below {largest / 4:g}"
            )
    if padded:
        pad = 2 * step if padding is None else np.maximum(padding, 0.0)
        lo, hi = lo - pad, hi + pad
    counts = np.ceil((hi - lo) / step - 1e-9).astype(np.int64) + 1
    centre = (lo + hi) / 2
    origin = centre - step * (counts - 1) / 2
    return origin, step, counts


def _check_memory(counts: np.ndarray, dtype: np.dtype) -> None:
    needed = float(np.prod(counts.astype(float))) * dtype.itemsize
    if needed > config.max_grid_bytes:
        raise ValueError(
            f"the grid of {counts[0]} x {counts[1]} x {counts[2]} nodes would need "
            f"{_format_bytes(needed)} of {dtype.name}, more than fepre.config.max_grid_bytes = "
            f"{_format_bytes(config.max_grid_bytes)}; use a larger spacing, a smaller shape or "
            f"tighter bounds, or raise fepre.config.max_grid_bytes"
        )


def _sample_band(model: SDF, axes: list[np.ndarray], step: np.ndarray, band: float, dtype, workers: int, blocks=None):
    """Banded sampling on (x, y, z) axes; returns the array and the number of evaluations.

    ``blocks``: optional ``(centres (B, 3)) -> (B,) bool``, the blocks wanted at all (the others
    are filled, whatever their distance).

    Blocks are aligned (the last one per axis may be short) and about ``BLOCK`` nodes wide along
    the finest axis, fewer along coarser axes, so they stay roughly cubic in world units. Runs of
    all active blocks of a z slab are evaluated in one broadcast call; each run of consecutive
    active blocks along x is then copied into the output as contiguous rows.
    """
    counts = [a.size for a in axes]
    finest = float(step.min())
    width = [max(2, min(n, 1 + int(round((BLOCK - 1) * finest / h)))) for n, h in zip(counts, step)]
    nblocks = [-(-n // w) for n, w in zip(counts, width)]
    starts = [np.arange(b) * w for b, w in zip(nblocks, width)]
    sizes = [np.minimum(w, n - s) for w, n, s in zip(width, counts, starts)]
    centres = [
        axis[s].astype(np.float64) + (size - 1) / 2 * h for axis, s, size, h in zip(axes, starts, sizes, step)
    ]
    centre_values = model.values_on_axes(*centres, dtype=np.float64, workers=workers)
    half_diagonal = 0.5 * float(np.sqrt(np.sum(((np.array(width) - 1) * step) ** 2)))
    margin = half_diagonal + band + 1e-6 * (half_diagonal + band)
    active = np.abs(centre_values) <= margin  # (blocks z, blocks y, blocks x)
    if blocks is not None:
        z, y, x = np.meshgrid(centres[2], centres[1], centres[0], indexing="ij")
        active &= np.asarray(blocks(np.column_stack([x.ravel(), y.ravel(), z.ravel()])), bool).reshape(active.shape)
    fill = np.where(centre_values > 0, band, -band).astype(dtype)
    wx, wy, wz = width
    nx, ny, nz = counts
    row_fill = np.repeat(fill, wx, axis=2)[:, :, :nx]  # (blocks z, blocks y, nx), rows contiguous
    whole_y = ny // wy  # block rows without the short last one

    edges = np.diff(np.pad(active, ((0, 0), (0, 0), (1, 1))).view(np.int8), axis=2)
    run_z, run_y, run_start = np.nonzero(edges == 1)
    run_end = np.nonzero(edges == -1)[2]
    x_lo = run_start * wx
    x_hi = np.minimum(run_end * wx, nx)
    slab_runs = np.searchsorted(run_z, np.arange(nblocks[2] + 1)).tolist()
    # per run, as Python ints for the copy loop: rows y0:y1, columns x_lo:x_hi of the grid, and
    # the first column of the run in its slab's block of values
    y_lo = run_y * wy
    first_column = (np.cumsum(run_end - run_start) - (run_end - run_start)) * wx
    first_column -= first_column[np.asarray(slab_runs[:-1])[run_z]] if run_z.size else 0
    runs = list(zip(y_lo.tolist(), np.minimum(y_lo + wy, ny).tolist(), x_lo.tolist(), x_hi.tolist(), first_column.tolist()))
    block_z, block_y, block_x = np.nonzero(active)  # same order as the runs' blocks
    slab_blocks = np.searchsorted(block_z, np.arange(nblocks[2] + 1))
    # axes extended to whole blocks, so every block is evaluated at full size; in float64 where
    # float32 coordinates would move the nodes (a part placed at 1e4), as values_on_axes does
    coordinates = np.float64 if np.dtype(dtype).itemsize < 8 and _far_for_single(axes) else dtype
    padded = [
        (axis[0] + h * np.arange(b * w)).astype(coordinates) for axis, h, b, w in zip(axes, step, nblocks, width)
    ]
    local = [np.arange(w) for w in width]
    out = np.empty((nz, ny, nx), dtype=dtype)

    def slab(bz: int) -> None:
        z0, z1 = bz * wz, min((bz + 1) * wz, nz)
        depth = z1 - z0
        # Fill: each node row takes its block row's fill row, in one broadcast copy per slab.
        rows = out[z0:z1, : whole_y * wy]
        rows.shape = (depth, whole_y, wy, nx)  # a view (raises rather than copy)
        rows[...] = row_fill[bz, :whole_y, None, :]
        if whole_y * wy < ny:
            out[z0:z1, whole_y * wy :] = row_fill[bz, whole_y]
        first, last = slab_blocks[bz], slab_blocks[bz + 1]
        if first == last:
            return
        # The active blocks of the slab side by side along x, as one grid block of shape
        # (wz, wy, blocks * wx): y is repeated along each block's x values so that every numpy
        # loop runs along whole rows, and each run of blocks comes out as contiguous rows.
        count = last - first
        columns = (block_x[first:last] * wx)[:, None] + local[0]
        lines = (block_y[first:last] * wy)[None, :] + local[1][:, None]
        x = padded[0][columns].reshape(1, 1, count * wx)
        y = np.repeat(padded[1][lines], wx, axis=1).reshape(1, wy, count * wx)
        z = padded[2][bz * wz + local[2]][:, None, None]
        values = take_scratch((wz, wy, count * wx), dtype)
        model._values_into(values, x, y, z)
        settle_grid_block(model, values, (x, y, z))
        for y0, y1, x0, x1, column in runs[slab_runs[bz] : slab_runs[bz + 1]]:
            out[z0:z1, y0:y1, x0:x1] = values[:depth, : y1 - y0, column : column + x1 - x0]
        give_scratch(values)

    from .sdf.touching import settle_grid_block

    arenas = ScratchArenas()
    if workers > 1:
        list(thread_pool(workers).map(lambda bz: arenas.run(slab, bz), range(nblocks[2])))
    else:
        for bz in range(nblocks[2]):
            arenas.run(slab, bz)
    z_sizes, y_sizes = sizes[2][run_z], sizes[1][run_y]
    evaluated = centre_values.size + int(np.sum(z_sizes * y_sizes * (x_hi - x_lo)))
    return out, evaluated


def sample(
    model: SDF,
    *,
    spacing: Any = None,
    shape: Any = None,
    bounds: Any = None,
    padding: float | None = None,
    dtype: Any = "float32",
    band: float | None = None,
    workers: int | None = None,
    chunks: Any = None,
    store: Any = None,
    overwrite: bool = False,
):
    """Sample ``model`` on a regular grid and return it as a :class:`pyvista.ImageData`
    (or, with ``chunks``, as a lazy :class:`fepre.chunked.ChunkedGrid`).

    Parameters
    ----------
    model : fepre.sdf.SDF
        A 3D model.
    spacing : float or (3,) floats, optional
        Node spacing; the grid box is centred on the requested box and the node counts rounded
        up. Give ``spacing`` or ``shape``; with neither, 128 cells along the longest axis.
    shape : int or (nx, ny, nz), optional
        Node counts per axis.
    bounds : ((xmin, ymin, zmin), (xmax, ymax, zmax)), optional
        The grid's box. Default: the model's bounds grown by ``padding``.
    padding : float, optional
        Margin around the model's bounds, in world units (default two cells, so the surface is
        closed). Ignored when ``bounds`` is given.
    dtype : {"float32", "float64"}
    band : float, optional
        Narrow band half-width (world units): only blocks that may hold values within the band
        are evaluated; the rest hold ``±band``. Widened to one cell diagonal if smaller.
    workers : int, optional
        Threads (default ``fepre.config.workers``; with ``chunks`` dask's scheduler decides).
    chunks : int or (3,) ints, optional
        Nodes per chunk along x, y, z (at least 8): return a lazy
        :class:`fepre.chunked.ChunkedGrid` (a dask array with the grid's origin and spacing)
        whose chunks are evaluated where dask runs them, bit for bit as the whole grid would be;
        with ``band``, chunks farther than the band from the surface are filled without
        evaluating the model. Needs ``pip install 'fepre[dask]'``.
    store : str or os.PathLike, optional
        With ``chunks``: compute the grid into this zarr store (written beside it under a
        temporary name, moved into place when complete) and return the grid read from it.
    overwrite : bool
        Replace an existing ``store``.

    Returns
    -------
    pyvista.ImageData or fepre.chunked.ChunkedGrid
        Point array ``"sdf"``; field data ``"sdf_evaluated_fraction"`` (nodes evaluated / nodes)
        and, when banded, ``"sdf_band"``.

    Examples
    --------
    >>> import fepre
    >>> from fepre import sdf
    >>> grid = fepre.sample(sdf.sphere(1.0), spacing=0.1)
    >>> grid.dimensions
    (25, 25, 25)
    >>> float(grid["sdf"].min()) < 0 < float(grid["sdf"].max())
    True
    """
    import pyvista as pv

    if not isinstance(model, SDF):
        raise TypeError(f"model must be a fepre.sdf.SDF; got {type(model).__name__}")
    if model.dim != 3:
        raise ValueError(
            f"model must be 3D to sample onto an image grid; got a {model.dim}D model (extrude or revolve it)"
        )
    dtype = np.dtype(dtype)
    if dtype not in (np.dtype(np.float32), np.dtype(np.float64)):
        raise ValueError(f"dtype must be 'float32' or 'float64'; got {dtype.name!r}")
    if store is not None and chunks is None:
        raise ValueError("store needs chunks: a zarr store holds a chunked grid (pass chunks=, e.g. 128)")
    if chunks is not None:  # fepre.chunked, above this module (see fepre.backends)
        return provided("sample_chunked")(
            model, spacing=spacing, shape=shape, bounds=bounds, padding=padding, dtype=dtype, band=band,
            chunks=chunks, store=store, overwrite=overwrite,
        )
    workers = config.resolve_workers(workers)
    origin, step, counts = grid_geometry(model, spacing=spacing, shape=shape, bounds=bounds, padding=padding)
    _check_memory(counts, dtype)
    axes = [origin[a] + step[a] * np.arange(counts[a]) for a in range(3)]
    total = int(np.prod(counts))
    if band is None:
        values = model.values_on_axes(*axes, dtype=dtype, workers=workers)
        evaluated = total
    else:
        band = max(nonnegative_float(band, "band"), float(np.linalg.norm(step)))
        values, evaluated = _sample_band(model, axes, step, band, dtype, workers)
    grid = pv.ImageData(dimensions=tuple(int(c) for c in counts), spacing=tuple(step), origin=tuple(origin))
    grid.point_data["sdf"] = values.reshape(-1)
    grid.field_data["sdf_evaluated_fraction"] = np.array([min(1.0, evaluated / total)])
    if band is not None:
        grid.field_data["sdf_band"] = np.array([band])
    return grid
