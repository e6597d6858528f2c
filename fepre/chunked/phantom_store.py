"""Phantoms too large for memory, written chunk by chunk to a zarr store.

The image of :func:`fepre.sdf.imagemodel.phantoms.partial_volume` (each voxel's share inside an
analytic model) and the label image of :func:`fepre.sdf.imagemodel.phantoms.label_image` (the
label of the last model holding each voxel centre), but computed one chunk at a time on threads
and written straight into a zarr array indexed ``[i, j, k]`` along x, y, z with ``spacing`` and
``origin`` attributes, which :func:`fepre.sdf.image` and :func:`fepre.sdf.labels` read back
chunk by chunk. A chunk whose centre is farther from a model's surface than its half-diagonal
(the model is 1-Lipschitz) is all inside or all outside it after one evaluation.
"""

from __future__ import annotations

import os
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path
from typing import Any

import numpy as np

from ..arguments import positive_float
from ..sdf.imagemodel.phantoms import voxel_shares
from .cluster import require_dask
from .layout import ChunkLayout

__all__ = ["write_partial_volume", "write_label_image"]


def _block(model, store, first: np.ndarray, spacing: float, lo: np.ndarray, hi: np.ndarray, sub: int) -> None:
    axes = [first[k] + spacing * np.arange(lo[k], hi[k]) for k in range(3)]
    centre = np.array([0.5 * (a[0] + a[-1]) for a in axes])
    reach = 0.5 * spacing * float(np.linalg.norm(hi - lo)) + spacing
    distance = float(np.asarray(model(centre[None]))[0])
    if abs(distance) > reach:
        share = np.full(tuple(int(n) for n in hi - lo), 1.0 if distance < 0 else 0.0, dtype=np.float32)
    else:
        points = np.stack(np.meshgrid(*axes, indexing="ij"), axis=-1).reshape(-1, 3)
        share = voxel_shares(model, points, spacing, sub).reshape(tuple(int(n) for n in hi - lo)).astype(np.float32)
    store[lo[0]:hi[0], lo[1]:hi[1], lo[2]:hi[2]] = share


def _new_store(path: Any, lower: Any, upper: Any, spacing: float, chunks: int, dtype: str):
    """An empty zarr array for the voxels of ``spacing`` filling the box (as
    :func:`~fepre.sdf.imagemodel.phantoms.voxel_centres` centres them), its first centre and
    its chunks' layout."""
    import zarr

    spacing = positive_float(spacing, "spacing")
    path = Path(path)
    if path.exists():
        raise FileExistsError(f"path: {str(path)!r} exists; give a new .zarr store")
    if not path.parent.is_dir():
        raise FileNotFoundError(f"path: folder {str(path.parent)!r} does not exist (for {str(path)!r})")
    lower, upper = np.asarray(lower, float), np.asarray(upper, float)
    shape = tuple(int(n) for n in np.maximum(np.ceil((upper - lower) / spacing - 1e-9).astype(int), 2))
    first = 0.5 * (lower + upper) - 0.5 * spacing * (np.array(shape) - 1)  # as voxel_centres centres them
    store = zarr.create_array(store=str(path), shape=shape, chunks=(int(chunks),) * 3, dtype=dtype, fill_value=0)
    store.attrs.update({"spacing": [spacing] * 3, "origin": [float(v) for v in first]})
    layout = ChunkLayout(shape, tuple(tuple(int(c) for c in np.diff(np.r_[0:n:chunks, n])) for n in shape))
    return store, first, spacing, layout


def _label_block(models, labels, store, first: np.ndarray, spacing: float, lo: np.ndarray, hi: np.ndarray) -> None:
    axes = [first[k] + spacing * np.arange(lo[k], hi[k]) for k in range(3)]
    centre = np.array([[0.5 * (a[0] + a[-1]) for a in axes]])
    reach = 0.5 * spacing * float(np.linalg.norm(hi - lo))
    shape = tuple(int(n) for n in hi - lo)
    result = np.zeros(shape, dtype=store.dtype)
    points = None
    for label, model in zip(labels, models):
        distance = float(np.asarray(model(centre))[0])
        if distance < -reach:
            result[...] = label
        elif distance <= reach:
            if points is None:
                points = np.stack(np.meshgrid(*axes, indexing="ij"), axis=-1).reshape(-1, 3)
            result[(np.asarray(model(points)) < 0).reshape(shape)] = label
    store[lo[0]:hi[0], lo[1]:hi[1], lo[2]:hi[2]] = result


