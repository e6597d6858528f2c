"""Three-dimensional primitive solids.

Every primitive is centred at the origin unless ``center=`` says otherwise. Evaluation keeps
work that depends on one axis on that axis' array (a grid passes ``x`` as (1, 1, nx), ``y`` as
(1, ny, 1), ``z`` as (nz, 1, 1)), and uses Python floats for constants so float32 grids stay
float32. This module holds the sphere, boxes, capsule and ellipsoid and gathers the other 3D
primitives: :mod:`.radial` (cylinder, cone, torus), :mod:`.halfspaces` (plane, slab) and
:mod:`.polyhedra` (tetrahedron, octahedron).
"""

from __future__ import annotations

from typing import Any

import numpy as np

from ..arguments import as_vector, positive_float
from .core import SDF, Coords
from .halfspaces import plane, slab
from .orthant import axis_sign, orthant_distance, orthant_gradient
from .parameters import floats, positive_vector
from .polyhedra import octahedron, tetrahedron
from .radial import cone, cylinder, torus

__all__ = [
    "sphere",
    "box",
    "rounded_box",
    "cylinder",
    "capsule",
    "cone",
    "torus",
    "ellipsoid",
    "plane",
    "slab",
    "tetrahedron",
    "octahedron",
]


class Sphere(SDF):
    """Ball of ``radius`` around ``center`` (exact)."""

    analytic_gradient = True

    def __init__(self, radius: float, center: np.ndarray) -> None:
        self.radius = radius
        self.center = center
        self._c = floats(center)
        super().__init__(bounds=(tuple(center - radius), tuple(center + radius)), exact=True)

    def _parameters(self) -> dict[str, Any]:
        return {"radius": self.radius, "center": self.center}

    def _label(self) -> str:
        return "sphere"

    def _values(self, x, y, z):
        cx, cy, cz = self._c
        squared = (x - cx) ** 2 + (y - cy) ** 2 + (z - cz) ** 2  # a fresh array: finish in place
        np.sqrt(squared, out=squared)
        squared -= self.radius
        return squared

    def _values_into(self, target: np.ndarray, x, y, z) -> None:
        cx, cy, cz = self._c
        np.add((x - cx) ** 2 + (y - cy) ** 2, (z - cz) ** 2, out=target)  # same order as _values
        np.sqrt(target, out=target)
        target -= self.radius

    def _values_and_gradient(self, x, y, z) -> tuple[np.ndarray, Coords]:
        cx, cy, cz = self._c
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


class Box(SDF):
    """Axis-aligned box (or, with ``dim = 2``, rectangle), optionally with rounded edges (exact).

    The value is the distance to the box of half sizes ``half - rounding`` minus ``rounding``:
    the set of points within ``rounding`` of that smaller box.
    """

    analytic_gradient = True

    def __init__(self, size: np.ndarray, center: np.ndarray, rounding: float = 0.0, dim: int = 3) -> None:
        self.dim = dim
        self.size = size
        self.center = center
        self.rounding = rounding
        self._c = floats(center)
        self._h = floats(size / 2.0 - rounding)
        half = size / 2.0
        super().__init__(bounds=(tuple(center - half), tuple(center + half)), exact=True)

    def _parameters(self) -> dict[str, Any]:
        parameters: dict[str, Any] = {"size": self.size, "center": self.center}
        if self.rounding > 0:
            parameters["radius"] = self.rounding
        return parameters

    def _label(self) -> str:
        name = "box" if self.dim == 3 else "rectangle"
        return f"rounded_{name}" if self.rounding > 0 else name

    def _parts(self, coords):
        return [np.abs(u - c) - h for u, c, h in zip(coords, self._c, self._h)]

    def _values(self, *coords):
        values = orthant_distance(self._parts(coords))
        if self.rounding > 0:
            values -= self.rounding
        return values

    @property
    def patch_count(self) -> int:
        return 2 * self.dim if self.rounding == 0 else 1  # faces 2 * axis + (1 on the + side)

    def _patch_labels(self, points):
        if self.rounding > 0:
            return super()._patch_labels(points)
        parts = np.column_stack(self._parts(points.T))
        axis = np.argmax(parts, axis=1)
        side = points[np.arange(points.shape[0]), axis] > np.asarray(self._c)[axis]
        return self._values(*points.T), 2 * axis + side

    def _patch_values(self, labels, points):
        if self.rounding > 0:
            return super()._patch_values(labels, points)
        axis = labels // 2
        sign = np.where(labels % 2 == 1, 1.0, -1.0)
        offset = points[np.arange(points.shape[0]), axis] - np.asarray(self._c)[axis]
        return sign * offset - np.asarray(self._h)[axis]

    def _values_into(self, target: np.ndarray, *coords) -> None:
        orthant_distance(self._parts(coords), out=target)
        if self.rounding > 0:
            target -= self.rounding

    def _values_and_gradient(self, *coords) -> tuple[np.ndarray, Coords]:
        parts = self._parts(coords)
        gradients = []
        for axis, (u, c) in enumerate(zip(coords, self._c)):
            unit: list[Any] = [0.0] * self.dim
            unit[axis] = axis_sign(u - c)
            gradients.append(unit)
        values, gradient = orthant_gradient(parts, gradients)
        return values - self.rounding, gradient


