"""Phantoms: images of analytic models, for tests and benchmarks with known answers.

A grey phantom holds each voxel's partial volume (the fraction of the voxel inside the model,
by ``sub^3`` samples in voxels near the surface; 0 or 1 elsewhere), as a CT of the part would at
that resolution; a label phantom holds, at each voxel centre, the label of the last model that
contains it.
"""

from __future__ import annotations

from typing import Any, Sequence

import numpy as np

__all__ = ["voxel_centres", "voxel_shares", "partial_volume", "label_image"]

#: voxels handled per batch of supersamples (memory: CHUNK * sub^3 points)
CHUNK = 8192


def voxel_centres(lower: Any, upper: Any, spacing: float) -> tuple[np.ndarray, np.ndarray, tuple[int, int, int]]:
    """Centres (N, 3) of the voxels of side ``spacing`` filling the box from ``lower`` to
    ``upper`` (rounded up to whole voxels, centred on the box), the first centre, and the shape."""
    lower, upper = np.asarray(lower, float), np.asarray(upper, float)
    shape = np.maximum(np.ceil((upper - lower) / spacing - 1e-9).astype(int), 2)
    first = 0.5 * (lower + upper) - 0.5 * spacing * (shape - 1)
    axes = [first[k] + spacing * np.arange(shape[k]) for k in range(3)]
    points = np.stack(np.meshgrid(*axes, indexing="ij"), axis=-1).reshape(-1, 3)
    return points, first, tuple(int(n) for n in shape)


def _grid(values: np.ndarray, first: np.ndarray, spacing: float, name: str):
    import pyvista as pv

    grid = pv.ImageData(dimensions=values.shape, spacing=(spacing,) * 3, origin=tuple(first))
    grid.point_data[name] = values.ravel(order="F")
    grid.point_data.active_scalars_name = name
    return grid


def voxel_shares(model, points: np.ndarray, spacing: float, sub: int = 6) -> np.ndarray:
    """The share of each voxel of side ``spacing`` centred at ``points`` (N, 3) inside ``model``:
    ``sub^3`` samples in the voxels within 0.87 spacing of the surface, 0 or 1 elsewhere."""
    values = np.asarray(model(points), dtype=np.float64)
    share = (values < 0).astype(np.float64)
    near = np.flatnonzero(np.abs(values) < 0.87 * spacing)
    offsets = ((np.arange(sub) + 0.5) / sub - 0.5) * spacing
    cube = np.stack(np.meshgrid(offsets, offsets, offsets, indexing="ij"), axis=-1).reshape(-1, 3)
    for start in range(0, len(near), CHUNK):
        chunk = near[start:start + CHUNK]
        samples = (points[chunk, None, :] + cube[None]).reshape(-1, 3)
        share[chunk] = (np.asarray(model(samples)) < 0).reshape(len(chunk), -1).mean(axis=1)
    return share


def partial_volume(model, lower: Any, upper: Any, spacing: float, *, sub: int = 6, scale: float = 1.0):
    """A grey image of ``model``: each voxel's share inside it, times ``scale``.

    Returns
    -------
    pyvista.ImageData
        Point array ``"density"`` at the voxel centres (float32).

    Examples
    --------
    >>> from fepre import sdf
    >>> grid = partial_volume(sdf.sphere(0.5), (-1, -1, -1), (1, 1, 1), 0.1)
    >>> round(float(grid["density"].sum()) * 0.1**3, 3)    # 4/3 pi 0.5^3 = 0.524
    0.524
    """
    points, first, shape = voxel_centres(lower, upper, spacing)
    share = voxel_shares(model, points, spacing, sub)
    return _grid((scale * share).reshape(shape).astype(np.float32), first, spacing, "density")


def label_image(models: Sequence, lower: Any, upper: Any, spacing: float, labels: Sequence[int] | None = None):
    """A label image: at each voxel centre the label of the last of ``models`` that holds it
    (``labels[k]`` for ``models[k]``, default ``k + 1``), 0 where none does. A voxel centre on
    the face two models share (both zero there, neither holding it) takes the last of them: it
    lies inside the part, and a background voxel there would be a crack between the two.

    Examples
    --------
    >>> from fepre import sdf
    >>> grid = label_image([sdf.box(1.0), sdf.sphere(0.3)], (-0.6,) * 3, (0.6,) * 3, 0.1)
    >>> sorted(set(grid["labels"].tolist()))
    [0, 1, 2]
    """
    points, first, shape = voxel_centres(lower, upper, spacing)
    labels = list(range(1, len(models) + 1)) if labels is None else list(labels)
    result = np.zeros(len(points), dtype=np.int16)
    on_face = np.zeros(len(points), dtype=np.int16)  # models zero at the point
    tied = np.zeros(len(points), dtype=np.int16)  # the last of them
    for label, model in zip(labels, models):
        values = np.asarray(model(points))
        result[values < 0] = label
        on_face += values == 0
        tied[values == 0] = label
    shared = (result == 0) & (on_face >= 2)
    result[shared] = tied[shared]
    return _grid(result.reshape(shape), first, spacing, "labels")
