"""Sample a model onto a VTK image grid: dense (chunked, threaded) or in a narrow band.

The grid is a :class:`pyvista.ImageData` with the point array ``"sdf"`` in VTK order. Dense
sampling goes through :meth:`fepre.sdf.SDF.values_on_axes`, which never materialises the
coordinates of the whole grid.

Narrow band: the grid is cut into blocks of 8^3 nodes and the model is first evaluated at each
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

from .arguments import as_bounds, as_vector, nonnegative_float, positive_int
from .config import config
from .sdf.core import SDF, thread_pool

__all__ = ["sample", "grid_geometry"]

BLOCK = 8
_BLOCKS_PER_BATCH = 64


def _format_bytes(count: float) -> str:
    for unit in ("B", "KiB", "MiB", "GiB", "TiB"):
        if count < 1024 or unit == "TiB":
            return f"{count:.1f} {unit}"
        count /= 1024
    return f"{count:.1f} TiB"  # pragma: no cover


def _shape_vector(shape: Any) -> np.ndarray:
    if isinstance(shape, (int, np.integer)) and not isinstance(shape, bool):
        shape = (shape,) * 3
    try:
        entries = list(shape)
    except TypeError:
        raise TypeError(f"shape must be an int or a sequence of 3 ints; got {shape!r}") from None
    if len(entries) != 3:
        raise ValueError(f"shape must be an int or a sequence of 3 ints; got {shape!r}")
    result = []
    for entry in entries:
        if isinstance(entry, bool) or not isinstance(entry, (int, np.integer)):
            raise TypeError(f"shape must contain integers; got {shape!r}")
        if entry < 2:
            raise ValueError(f"shape must have at least 2 nodes per axis; got {shape!r}")
        result.append(int(entry))
    return np.array(result)


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
        if model is None or model.bounds is None:
            raise ValueError(
                "bounds is required: the model is unbounded (its bounds are None); pass "
                "bounds=((xmin, ymin, zmin), (xmax, ymax, zmax))"
            )
        lo, hi = (np.array(b, dtype=float) for b in model.bounds)
        if not (np.isfinite(lo).all() and np.isfinite(hi).all()):
            raise ValueError(f"bounds is required: the model's bounds {model.bounds} are not finite")
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
                    raise ValueError(f"shape must have at least 6 nodes per axis to pad the model by two cells; got {shape!r}")
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
            raise ValueError(f"spacing must be > 0; got {spacing!r}")
        largest = float(np.max(extent))
        if np.any(step > largest):
            raise ValueError(
                f"spacing {spacing!r} is larger than the model (largest extent {largest:g}); "
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


def _sample_band(model: SDF, axes: list[np.ndarray], step: np.ndarray, band: float, dtype, workers: int):
    """Banded sampling on (x, y, z) axes; returns the array and the number of evaluations."""
    nx, ny, nz = (a.size for a in axes)
    out = np.empty((nz, ny, nx), dtype=dtype)
    starts, owners = [], []
    for axis in axes:
        n = axis.size
        count = max(1, math.ceil(n / BLOCK))
        starts.append(np.minimum(np.arange(count) * BLOCK, max(n - BLOCK, 0)))
        owners.append(np.minimum(np.arange(n) // BLOCK, count - 1))
    width = [min(BLOCK, a.size) for a in axes]
    centres = [
        axis[s].astype(np.float64) + (w - 1) / 2 * h for axis, s, w, h in zip(axes, starts, width, step)
    ]
    centre_values = model.values_on_axes(*centres, dtype=np.float64, workers=workers)
    half_diagonal = 0.5 * float(np.sqrt(np.sum(((np.array(width) - 1) * step) ** 2)))
    margin = half_diagonal + band + 1e-6 * (half_diagonal + band)
    active = np.abs(centre_values) <= margin
    fill = np.where(centre_values > 0, band, -band).astype(dtype)

    slab_fill = fill[:, :, owners[0]]  # (blocks z, blocks y, nx)
    slab_starts = list(range(0, nz, BLOCK))

    def fill_slab(z0: int) -> None:
        bz = owners[2][z0]
        out[z0 : z0 + BLOCK] = slab_fill[bz][owners[1]][None, :, :]

    bz, by, bx = np.nonzero(active)
    batches = range(0, bz.size, _BLOCKS_PER_BATCH)
    local = [np.arange(w) for w in width]

    def evaluate(first: int) -> None:
        sl = slice(first, first + _BLOCKS_PER_BATCH)
        iz = starts[2][bz[sl]][:, None] + local[2]
        iy = starts[1][by[sl]][:, None] + local[1]
        ix = starts[0][bx[sl]][:, None] + local[0]
        z = axes[2][iz][:, :, None, None]
        y = axes[1][iy][:, None, :, None]
        x = axes[0][ix][:, None, None, :]
        values = model._values(x, y, z)
        out[iz[:, :, None, None], iy[:, None, :, None], ix[:, None, None, :]] = values

    pool = thread_pool(workers) if workers > 1 else None
    if pool is None:
        for z0 in slab_starts:
            fill_slab(z0)
        for first in batches:
            evaluate(first)
    else:
        list(pool.map(fill_slab, slab_starts))
        list(pool.map(evaluate, batches))
    evaluated = centre_values.size + bz.size * width[0] * width[1] * width[2]
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
):
    """Sample ``model`` on a regular grid and return it as a :class:`pyvista.ImageData`.

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
        Threads (default ``fepre.config.workers``).

    Returns
    -------
    pyvista.ImageData
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
        raise ValueError(f"model must be 3D to sample onto an image grid; got a {model.dim}D model (extrude or revolve it)")
    dtype = np.dtype(dtype)
    if dtype not in (np.dtype(np.float32), np.dtype(np.float64)):
        raise ValueError(f"dtype must be 'float32' or 'float64'; got {dtype.name!r}")
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
        values, evaluated = _sample_band(model, [a.astype(dtype) for a in axes], step, band, dtype, workers)
    grid = pv.ImageData(dimensions=tuple(int(c) for c in counts), spacing=tuple(step), origin=tuple(origin))
    grid.point_data["sdf"] = values.reshape(-1)
    grid.field_data["sdf_evaluated_fraction"] = np.array([min(1.0, evaluated / total)])
    if band is not None:
        grid.field_data["sdf_band"] = np.array([band])
    return grid