def box(size: Any = (1.0, 1.0, 1.0), center: Any = (0.0, 0.0, 0.0)) -> SDF:
    """Axis-aligned box of edge lengths ``size`` centred at ``center`` (exact, corners too).

    Parameters
    ----------
    size : float or (3,) sequence of float
        Edge lengths along x, y, z (a number gives a cube); each > 0.
    center : (3,) sequence of float

    Examples
    --------
    >>> from fepre import sdf
    >>> cube = sdf.box(2.0)
    >>> float(cube([2.0, 2.0, 0.0]))  # distance to the edge at (1, 1, z)
    1.4142135623730951
    """
    size = positive_vector(size, 3, "size")
    return Box(size, as_vector(center, 3, "center"))


def rounded_box(size: Any = (1.0, 1.0, 1.0), radius: float = 0.1, center: Any = (0.0, 0.0, 0.0)) -> SDF:
    """Box of outer edge lengths ``size`` whose edges and corners are rounded with ``radius``.

    The solid fits in the same bounds as ``box(size, center)``; ``radius`` must be at most half
    the smallest edge (at exactly half, the two faces across that edge become one half-round).
    Exact: the distance to the box shrunk by ``radius``, minus ``radius``.

    Examples
    --------
    >>> from fepre import sdf
    >>> part = sdf.rounded_box((2, 2, 2), radius=0.5)
    >>> round(float(part([1.0, 1.0, 1.0])), 6)  # corner: sqrt(3) * 0.5 - 0.5
    0.366025
    """
    size = positive_vector(size, 3, "size")
    radius = positive_float(radius, "radius")
    if radius > float(size.min()) / 2.0:
        raise ValueError(f"radius must be <= half the smallest edge ({float(size.min()) / 2:g}); got {radius:g}")
    return Box(size, as_vector(center, 3, "center"), rounding=radius)


class Capsule(SDF):
    """Points within ``radius`` of the segment from ``a`` to ``b`` (exact)."""

    analytic_gradient = True

    def __init__(self, a: np.ndarray, b: np.ndarray, radius: float) -> None:
        self.a, self.b, self.radius = a, b, radius
        self._a = floats(a)
        self._e = floats(b - a)
        self._inverse_length2 = 1.0 / float(np.dot(b - a, b - a))
        lo, hi = np.minimum(a, b) - radius, np.maximum(a, b) + radius
        super().__init__(bounds=(tuple(lo), tuple(hi)), exact=True)

    def _parameters(self) -> dict[str, Any]:
        return {"a": self.a, "b": self.b, "radius": self.radius}

    def _label(self) -> str:
        return "capsule"

    def _offsets(self, x, y, z):
        w = [u - a for u, a in zip((x, y, z), self._a)]
        t = w[0] * (self._e[0] * self._inverse_length2)
        t = t + w[1] * (self._e[1] * self._inverse_length2)
        t = t + w[2] * (self._e[2] * self._inverse_length2)
        np.clip(t, 0.0, 1.0, out=t)
        return [wi - ei * t for wi, ei in zip(w, self._e)]

    def _values(self, x, y, z):
        ox, oy, oz = self._offsets(x, y, z)
        return np.sqrt(ox * ox + oy * oy + oz * oz) - self.radius

    def _values_and_gradient(self, x, y, z) -> tuple[np.ndarray, Coords]:
        ox, oy, oz = np.broadcast_arrays(*self._offsets(x, y, z))
        length = np.sqrt(ox * ox + oy * oy + oz * oz)
        on_axis = length == 0
        safe = np.where(on_axis, 1.0, length)
        # On the segment itself any direction perpendicular to it is a gradient; pick one.
        e = np.array(self._e)
        normal = np.cross(e, np.eye(3)[int(np.argmin(np.abs(e)))])
        normal /= np.linalg.norm(normal)
        gradient = tuple(np.where(on_axis, float(n), o / safe) for o, n in zip((ox, oy, oz), normal))
        return length - self.radius, gradient