def write_label_image(models: Any, path: Any, lower: Any, upper: Any, spacing: float, *, labels: Any = None,
                      chunks: int = 128, workers: int | None = None):
    """Write the label image of ``models`` over the box ``lower``-``upper`` (voxels of side
    ``spacing``) to a zarr store at ``path``, chunk by chunk: at each voxel centre the label of
    the last model that holds it (``labels[k]`` for ``models[k]``, default ``k + 1``), 0 where
    none does, the same values as :func:`fepre.sdf.imagemodel.phantoms.label_image`.

    Parameters
    ----------
    models : sequence of fepre.sdf.SDF
        The parts (1-Lipschitz, negative inside), later ones over earlier ones.
    path : str or path-like
        The ``.zarr`` store to create (it must not exist).
    lower, upper : (3,) floats
        The box, rounded up to whole voxels about its centre.
    spacing : float
        Voxel side.
    labels : sequence of int, optional
        Each model's label (1 to 255).
    chunks : int
        Voxels per zarr chunk along each axis.
    workers : int, optional
        Threads (default all cores).

    Returns
    -------
    zarr.Array
        Shape ``(nx, ny, nz)``, uint8, attributes ``spacing`` and ``origin``.

    Examples
    --------
    >>> import tempfile, pathlib
    >>> from fepre import sdf
    >>> path = pathlib.Path(tempfile.mkdtemp()) / "labels.zarr"
    >>> store = write_label_image([sdf.box(1.0), sdf.sphere(0.3)], path, (-0.6,) * 3, (0.6,) * 3, 0.1, chunks=8)
    >>> store.shape, sorted(set(store[:].ravel().tolist()))
    ((12, 12, 12), [0, 1, 2])
    """
    require_dask("zarr phantoms")
    models = list(models)
    labels = list(range(1, len(models) + 1)) if labels is None else [int(v) for v in labels]
    if len(labels) != len(models) or not all(1 <= v <= 255 for v in labels):
        raise ValueError(f"labels must give one label from 1 to 255 per model ({len(models)}); got {labels}")
    store, first, spacing, layout = _new_store(path, lower, upper, spacing, chunks, "uint8")
    with ThreadPoolExecutor(max_workers=workers or os.cpu_count() or 1) as pool:
        jobs = [pool.submit(_label_block, models, labels, store, first, spacing, lo, hi) for _, lo, hi in layout]
        for job in jobs:
            job.result()
    return store


def write_partial_volume(model, path: Any, lower: Any, upper: Any, spacing: float, *, chunks: int = 128,
                         sub: int = 6, workers: int | None = None):
    """Write the partial-volume image of ``model`` over the box ``lower``-``upper`` (voxels of
    side ``spacing``) to a zarr store at ``path``, chunk by chunk.

    Parameters
    ----------
    model : fepre.sdf.SDF
        The part (1-Lipschitz, negative inside).
    path : str or path-like
        The ``.zarr`` store to create (it must not exist).
    lower, upper : (3,) floats
        The box, rounded up to whole voxels about its centre.
    spacing : float
        Voxel side.
    chunks : int
        Voxels per zarr chunk along each axis.
    sub : int
        Samples per voxel side in the voxels the surface may cross.
    workers : int, optional
        Threads (default all cores).

    Returns
    -------
    zarr.Array
        Shape ``(nx, ny, nz)``, float32, attributes ``spacing`` and ``origin`` (the first voxel's
        centre).

    Examples
    --------
    >>> import tempfile, pathlib
    >>> from fepre import sdf
    >>> path = pathlib.Path(tempfile.mkdtemp()) / "ball.zarr"
    >>> store = write_partial_volume(sdf.sphere(0.5), path, (-1, -1, -1), (1, 1, 1), 0.1, chunks=8)
    >>> store.shape, round(float(store[:].sum()) * 0.1**3, 3)    # 4/3 pi 0.5^3 = 0.524
    ((20, 20, 20), 0.524)
    """
    require_dask("zarr phantoms")
    store, first, spacing, layout = _new_store(path, lower, upper, spacing, chunks, "float32")
    with ThreadPoolExecutor(max_workers=workers or os.cpu_count() or 1) as pool:
        jobs = [pool.submit(_block, model, store, first, spacing, lo, hi, sub) for _, lo, hi in layout]
        for job in jobs:
            job.result()
    return store
