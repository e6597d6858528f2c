"""Solids made from 2D shapes: extrude and revolve."""

from __future__ import annotations

from typing import Any

import numpy as np

from ..arguments import finite_float, positive_float
from .axis_section import AxisSection, mirrored_section
from .core import SDF, Coords
from .polygon import Polygon
from .orthant import axis_sign, orthant_distance, orthant_gradient
from .radial import radial, radial_direction

__all__ = ["extrude", "revolve"]


def _shape2d(shape: Any, name: str = "shape2d") -> SDF:
    if not isinstance(shape, SDF):
        raise TypeError(f"{name} must be a 2D fepre.sdf shape (e.g. sdf.circle); got {type(shape).__name__}")
    if shape.dim != 2:
        raise ValueError(
            f"{name} must be a 2D shape (dim 2, e.g. sdf.circle, sdf.polygon); "
            f"got a {shape.dim}D {shape.describe()}"
        )
    return shape


class Extrusion(SDF):
    """A 2D shape swept along z from -height/2 to height/2."""

    def __init__(self, shape: SDF, height: float) -> None:
        self.shape, self.height = shape, height
        self.analytic_gradient = shape.analytic_gradient
        bounds = None
        if shape.bounds is not None:
            (x0, y0), (x1, y1) = shape.bounds
            bounds = ((x0, y0, -height / 2.0), (x1, y1, height / 2.0))
        super().__init__(bounds=bounds, exact=shape.exact, children=(shape,))

    def _parameters(self) -> dict[str, Any]:
        return {"height": self.height}

    def _label(self) -> str:
        return "extrude"

    def _values(self, x, y, z):
        return orthant_distance([self.shape._values(x, y), np.abs(z) - self.height / 2.0])

    @property
    def patch_count(self) -> int:
        return self.shape.patch_count + 2  # the 2D shape's patches swept, then top and bottom

    def _patch_labels(self, points):
        values, labels = self.shape._patch_labels(points[:, :2])
        cap = np.abs(points[:, 2]) - self.height / 2.0 > values
        top = self.shape.patch_count
        return self._values(*points.T), np.where(cap, np.where(points[:, 2] > 0, top, top + 1), labels)

    def _patch_values(self, labels, points):
        top = self.shape.patch_count
        side = labels < top
        values = np.where(labels == top, points[:, 2], -points[:, 2]) - self.height / 2.0
        if side.any():
            values[side] = self.shape._patch_values(labels[side], points[side, :2])
        return values

    def _values_and_gradient(self, x, y, z) -> tuple[np.ndarray, Coords]:
        values, (gx, gy) = self.shape._values_and_gradient(x, y)
        parts = [values, np.abs(z) - self.height / 2.0]
        return orthant_gradient(parts, [(gx, gy, 0.0), (0.0, 0.0, axis_sign(z))])


def extrude(shape2d: SDF, height: float) -> SDF:
    """Prism of the 2D shape ``shape2d`` from z = -height/2 to z = height/2.

    Exact (``sqrt(max(d2, 0)**2 + max(|z| - h/2, 0)**2) + min(max(d2, |z| - h/2), 0)``) when
    ``shape2d`` is exact; otherwise a 1-Lipschitz lower bound like ``shape2d``.

    Examples
    --------
    >>> from fepre import sdf
    >>> plate = sdf.extrude(sdf.rectangle((4, 2)), height=0.5)
    >>> plate.bounds
    ((-2.0, -1.0, -0.25), (2.0, 1.0, 0.25))
    >>> float(plate([0.0, 0.0, 1.25]))
    1.0
    """
    return Extrusion(_shape2d(shape2d), positive_float(height, "height"))


