"""Unbounded solids bounded by planes: the half-space and the slab."""

from __future__ import annotations

from typing import Any

import numpy as np

from ..arguments import as_vector, positive_float
from .core import SDF, Coords
from .orthant import axis_sign
from .parameters import floats, unit_vector

__all__ = ["plane", "slab"]


class Plane(SDF):
    """Half-space below a plane: negative on the side opposite ``normal`` (exact, unbounded)."""

    analytic_gradient = True

    def __init__(self, normal: np.ndarray, point: np.ndarray) -> None:
        self.normal, self.point = normal, point
        self._n = floats(normal)
        self._offset = float(np.dot(normal, point))
        super().__init__(bounds=None, exact=True)

    def _parameters(self) -> dict[str, Any]:
        return {"normal": self.normal, "point": self.point}

    def _label(self) -> str:
        return "plane"

    def _height(self, x, y, z):
        nx, ny, nz = self._n
        return x * nx + y * ny + (z * nz - self._offset)

    def _values(self, x, y, z):
        return self._height(x, y, z)

    def _values_and_gradient(self, x, y, z) -> tuple[np.ndarray, Coords]:
        values = np.asarray(self._height(x, y, z))
        return values, tuple(np.full(values.shape, n, dtype=values.dtype) for n in self._n)


def plane(normal: Any = (0.0, 0.0, 1.0), point: Any = (0.0, 0.0, 0.0)) -> SDF:
    """Half-space ``dot(p - point, normal) <= 0``: the solid lies opposite the (normalised) ``normal``.

    Exact; unbounded (``bounds`` is None). Intersect it with a bounded solid to cut that solid.

    Examples
    --------
    >>> from fepre import sdf
    >>> ground = sdf.plane(normal=(0, 0, 2), point=(0, 0, 1))
    >>> float(ground([5.0, 5.0, 4.0])), ground.bounds
    (3.0, None)
    """
    return Plane(unit_vector(as_vector(normal, 3, "normal"), "normal"), as_vector(point, 3, "point"))


class Slab(SDF):
    """Region between two parallel planes (exact, unbounded)."""

    analytic_gradient = True

    def __init__(self, normal: np.ndarray, thickness: float, center: np.ndarray) -> None:
        self.normal, self.thickness, self.center = normal, thickness, center
        self._n = floats(normal)
        self._offset = float(np.dot(normal, center))
        super().__init__(bounds=None, exact=True)

    def _parameters(self) -> dict[str, Any]:
        return {"normal": self.normal, "thickness": self.thickness, "center": self.center}

    def _label(self) -> str:
        return "slab"

    def _height(self, x, y, z):
        nx, ny, nz = self._n
        return x * nx + y * ny + (z * nz - self._offset)

    def _values(self, x, y, z):
        height = self._height(x, y, z)
        return np.abs(height) - self.thickness / 2.0

    def _values_and_gradient(self, x, y, z) -> tuple[np.ndarray, Coords]:
        height = np.asarray(self._height(x, y, z))
        sign = axis_sign(height)
        return np.abs(height) - self.thickness / 2.0, tuple(sign * n for n in self._n)


def slab(normal: Any = (0.0, 0.0, 1.0), thickness: float = 1.0, center: Any = (0.0, 0.0, 0.0)) -> SDF:
    """Points within ``thickness / 2`` of the plane through ``center`` with ``normal`` (exact).

    The slab is unbounded (``bounds`` is None); intersect it with a bounded solid.

    Examples
    --------
    >>> from fepre import sdf
    >>> layer = sdf.slab(normal=(0, 0, 1), thickness=2.0, center=(0, 0, 1))
    >>> float(layer([3.0, 0.0, 5.0])), float(layer([3.0, 0.0, 1.0]))
    (3.0, -1.0)
    """
    return Slab(
        unit_vector(as_vector(normal, 3, "normal"), "normal"),
        positive_float(thickness, "thickness"),
        as_vector(center, 3, "center"),
    )
