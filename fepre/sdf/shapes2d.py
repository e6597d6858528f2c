"""Two-dimensional shapes (circle, rectangle, polygon) for extrusion and revolution.

A 2D shape is an :class:`SDF` with ``dim = 2``: it is called on (N, 2) arrays and its
``_values`` takes broadcastable ``x, y`` arrays. :func:`fepre.sdf.extrude` and
:func:`fepre.sdf.revolve` turn it into a solid.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from ..arguments import as_vector, finite_float, positive_float, positive_int
from .core import SDF, Coords
from .polygon import Polygon, polygon
from .parameters import floats, positive_vector
from .solids import Box

__all__ = ["circle", "rectangle", "rounded_rectangle", "polygon", "regular_polygon"]


class Circle(SDF):
    """Disk of ``radius`` around ``center`` (exact)."""

    dim = 2
    analytic_gradient = True

    def __init__(self, radius: float, center: np.ndarray) -> None:
        self.radius, self.center = radius, center
        self._c = floats(center)
        super().__init__(bounds=(tuple(center - radius), tuple(center + radius)), exact=True)

    def _parameters(self) -> dict[str, Any]:
        return {"radius": self.radius, "center": self.center}

    def _label(self) -> str:
        return "circle"

    def _values(self, x, y):
        cx, cy = self._c
        return np.sqrt((x - cx) ** 2 + (y - cy) ** 2) - self.radius

    def _values_and_gradient(self, x, y) -> tuple[np.ndarray, Coords]:
        cx, cy = self._c
        dx, dy = np.broadcast_arrays(x - cx, y - cy)
        r = np.sqrt(dx * dx + dy * dy)
        safe = np.where(r > 0, r, 1.0)
        return r - self.radius, (np.where(r > 0, dx / safe, 1.0), np.where(r > 0, dy / safe, 0.0))


def circle(radius: float = 1.0, center: Any = (0.0, 0.0)) -> SDF:
    """Disk of ``radius`` centred at ``center`` (2D, exact).

    Examples
    --------
    >>> from fepre import sdf
    >>> float(sdf.circle(1.0)([3.0, 4.0]))
    4.0
    """
    return Circle(positive_float(radius, "radius"), as_vector(center, 2, "center"))


def rectangle(size: Any = (1.0, 1.0), center: Any = (0.0, 0.0)) -> SDF:
    """Axis-aligned rectangle of side lengths ``size`` centred at ``center`` (2D, exact).

    Examples
    --------
    >>> from fepre import sdf
    >>> float(sdf.rectangle((2, 2))([4.0, 5.0]))  # to the corner (1, 1)
    5.0
    """
    return Box(positive_vector(size, 2, "size"), as_vector(center, 2, "center"), dim=2)


def rounded_rectangle(size: Any = (1.0, 1.0), radius: float = 0.1, center: Any = (0.0, 0.0)) -> SDF:
    """Rectangle of outer side lengths ``size`` with corners rounded by ``radius`` (2D, exact).

    ``radius`` must be at most half the shorter side.

    Examples
    --------
    >>> from fepre import sdf
    >>> slot = sdf.rounded_rectangle((4, 2), radius=1.0)
    >>> float(slot([3.0, 0.0])), float(slot([0.0, 2.0]))
    (1.0, 1.0)
    """
    size = positive_vector(size, 2, "size")
    radius = positive_float(radius, "radius")
    if radius > float(size.min()) / 2.0:
        raise ValueError(f"radius must be <= half the shorter side ({float(size.min()) / 2:g}); got {radius:g}")
    return Box(size, as_vector(center, 2, "center"), rounding=radius, dim=2)


def regular_polygon(sides: int = 6, radius: float = 1.0, center: Any = (0.0, 0.0), angle: float = 0.0) -> Polygon:
    """Regular polygon with ``sides`` vertices on a circle of ``radius`` (2D, exact).

    The first vertex lies at ``angle`` degrees from the x axis.

    Examples
    --------
    >>> from fepre import sdf
    >>> hexagon = sdf.regular_polygon(6, radius=1.0)
    >>> round(float(hexagon([0.0, 0.0])), 12)  # minus the apothem, cos(30 deg)
    -0.866025403784
    """
    sides = positive_int(sides, "sides")
    if sides < 3:
        raise ValueError(f"sides must be >= 3; got {sides}")
    radius = positive_float(radius, "radius")
    center = as_vector(center, 2, "center")
    angles = np.radians(finite_float(angle, "angle")) + 2.0 * np.pi * np.arange(sides) / sides
    return polygon(center + radius * np.column_stack([np.cos(angles), np.sin(angles)]))
