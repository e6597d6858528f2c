"""Three-dimensional primitive solids."""

from __future__ import annotations

from typing import Any

import numpy as np

from ..arguments import as_vector, positive_float
from .core import SDF, Coords

__all__ = ["sphere"]


class Sphere(SDF):
    """Ball of ``radius`` around ``center`` (exact)."""

    analytic_gradient = True

    def __init__(self, radius: float, center: np.ndarray) -> None:
        self.radius = radius
        self.center = center
        super().__init__(bounds=(tuple(center - radius), tuple(center + radius)), exact=True)

    def _parameters(self) -> dict[str, Any]:
        return {"radius": self.radius, "center": self.center}

    def _label(self) -> str:
        return "sphere"

    def _values(self, x, y, z):
        cx, cy, cz = self.center
        return np.sqrt((x - cx) ** 2 + (y - cy) ** 2 + (z - cz) ** 2) - self.radius

    def _values_and_gradient(self, x, y, z) -> tuple[np.ndarray, Coords]:
        cx, cy, cz = self.center
        dx, dy, dz = np.broadcast_arrays(x - cx, y - cy, z - cz)
        r = np.sqrt(dx * dx + dy * dy + dz * dz)
        safe = np.where(r > 0, r, 1.0)
        gx = np.where(r > 0, dx / safe, 0.0)
        gy = np.where(r > 0, dy / safe, 0.0)
        gz = np.where(r > 0, dz / safe, 1.0)
        return r - self.radius, (gx, gy, gz)


def sphere(radius: float = 1.0, center: Any = (0.0, 0.0, 0.0)) -> SDF:
    """Ball of ``radius`` centred at ``center`` (exact distance).

    Examples
    --------
    >>> from fepre import sdf
    >>> float(sdf.sphere(2.0, center=(1, 0, 0))([1.0, 0.0, 0.0]))
    -2.0
    """
    return Sphere(positive_float(radius, "radius"), as_vector(center, 3, "center"))
