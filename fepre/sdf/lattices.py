"""Triply periodic minimal surface lattices (gyroid, Schwarz P/D, Neovius) and infill.

Each lattice is an implicit function ``g`` of ``(kx, ky, kz)`` with ``k = 2 pi / period``,
divided by a proven upper bound ``G`` of ``|grad g|`` so the result is 1-Lipschitz:

* gyroid ``sin x cos y + sin y cos z + sin z cos x``: the x-component of the gradient is
  ``k (cos x, -sin x) . (cos y, sin z)``, so by Cauchy-Schwarz its square is at most
  ``k^2 (cos^2 y + sin^2 z)``; summing the three cyclic components gives ``|grad g|^2 <= 3 k^2``.
* Schwarz P ``cos x + cos y + cos z``: ``|grad g|^2 = k^2 (sin^2 x + sin^2 y + sin^2 z) <= 3 k^2``.
* Schwarz D ``sin x sin y sin z + sin x cos y cos z + cos x sin y cos z + cos x cos y sin z``
  ``= sin x cos u + cos x sin v`` with ``u = y - z``, ``v = y + z``. Since
  ``d/dy = d/du + d/dv`` and ``d/dz = d/dv - d/du``,
  ``|grad g|^2 / k^2 = (a cos u - b sin v)^2 + 2 b^2 sin^2 u + 2 a^2 cos^2 v`` with
  ``a = cos x``, ``b = sin x``. Cauchy-Schwarz bounds the first term by ``cos^2 u + sin^2 v``,
  so the sum is at most ``max(1, 2 b^2) + max(1, 2 a^2) <= 3`` (as ``a^2 + b^2 = 1``):
  ``|grad g| <= sqrt(3) k``.
* Neovius ``3 (cos x + cos y + cos z) + 4 cos x cos y cos z``: with ``s_i = cos^2 x_i``,
  ``|grad g|^2 / k^2 = sum (1 - s_i) (3 + 4 cos x_j cos x_k)^2
  <= sum (1 - s_i) (3 + 2 s_j + 2 s_k)^2`` (AM-GM). With ``w_i = 1 - s_i`` in [0, 1] and
  ``W = sum w_i`` this is ``sum w_i (7 - 2W + 2 w_i)^2``, convex in each ``w_i`` for fixed ``W``,
  so its largest value is at a vertex ``(1, .., 1, W - m, 0, ..)``; checking the three pieces
  gives at most 50 (at ``W = 2``): ``|grad g| <= sqrt(50) k`` (sampled maximum: ``7 k``).

``form="sheet"`` (default) is the thickened surface ``|g| / G - thickness / 2``;
``form="network"`` the solid on the negative side, ``g / G - thickness / 2``. Because ``G``
bounds the gradient from above, ``thickness`` is the sheet's thinnest wall: where ``|grad g|``
is below its bound the wall is thicker, ``thickness * G / |grad g|`` to first order. Measured
over the surface of one cell (area-weighted, thin walls; ``tests/test_sdf_lattices.py`` checks
these figures):

============  ===========  ==========  =======
lattice       mean wall    thickest    thinnest
============  ===========  ==========  =======
gyroid        1.13 t       1.22 t      1.00 t
schwarz_p     1.32 t       1.73 t      1.00 t
schwarz_d     1.16 t       1.22 t      1.00 t
neovius       2.75 t       ~7 t        1.36 t
============  ===========  ==========  =======

So ``thickness`` is what a printer or a minimum-gauge rule needs (no wall is thinner); for a
given mean wall or relative density divide by the mean factor. Lattices are unbounded
(``bounds`` is None) and never exact.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from ..arguments import as_vector, choice, positive_float
from .booleans import check_operands
from .core import SDF

__all__ = ["gyroid", "schwarz_p", "schwarz_d", "neovius", "infill"]

FORMS = ("sheet", "network")


class Lattice(SDF):
    """A normalised triply periodic implicit surface (see the module notes for the bounds)."""

    name = "lattice"
    #: Proven bound of |grad g| / k.
    gradient_bound = 1.0

    def __init__(self, period: float, thickness: float, form: str, center: np.ndarray) -> None:
        self.period = period
        self.thickness = thickness
        self.form = form
        self.center = center
        self.k = 2.0 * math.pi / period
        self._scale = 1.0 / (self.k * self.gradient_bound)
        super().__init__(bounds=None, exact=False)

    def _label(self) -> str:
        return self.name

    def _parameters(self) -> dict[str, Any]:
        return {"period": self.period, "thickness": self.thickness, "form": self.form}

    @property
    def length_scale(self) -> float:
        return self.period

    def _angles(self, coords):
        return [(c - float(m)) * self.k for c, m in zip(coords, self.center)]

    def implicit(self, x, y, z):
        """The raw implicit function ``g`` at angles ``(x, y, z)`` (already multiplied by k)."""
        raise NotImplementedError

    def _values(self, *coords):
        g = self.implicit(*self._angles(coords)) * self._scale
        if self.form == "sheet":
            g = np.abs(g)
        return g - self.thickness / 2.0


class Gyroid(Lattice):
    name = "gyroid"
    gradient_bound = math.sqrt(3.0)

    def implicit(self, x, y, z):
        sx, cx, sy, cy, sz, cz = np.sin(x), np.cos(x), np.sin(y), np.cos(y), np.sin(z), np.cos(z)
        return sx * cy + sy * cz + sz * cx


class SchwarzP(Lattice):
    name = "schwarz_p"
    gradient_bound = math.sqrt(3.0)

    def implicit(self, x, y, z):
        return np.cos(x) + np.cos(y) + np.cos(z)


class SchwarzD(Lattice):
    name = "schwarz_d"
    gradient_bound = math.sqrt(3.0)

    def implicit(self, x, y, z):
        sx, cx, sy, cy, sz, cz = np.sin(x), np.cos(x), np.sin(y), np.cos(y), np.sin(z), np.cos(z)
        return sx * sy * sz + sx * cy * cz + cx * sy * cz + cx * cy * sz


class Neovius(Lattice):
    name = "neovius"
    gradient_bound = math.sqrt(50.0)

    def implicit(self, x, y, z):
        cx, cy, cz = np.cos(x), np.cos(y), np.cos(z)
        return 3.0 * (cx + cy + cz) + 4.0 * cx * cy * cz


def _make(kind: type[Lattice], period: Any, thickness: Any, form: str, center: Any) -> Lattice:
    return kind(
        positive_float(period, "period"),
        positive_float(thickness, "thickness"),
        choice(form, "form", FORMS),
        as_vector(center, 3, "center"),
    )


def gyroid(period: float = 1.0, thickness: float = 0.1, form: str = "sheet", center: Any = (0.0, 0.0, 0.0)) -> SDF:
    """Gyroid lattice of cell size ``period``; a sheet whose thinnest wall is ``thickness``, or a network.

    The wall is thicker where the gyroid's gradient is below its bound: 1.13 ``thickness`` on
    average over the surface, 1.22 at most (:mod:`fepre.sdf.lattices` gives the figures of
    every lattice).

    Examples
    --------
    >>> from fepre import sdf
    >>> g = sdf.gyroid(period=2.0, thickness=0.2)
    >>> float(g([0.0, 0.0, 0.0]))  # the gyroid passes through the origin
    -0.1
    """
    return _make(Gyroid, period, thickness, form, center)


def schwarz_p(period: float = 1.0, thickness: float = 0.1, form: str = "sheet", center: Any = (0.0, 0.0, 0.0)) -> SDF:
    """Schwarz P (primitive) lattice; see :func:`gyroid` for the parameters.

    Examples
    --------
    >>> from fepre import sdf
    >>> round(float(sdf.schwarz_p(period=1.0, thickness=0.1)([0.25, 0.25, 0.0])), 6)
    0.041888
    """
    return _make(SchwarzP, period, thickness, form, center)


def schwarz_d(period: float = 1.0, thickness: float = 0.1, form: str = "sheet", center: Any = (0.0, 0.0, 0.0)) -> SDF:
    """Schwarz D (diamond) lattice; see :func:`gyroid` for the parameters.

    Examples
    --------
    >>> from fepre import sdf
    >>> float(sdf.schwarz_d(period=1.0, thickness=0.1)([0.0, 0.0, 0.0]))
    -0.05
    """
    return _make(SchwarzD, period, thickness, form, center)


def neovius(period: float = 1.0, thickness: float = 0.1, form: str = "sheet", center: Any = (0.0, 0.0, 0.0)) -> SDF:
    """Neovius lattice; see :func:`gyroid` for the parameters.

    Examples
    --------
    >>> from fepre import sdf
    >>> sdf.neovius(period=1.0, thickness=0.1, form="network").bounds is None
    True
    """
    return _make(Neovius, period, thickness, form, center)


def infill(part: SDF, lattice: SDF, wall: float) -> SDF:
    """``part`` as a skin of thickness ``wall`` filled with ``lattice``.

    The result is ``part.shell(wall) | (lattice & part)``; its bounds are the part's.

    Examples
    --------
    >>> from fepre import sdf
    >>> light = sdf.infill(sdf.sphere(1.0), sdf.gyroid(period=0.5, thickness=0.05), wall=0.1)
    >>> light.bounds == sdf.sphere(1.0).bounds
    True
    """
    part, lattice = check_operands((part, lattice), "infill")
    wall = positive_float(wall, "wall")
    return part.shell(wall) | (lattice & part)
