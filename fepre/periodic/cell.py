"""The periodic cell: a box whose opposite faces are identified, and the checks on a model in it."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from ..arguments import as_bounds, as_vector, shown
from ..distmesh.constraints import compose  # noqa: F401  (the loop's hooks composed; public here before)

__all__ = ["PeriodicCell", "periodic_cell", "check_periodic_model", "compose", "AXES", "FACE_MARGIN"]

AXES = "xyz"
#: free DistMesh points stay this far (times h) from the cell's faces
FACE_MARGIN = 0.45
#: samples per face side when checking that a model repeats across the period
_CHECK_SAMPLES = 24


@dataclass(frozen=True)
class PeriodicCell:
    """The box ``[lower, lower + period]`` whose opposite faces are identified.

    Attributes
    ----------
    lower : (3,) float64
        The cell's lowest corner.
    period : (3,) float64
        Its edge lengths (the periods along x, y and z).
    """

    lower: np.ndarray
    period: np.ndarray

    @property
    def upper(self) -> np.ndarray:
        return self.lower + self.period

    @property
    def volume(self) -> float:
        return float(np.prod(self.period))

    def tolerance(self, h: float) -> float:
        """Distance within which a node counts as on a face of the cell."""
        return 1e-9 * float(self.period.max()) + 1e-6 * h

    def solid(self, model):
        """``model`` cut by the cell (the part fepre meshes)."""
        from ..sdf import box

        return model & box(tuple(self.period), center=tuple(self.lower + 0.5 * self.period))

    def on_planes(self, points: np.ndarray, tol: float) -> np.ndarray:
        """(N, 3) bool: point on the lower (or upper) face normal to each axis."""
        return (np.abs(points - self.lower) <= tol) | (np.abs(points - self.upper) <= tol)

    def keep_off_faces(self, margin: float):
        """A ``protect(points, movable)`` hook for the DistMesh loop: free points closer than
        ``margin`` to a face of the cell move back to ``margin`` from it, so that only the
        periodic boundary nodes lie on the faces."""
        low, high = self.lower + margin, self.upper - margin

        def clamp(points: np.ndarray, movable: np.ndarray):
            index = np.flatnonzero(movable & ((points < low) | (points > high)).any(axis=1))
            if index.size == 0:
                return index, np.zeros(0)
            before = points[index].copy()
            points[index] = np.clip(before, low, high)
            return index, np.sqrt(((points[index] - before) ** 2).sum(axis=1))

        return clamp


def periodic_cell(periodic: Any, bounds: Any) -> PeriodicCell:
    """The cell of ``distmesh(..., periodic=..., bounds=...)``, checked.

    ``periodic`` is one period or three; ``bounds`` the cell (default: from the origin).
    """
    period = as_vector(periodic, 3, "periodic", allow_scalar=True)
    if not np.all(np.isfinite(period)) or np.any(period <= 0):
        raise ValueError(f"periodic must be three positive periods (Lx, Ly, Lz); got {shown(periodic)}")
    if bounds is None:
        return PeriodicCell(np.zeros(3), period)
    lower, upper = (np.asarray(v, dtype=np.float64) for v in as_bounds(bounds, 3, "bounds"))
    extent = upper - lower
    if not np.allclose(extent, period, rtol=1e-9, atol=0.0):
        raise ValueError(
            f"periodic={tuple(period.tolist())} disagrees with the bounds, whose extents are "
            f"{tuple(extent.tolist())}: the bounds are the periodic cell, so each extent must equal its period"
        )
    return PeriodicCell(lower, period)


def check_periodic_model(model, cell: PeriodicCell, h: float) -> None:
    """Refuse a model that does not repeat across the cell, or one already cut by its faces.

    The model is sampled on a grid of every pair of opposite faces: its sign must agree, and
    within ``0.1 h`` of the zero set its values too (to ``1e-6`` of the cell's size plus
    ``1e-4 h``), or its faces do not match. Farther from the zero set the values may differ (a
    void nearer one face than the other is still a periodic solid). A model
    whose values are zero on a face where they are negative just inside was cut by the cell
    already (fepre cuts it itself: give the unbounded periodic model).
    """
    scale = float(cell.period.max())
    tolerance = 1e-6 * scale + 1e-4 * h
    for axis in range(3):
        u, v = [a for a in range(3) if a != axis]
        su = cell.lower[u] + cell.period[u] * (np.arange(_CHECK_SAMPLES) + 0.37) / _CHECK_SAMPLES
        sv = cell.lower[v] + cell.period[v] * (np.arange(_CHECK_SAMPLES) + 0.61) / _CHECK_SAMPLES
        grid = np.zeros((_CHECK_SAMPLES**2, 3))
        grid[:, u], grid[:, v] = (w.ravel() for w in np.meshgrid(su, sv, indexing="ij"))
        low, high, inside = grid.copy(), grid.copy(), grid.copy()
        low[:, axis] = cell.lower[axis]
        high[:, axis] = cell.upper[axis]
        inside[:, axis] = cell.lower[axis] + 1e-3 * h
        a, b, c = model(low), model(high), model(inside)
        # the solid must repeat: same sign everywhere, same value right at the zero set (the rim's
        # place); farther in, distances may differ (a void nearer one face than the other)
        near = np.minimum(np.abs(a), np.abs(b)) < 0.1 * h
        mismatch = np.where(near, np.abs(a - b) > tolerance, (a < 0) != (b < 0))
        if mismatch.any():
            worst = int(np.argmax(np.where(mismatch, np.abs(a - b), -1.0)))
            point = low[worst].copy()
            raise ValueError(
                f"the model does not repeat across the period along {AXES[axis]}: at "
                f"{np.round(point, 6).tolist()} its value is {a[worst]:.6g}, and {b[worst]:.6g} one period "
                f"({cell.period[axis]:g}) further; give a model periodic with periods "
                f"{tuple(cell.period.tolist())} in these bounds"
            )
        cut = (np.abs(a) <= 1e-12 * scale) & (c < -1e-4 * h)
        if cut.mean() > 0.25:
            raise ValueError(
                f"the model is zero on the cell's face {AXES[axis]} = {cell.lower[axis]:g} where it is negative "
                "just inside: it looks cut by the cell already; give the unbounded periodic model "
                "(fepre cuts it with the cell itself)"
            )