def capsule(a: Any = (0.0, 0.0, -0.5), b: Any = (0.0, 0.0, 0.5), radius: float = 0.5) -> SDF:
    """Points within ``radius`` of the segment from ``a`` to ``b`` (exact); ``a`` != ``b``.

    Examples
    --------
    >>> from fepre import sdf
    >>> pill = sdf.capsule((0, 0, 0), (2, 0, 0), radius=0.5)
    >>> float(pill([1.0, 2.0, 0.0])), float(pill([3.0, 0.0, 0.0]))
    (1.5, 0.5)
    """
    a = as_vector(a, 3, "a")
    b = as_vector(b, 3, "b")
    radius = positive_float(radius, "radius")
    scale = max(1.0, float(np.abs(a).max()), float(np.abs(b).max()), radius)
    if not np.linalg.norm(b - a) > 1e-12 * scale:
        raise ValueError(
            f"capsule needs end points a and b at least 1e-12 x the part's size apart; got "
            f"a = {a.tolist()}, b = {b.tolist()} (use sphere for a ball)"
        )
    return Capsule(a, b, radius)


class Ellipsoid(SDF):
    """Ellipsoid with semi-axes ``radii`` (a 1-Lipschitz lower bound of the distance).

    ``min(radii) * (|p / radii| - 1)`` is 1-Lipschitz (its gradient has norm at most 1) and is
    zero exactly on the surface, so its magnitude never exceeds the distance. Outside, the
    distance to the circumscribed ball, ``|p| - max(radii)``, is also a lower bound and is much
    tighter far away; the value is the larger of the two.
    """

    analytic_gradient = True

    def __init__(self, radii: np.ndarray, center: np.ndarray) -> None:
        self.radii, self.center = radii, center
        self._c = floats(center)
        self._inverse = floats(1.0 / radii)
        self._smallest = float(radii.min())
        self._largest = float(radii.max())
        super().__init__(bounds=(tuple(center - radii), tuple(center + radii)), exact=False)

    def _parameters(self) -> dict[str, Any]:
        return {"radii": self.radii, "center": self.center}

    def _label(self) -> str:
        return "ellipsoid"

    def _values(self, x, y, z):
        d = [u - c for u, c in zip((x, y, z), self._c)]
        scaled = [di * k for di, k in zip(d, self._inverse)]
        normalised = np.sqrt(scaled[0] ** 2 + scaled[1] ** 2 + scaled[2] ** 2)
        bound = (normalised - 1.0) * self._smallest
        ball = np.sqrt(d[0] ** 2 + d[1] ** 2 + d[2] ** 2) - self._largest
        return np.maximum(bound, ball, out=bound)

    def _values_and_gradient(self, x, y, z) -> tuple[np.ndarray, Coords]:
        d = np.broadcast_arrays(*(u - c for u, c in zip((x, y, z), self._c)))
        scaled = [di * k for di, k in zip(d, self._inverse)]
        normalised = np.sqrt(scaled[0] ** 2 + scaled[1] ** 2 + scaled[2] ** 2)
        length = np.sqrt(d[0] ** 2 + d[1] ** 2 + d[2] ** 2)
        bound = (normalised - 1.0) * self._smallest
        ball = length - self._largest
        use_ball = ball > bound
        # At the centre both gradients vanish; +z is as good a direction as any.
        safe_n = np.where(normalised > 0, normalised, 1.0)
        safe_l = np.where(length > 0, length, 1.0)
        gradient = []
        for axis, (di, si, k) in enumerate(zip(d, scaled, self._inverse)):
            g_bound = si * (k * self._smallest) / safe_n
            g_ball = di / safe_l
            fallback = 1.0 if axis == 2 else 0.0
            g = np.where(use_ball, g_ball, g_bound)
            gradient.append(np.where((normalised > 0) | use_ball, g, fallback).astype(g_ball.dtype, copy=False))
        return np.maximum(bound, ball), tuple(gradient)


def ellipsoid(radii: Any = (1.0, 0.5, 0.25), center: Any = (0.0, 0.0, 0.0)) -> SDF:
    """Axis-aligned ellipsoid with semi-axes ``radii`` (exact=False: a 1-Lipschitz lower bound).

    The value has the right sign and zero set; its magnitude never exceeds the true distance
    (it equals it on the surface and along the smallest axis inside).

    Examples
    --------
    >>> from fepre import sdf
    >>> egg = sdf.ellipsoid((2.0, 1.0, 1.0))
    >>> egg.exact, float(egg([0.0, 0.0, 0.0]))
    (False, -1.0)
    """
    return Ellipsoid(positive_vector(radii, 3, "radii"), as_vector(center, 3, "center"))