class Revolution(SDF):
    """A 2D profile in the (r, z) half-plane swept around the z axis."""

    def __init__(self, shape: SDF, offset: float) -> None:
        self.shape, self.offset = shape, offset
        self.analytic_gradient = shape.analytic_gradient
        bounds = None
        exact = False
        if shape.bounds is not None:
            (u0, z0), (u1, z1) = shape.bounds
            outer = u1 + offset
            if outer <= 0:
                raise ValueError(
                    f"revolve: shape2d lies at r = u + offset <= 0 (u <= {u1:g}, offset {offset:g}); "
                    "the profile must reach r > 0"
                )
            bounds = ((-outer, -outer, z0), (outer, outer, z1))
            # Off the axis, the distance in the meridian plane is the 3D distance. A profile that
            # reaches the axis may have boundary there that is not a surface of the solid.
            # (a polygon's mirrored section is exact across the axis)
            exact = shape.exact and (u0 + offset > 0 or isinstance(shape, AxisSection))
        super().__init__(bounds=bounds, exact=exact, children=(shape,))

    def _parameters(self) -> dict[str, Any]:
        return {"offset": self.offset}

    def _label(self) -> str:
        return "revolve"

    def _values(self, x, y, z):
        _, _, r = radial(x, y, 0.0, 0.0)
        return self.shape._values(r - self.offset, z)

    def _meridian_points(self, points: np.ndarray) -> np.ndarray:
        r = np.sqrt(points[:, 0] ** 2 + points[:, 1] ** 2)
        return np.column_stack([r - self.offset, points[:, 2]])

    @property
    def patch_count(self) -> int:
        return self.shape.patch_count

    def _patch_labels(self, points):
        return self._values(*points.T), self.shape._patch_labels(self._meridian_points(points))[1]

    def _patch_values(self, labels, points):
        return self.shape._patch_values(labels, self._meridian_points(points))

    def _values_and_gradient(self, x, y, z) -> tuple[np.ndarray, Coords]:
        dx, dy, r = radial(x, y, 0.0, 0.0)
        ux, uy = radial_direction(dx, dy, r)
        values, (gr, gz) = self.shape._values_and_gradient(r - self.offset, z)
        values, gr, gz, ux, uy = np.broadcast_arrays(values, gr, gz, ux, uy)
        return values, (gr * ux, gr * uy, gz.copy())


def revolve(shape2d: SDF, offset: float = 0.0) -> SDF:
    """Solid of revolution about the z axis: ``{(x, y, z): shape2d(sqrt(x^2 + y^2) - offset, z) < 0}``.

    The 2D shape's x coordinate is the distance from the z axis minus ``offset``, its y coordinate
    is z. A profile that touches or crosses the axis (``xmin + offset <= 0``, e.g. a shaft's
    half-section drawn from the axis) is revolved together with its mirror image about the axis:
    the two are one region, so the axis is inside the solid, not a seam of zero value (25-34
    surface components and zero-area faces along the axis). For a :func:`polygon` profile the
    section ``profile | mirror`` is built exactly (:mod:`fepre.sdf.axis_section`) and the value is
    the distance; for other profiles it is a 1-Lipschitz lower bound there. ``exact`` is True
    when ``shape2d`` is exact and either its bounds stay off the axis (``xmin + offset > 0``,
    e.g. a torus from a circle) or it is a polygon.

    Examples
    --------
    >>> from fepre import sdf
    >>> ring = sdf.revolve(sdf.circle(0.5), offset=2.0)   # a torus
    >>> ring.exact, float(ring([2.0, 0.0, 1.5]))
    (True, 1.0)
    """
    shape2d, offset = _shape2d(shape2d), finite_float(offset, "offset")
    bounds = shape2d.bounds
    if bounds is not None and bounds[0][0] + offset <= 0.0:
        # on the axis the profile's own edge has value 0: union it with its mirror image so the
        # axis lies inside (the union's shared face is settled on grids, see fepre.sdf.touching)
        if type(shape2d) is Polygon:
            return Revolution(mirrored_section(shape2d, offset), 0.0)
        placed = shape2d.translate((offset, 0.0)) if offset else shape2d
        return Revolution(placed | placed.mirror((1.0, 0.0)), 0.0)
    return Revolution(shape2d, offset)
