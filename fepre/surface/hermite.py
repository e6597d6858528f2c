"""Hermite data of the crossing grid edges: where each edge crosses the level set, and the normal there.

Dual contouring needs, for every grid edge whose ends lie on different sides of the level, the
crossing point and the unit normal of the surface at that point. Two sources:

* a model (:func:`hermite_from_model`): the crossing starts at the linear interpolation of the
  two samples and is refined by a few safeguarded Newton steps along the edge on the model
  (false position when a Newton step would leave the bracket); the normal is the model's
  normalised gradient, taken a hair inside the crossing along the edge (a millionth of a cell
  towards the inside end), so a crossing exactly on a crease or a corner of a CSG part still
  gets the normal of the face the edge passes through;
* the grid alone (:func:`hermite_from_grid`): the crossing is the linear interpolation, the
  normal the gradient of the samples, central differences across the edge interpolated
  linearly along it (the trilinear interpolation of node gradients restricted to the edge)
  and the samples' own difference along it. It reads only the nodes of the four cells around
  the edge, which are all active, so a narrow-band grid gives the same normals as a dense one.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from .dual_cells import DualCells
from .grid_scan import inside_threshold

__all__ = ["Hermite", "hermite_from_model", "hermite_from_grid"]

#: where the normal is taken: this fraction of a cell inside the crossing, along the edge
_NORMAL_OFFSET = 1e-6
#: bisection steps for edges running along the surface (2^-30 of a cell)
_BISECTIONS = 30


@dataclass
class Hermite:
    """Crossing points (E, 3) and unit outward normals (E, 3; zero where the gradient vanishes)."""

    points: np.ndarray
    normals: np.ndarray


def _edge_geometry(dual: DualCells, values: np.ndarray, level: float):
    """Node indices (E, 3) as (i, j, k), axis, end values and linear crossing parameter of each crossing."""
    nz, ny, nx = values.shape
    start, axis = dual.crossing_edges()
    k, rest = np.divmod(start, nx * ny)
    j, i = np.divmod(rest, nx)
    ijk = np.stack([i, j, k], axis=1)
    stride = np.array([1, nx, nx * ny])[axis]
    flat = values.reshape(-1)
    v0 = flat[start].astype(np.float64)
    v1 = flat[start + stride].astype(np.float64)
    t = (level - v0) / (v1 - v0)
    return ijk, axis, v0, v1, t


def _unit(vectors: np.ndarray) -> np.ndarray:
    length = np.linalg.norm(vectors, axis=1, keepdims=True)
    return np.divide(vectors, length, out=np.zeros_like(vectors), where=length > 0)


def hermite_from_model(
    dual: DualCells,
    values: np.ndarray,
    level: float,
    origin: np.ndarray,
    spacing: np.ndarray,
    model: Any,
    iterations: int = 12,
    *,
    first_node: np.ndarray | None = None,
) -> Hermite:
    """Crossings refined on ``model`` and its normalised gradients.

    Parameters
    ----------
    dual : DualCells
        Connectivity of the grid ``values`` (gives the crossing edges).
    values : (nz, ny, nx) array
        The samples of ``model`` (they decide which edges cross and bracket each crossing).
    level : float
    origin, spacing : (3,) arrays
        The grid's geometry.
    model : fepre.sdf.SDF
        Evaluated with ``value_and_gradient`` on the crossing edges only.
    iterations : int
        Largest number of steps per edge (each a model evaluation on the edges not yet
        converged to a millionth of a cell; Newton needs two or three on smooth surfaces).
    first_node : (3,) int, optional
        The (i, j, k) index of ``values[0, 0, 0]`` in the grid of ``origin`` (a chunk).

    Examples
    --------
    >>> import numpy as np
    >>> from fepre import sdf
    >>> from fepre.surface.dual_cells import dual_cells
    >>> ball = sdf.sphere(0.6)
    >>> axis = np.linspace(-1, 1, 9)
    >>> values = ball.values_on_axes(axis, axis, axis)
    >>> data = hermite_from_model(dual_cells(values, 0.0), values, 0.0, np.full(3, -1.0), np.full(3, 0.25), ball)
    >>> bool(np.allclose(np.linalg.norm(data.points, axis=1), 0.6))
    True
    """
    ijk, axis, v0, v1, t = _edge_geometry(dual, values, level)
    rows = np.arange(axis.size)
    step = np.zeros((axis.size, 3))
    step[rows, axis] = spacing[axis]  # the edge vector
    base = origin + (ijk + _first(first_node)) * spacing
    threshold = float(inside_threshold(values.dtype, level))
    start_inside = v0 < threshold
    _solve_on_edges(model, level, base, step, t, v0 - level, v1 - level, start_inside, iterations, spacing)
    inward = np.where(start_inside, -1.0, 1.0)[:, None] * step  # towards the inside end
    points = base + t[:, None] * step
    value, gradient = model.value_and_gradient(points + _NORMAL_OFFSET * inward)
    # a crossing on its outside node whose point just inside is not inside: the edge runs along
    # the surface from the node, and the crossing is where the inside ends (see _bisect_inside_end)
    outside_end = np.where(start_inside, 1.0, 0.0)
    along = np.flatnonzero((np.abs(t - outside_end) < 1e-9) & (value >= level))
    if along.size:
        t_along = _bisect_inside_end(model, level, base[along], step[along], 1.0 - outside_end[along], outside_end[along])
        points[along] = base[along] + t_along[:, None] * step[along]
        gradient[along] = model.value_and_gradient(points[along] + _NORMAL_OFFSET * inward[along])[1]
    return Hermite(points, _unit(gradient))


def _solve_on_edges(
    model: Any,
    level: float,
    base: np.ndarray,
    step: np.ndarray,
    t: np.ndarray,
    f_start: np.ndarray,
    f_end: np.ndarray,
    start_inside: np.ndarray,
    iterations: int,
    spacing: np.ndarray,
) -> None:
    """Refine the crossing parameters ``t`` (in place) to ``model == level`` on each edge.

    Newton along the edge where its step stays inside the bracket, otherwise the Illinois
    variant of false position (the value kept at an end twice in a row is halved), which
    converges even where the model is piecewise linear along the edge (CSG creases), where
    plain false position crawls. Edges stop once ``|value - level|`` is below a millionth of a
    cell; each iteration evaluates the model on the edges still moving.
    """
    lo, hi = np.zeros_like(t), np.ones_like(t)
    f_lo, f_hi = f_start.copy(), f_end.copy()
    kept = np.zeros(t.size, dtype=np.int8)  # which end the last step kept: 1 lo, 2 hi
    tolerance = 1e-6 * float(np.min(spacing))
    active = np.arange(t.size)
    for _ in range(iterations):
        value, gradient = model.value_and_gradient(base[active] + t[active, None] * step[active])
        f = value - level
        moving = np.abs(f) > tolerance
        active, f, gradient = active[moving], f[moving], gradient[moving]
        if active.size == 0:
            break
        at = t[active]
        # the end on the start node's side moves to t when f is on that side
        replaces_lo = (f < 0) == start_inside[active]
        a = np.where(replaces_lo, at, lo[active])
        b = np.where(replaces_lo, hi[active], at)
        fa = np.where(replaces_lo, f, f_lo[active])
        fb = np.where(replaces_lo, f_hi[active], f)
        now_kept = np.where(replaces_lo, 2, 1).astype(np.int8)
        again = kept[active] == now_kept
        fa = np.where(again & (now_kept == 1), 0.5 * fa, fa)
        fb = np.where(again & (now_kept == 2), 0.5 * fb, fb)
        lo[active], hi[active], f_lo[active], f_hi[active], kept[active] = a, b, fa, fb, now_kept
        slope = np.einsum("ij,ij->i", gradient, step[active])
        with np.errstate(divide="ignore", invalid="ignore"):
            newton = at - f / slope
            secant = np.where(fb != fa, a - fa * (b - a) / (fb - fa), 0.5 * (a + b))
        inside_bracket = np.isfinite(newton) & (newton > a) & (newton < b)
        t[active] = np.where(inside_bracket, newton, np.clip(secant, a, b))


def _bisect_inside_end(
    model: Any, level: float, base: np.ndarray, step: np.ndarray, inside: np.ndarray, outside: np.ndarray
) -> np.ndarray:
    """Edge parameters of the first outside point (``value >= level``) between ``inside`` and ``outside``.

    When the outside node lies on the surface, the model may be zero along a stretch of the
    edge (a grid edge in the floor of a slot, running from the material to the slot): any point
    of the stretch is a zero, but the crossing is where the inside ends, on the crease.
    """
    low, high = inside.copy(), outside.copy()
    for _ in range(_BISECTIONS):
        middle = 0.5 * (low + high)
        is_outside = model(base + middle[:, None] * step) >= level
        high = np.where(is_outside, middle, high)
        low = np.where(is_outside, low, middle)
    return high


def hermite_from_grid(
    dual: DualCells,
    values: np.ndarray,
    level: float,
    origin: np.ndarray,
    spacing: np.ndarray,
    first_node: np.ndarray | None = None,
) -> Hermite:
    """Linear crossings and normals from the gradient of the samples (no model needed).

    Examples
    --------
    >>> import numpy as np
    >>> from fepre.surface.dual_cells import dual_cells
    >>> axis = np.linspace(-1, 1, 9)
    >>> values = np.sqrt(axis[:, None, None]**2 + axis[None, :, None]**2 + axis[None, None, :]**2) - 0.6
    >>> data = hermite_from_grid(dual_cells(values, 0.0), values, 0.0, np.full(3, -1.0), np.full(3, 0.25))
    >>> outward = np.einsum("ij,ij->i", data.normals, data.points / np.linalg.norm(data.points, axis=1)[:, None])
    >>> bool(outward.min() > 0.95)
    True
    """
    nz, ny, nx = values.shape
    ijk, axis, v0, v1, t = _edge_geometry(dual, values, level)
    sizes = np.array([nx, ny, nz])
    strides = np.array([1, nx, nx * ny])
    flat = values.reshape(-1)
    rows = np.arange(axis.size)
    gradient = np.empty((axis.size, 3))
    gradient[rows, axis] = (v1 - v0) / spacing[axis]
    start = ijk @ strides
    end = start + strides[axis]
    for offset in (1, 2):
        across = (axis + offset) % 3  # the two axes across the edge
        position = ijk[rows, across]
        up = np.minimum(position + 1, sizes[across] - 1)
        down = np.maximum(position - 1, 0)
        width = (up - down) * spacing[across]
        shift_up, shift_down = (up - position) * strides[across], (down - position) * strides[across]
        at_start = (flat[start + shift_up].astype(np.float64) - flat[start + shift_down]) / width
        at_end = (flat[end + shift_up].astype(np.float64) - flat[end + shift_down]) / width
        gradient[rows, across] = (1 - t) * at_start + t * at_end
    points = origin + ((ijk + _first(first_node)) + t[:, None] * np.eye(3)[axis]) * spacing
    return Hermite(points, _unit(gradient))


def _first(first_node: np.ndarray | None) -> np.ndarray:
    return np.zeros(3, dtype=np.int64) if first_node is None else np.asarray(first_node, dtype=np.int64)
