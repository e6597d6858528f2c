"""Initial DistMesh points: a lattice clipped to the domain, thinned by the size function."""

from __future__ import annotations

from typing import Callable

import numpy as np

from ..arguments import evaluate_size

__all__ = ["lattice", "initial_points", "evaluate_size", "surface_points"]

# lattice constant (cube side) per unit edge length, chosen so that every lattice has about
# the point density of a regular-ish tetrahedral mesh with edges h (1.4 points per h^3)
_CELL = {"cubic": 1.0, "bcc": 1.1, "fcc": 2.0**0.5}
_BASIS = {
    "cubic": np.zeros((1, 3)),
    "bcc": np.array([[0.0, 0.0, 0.0], [0.5, 0.5, 0.5]]),
    "fcc": np.array([[0.0, 0.0, 0.0], [0.5, 0.5, 0.0], [0.5, 0.0, 0.5], [0.0, 0.5, 0.5]]),
}


def lattice(lower: np.ndarray, upper: np.ndarray, h: float, distribution: str) -> np.ndarray:
    """Points of a ``distribution`` lattice with edge length about ``h`` covering the box.

    Examples
    --------
    >>> lattice(np.zeros(3), np.ones(3), 0.5, "cubic").shape
    (27, 3)
    """
    a = _CELL[distribution] * h
    counts = np.floor((upper - lower) / a + 1e-9).astype(np.int64) + 1
    axes = [lower[k] + a * np.arange(counts[k]) for k in range(3)]
    grid = np.stack(np.meshgrid(*axes, indexing="ij"), axis=-1).reshape(-1, 3)
    points = (grid[None, :, :] + a * _BASIS[distribution][:, None, :]).reshape(-1, 3)
    inside = np.all(points <= upper + 1e-9 * a, axis=1)
    return points[inside]


def surface_points(model, candidates: np.ndarray, lower: np.ndarray, h: float) -> np.ndarray:
    """Points on the zero set about ``h`` apart: ``candidates`` (lattice points near the
    surface) are projected, one is kept per cube of side ``1.1 h`` (the one nearest the cube's
    centre; a surface meets about 1.5 such cubes per ``(1.1 h)^2``, the vertex density of
    equilateral triangles of side h), and of any pair closer than ``h/2`` the later is dropped.
    """
    if len(candidates) == 0:
        return candidates
    from scipy.spatial import cKDTree

    projected = model.project(candidates, iterations=8, tol=1e-6 * h, warn=False)
    projected = projected[np.abs(model(projected)) < 1e-3 * h]
    if len(projected) == 0:
        return projected
    side = 1.1 * h
    cells = np.floor((projected - lower) / side).astype(np.int64)
    cells -= cells.min(axis=0)
    span = cells.max(axis=0) + 1
    codes = (cells[:, 0] * span[1] + cells[:, 1]) * span[2] + cells[:, 2]
    # the two sides of a wall up to 1.1 h thick share cubes: one point per cube and side (the
    # normal's main axis and sign), or a plate h thick kept points on one face only
    _, gradient = model.value_and_gradient(projected)
    axis = np.argmax(np.abs(gradient), axis=1)
    side_of = 2 * axis + (gradient[np.arange(len(axis)), axis] > 0)
    codes = codes * 6 + side_of
    offset = np.linalg.norm(projected - (lower + (cells + 0.5) * side), axis=1)
    order = np.lexsort((offset, codes))
    _, first = np.unique(codes[order], return_index=True)
    surface = projected[np.sort(order[first])]
    pairs = cKDTree(surface).query_pairs(0.5 * h, output_type="ndarray")
    keep = np.ones(len(surface), bool)
    keep[pairs.max(axis=1) if len(pairs) else []] = False
    return surface[keep]


def _graded_points(model, lower, upper, h, distribution, geps, jitter, field, rng, boundary_layer) -> np.ndarray:
    """Initial points for a size field: an octave lattice (:mod:`.graded_lattice`) thinned to
    density ``1 / size^3``; with ``boundary_layer``, surface points per octave at density
    ``1 / size^2`` and lattice points deeper than half the local size."""
    from .graded_lattice import graded_lattice

    points, octave, at = graded_lattice(field, lower, upper, h, _CELL[distribution], _BASIS[distribution])
    if jitter > 0 and len(points):
        points = points + rng.uniform(-jitter, jitter, size=points.shape) * octave[:, None]
    values = model(points) if len(points) else np.zeros(0)
    if not boundary_layer:
        keep = (values < geps) & (rng.random(len(points)) < (octave / at) ** 3)
        return points[keep]
    chunks = []
    for size in np.unique(octave):
        mine = (octave == size) & (np.abs(values) < size)
        surface = surface_points(model, points[mine], lower, size)
        if len(surface):
            local = field(surface)
            chunks.append(surface[rng.random(len(surface)) < np.minimum(1.0, (size / local) ** 2)])
    deep = (values < -0.5 * octave) & (rng.random(len(points)) < (octave / at) ** 3)
    chunks.append(points[deep])
    return np.concatenate(chunks)


def initial_points(
    model,
    lower: np.ndarray,
    upper: np.ndarray,
    h: float,
    distribution: str,
    geps: float,
    jitter: float,
    size: Callable | None,
    fixed: np.ndarray,
    rng: np.random.Generator,
    boundary_layer: bool = False,
    absolute: bool = False,
) -> np.ndarray:
    """Fixed points followed by lattice points with sdf < ``geps``, thinned by ``size``.

    With a size function a lattice point is kept with probability ``min(size)^3 / size^3``
    (Persson's rejection), so the edge length where ``size`` is smallest is ``h``; with
    ``absolute`` (a size field in world units, never below ``h``) with probability
    ``h^3 / size^3``, so edges are about ``size`` everywhere. Lattice points
    closer than ``h/2`` to a fixed point are dropped. With ``boundary_layer`` the lattice keeps
    only points deeper than ``h/2`` and the surface gets its own points (:func:`surface_points`).
    """
    from ..sizing import SizeField

    margin = h if boundary_layer else 0.0
    if absolute and isinstance(size, SizeField):
        points = _graded_points(model, lower - margin, upper + margin, h, distribution, geps, jitter, size, rng,
                                boundary_layer)
    else:
        points = lattice(lower - margin, upper + margin, h, distribution)
        if jitter > 0:
            points = points + rng.uniform(-jitter * h, jitter * h, size=points.shape)
        values = model(points) if len(points) else np.zeros(0)
        if boundary_layer:
            surface = surface_points(model, points[np.abs(values) < h], lower, h)
            points = np.concatenate([surface, points[values < -0.5 * h]])
            dimension = np.concatenate([np.full(len(surface), 2.0), np.full(len(points) - len(surface), 3.0)])
        else:
            points = points[values < geps]
            dimension = np.full(len(points), 3.0)
        if size is not None and len(points):
            r0 = evaluate_size(size, points)
            keep = rng.random(len(points)) < ((h if absolute else r0.min()) / r0) ** dimension
            points = points[keep]
    if len(fixed) and len(points):
        from scipy.spatial import cKDTree

        near = cKDTree(fixed).query(points, distance_upper_bound=0.5 * h)[0]
        points = points[~np.isfinite(near)]
    return np.concatenate([fixed, points]) if len(fixed) else points
