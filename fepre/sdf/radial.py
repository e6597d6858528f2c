"""Solids with an axis of symmetry: cylinder, cone and torus.

Their values depend on the distance ``rho`` from the axis and on z; on a grid ``rho`` is computed
on the (y, x) plane of a block and only the combination with z runs at full size. Another
``axis=`` rotates the z-axis solid onto it (an exact rotation, collapsed with later transforms).
"""

from __future__ import annotations

from typing import Any

import numpy as np

from ..arguments import as_vector, positive_float
from .core import SDF, Coords
from .orthant import axis_sign, orthant_distance, orthant_gradient
from .parameters import floats

__all__ = ["cylinder", "cone", "torus"]

_NAMED_AXES = {"x": (1.0, 0.0, 0.0), "y": (0.0, 1.0, 0.0), "z": (0.0, 0.0, 1.0)}


def unit_axis(axis: Any) -> np.ndarray:
    """The unit vector of ``axis``: ``"x"``, ``"y"``, ``"z"`` or a non-zero 3-vector."""
    if isinstance(axis, str):
        if axis.lower() not in _NAMED_AXES:
            raise ValueError(f"axis must be 'x', 'y', 'z' or a 3-vector; got {axis!r}")
        return np.array(_NAMED_AXES[axis.lower()])
    vector = as_vector(axis, 3, "axis")
    length = float(np.linalg.norm(vector))
    if length == 0.0:
        raise ValueError(f"axis must be a non-zero vector; got {vector.tolist()}")
    return vector / length


def z_to(axis: np.ndarray) -> np.ndarray:
    """A rotation matrix taking the z axis onto the unit vector ``axis`` (the shortest turn)."""
    z = np.array([0.0, 0.0, 1.0])
    cosine = float(axis @ z)
    if cosine > 1.0 - 1e-15:
        return np.eye(3)
    if cosine < -1.0 + 1e-15:
        return np.diag([1.0, -1.0, -1.0])  # half a turn about x
    turn = np.cross(z, axis)
    sine = float(np.linalg.norm(turn))
    u = turn / sine
    cross = np.array([[0, -u[2], u[1]], [u[2], 0, -u[0]], [-u[1], u[0], 0]])
    return cosine * np.eye(3) + sine * cross + (1 - cosine) * np.outer(u, u)


def _placed(make: Any, center: Any, axis: Any) -> SDF:
    """``make(center)`` for the z axis; otherwise made at the origin and turned onto ``axis``."""
    center = as_vector(center, 3, "center")
    direction = unit_axis(axis)
    if np.array_equal(direction, [0.0, 0.0, 1.0]):
        return make(center)
    from .transforms import _apply, _fmt, _homogeneous

    return _apply(make(np.zeros(3)), _homogeneous(z_to(direction), center), f"axis{_fmt(direction)}, center{_fmt(center)}")


def radial(x, y, cx: float, cy: float):
    """Offsets from the axis through (cx, cy) and the distance to it."""
    dx, dy = x - cx, y - cy
    return dx, dy, np.sqrt(dx * dx + dy * dy)


def radial_direction(dx, dy, rho):
    """Unit radial components (x/rho, y/rho), with (1, 0) on the axis itself."""
    on_axis = rho == 0
    safe = np.where(on_axis, 1.0, rho)
    return np.where(on_axis, 1.0, dx / safe), np.where(on_axis, 0.0, dy / safe)


class Cylinder(SDF):
    """Capped cylinder with axis z (exact)."""

    analytic_gradient = True

    def __init__(self, radius: float, height: float, center: np.ndarray) -> None:
        self.radius = radius
        self.height = height
        self.center = center
        self._c = floats(center)
        extent = np.array([radius, radius, height / 2.0])
        super().__init__(bounds=(tuple(center - extent), tuple(center + extent)), exact=True)

    def _parameters(self) -> dict[str, Any]:
        return {"radius": self.radius, "height": self.height, "center": self.center}

    def _label(self) -> str:
        return "cylinder"

    def _values(self, x, y, z):
        cx, cy, cz = self._c
        _, _, rho = radial(x, y, cx, cy)
        return orthant_distance([rho - self.radius, np.abs(z - cz) - self.height / 2.0])

    @property
    def patch_count(self) -> int:
        return 3  # side, top cap, bottom cap

    def _patch_labels(self, points):
        cx, cy, cz = self._c
        _, _, rho = radial(points[:, 0], points[:, 1], cx, cy)
        dz = points[:, 2] - cz
        cap = np.abs(dz) - self.height / 2.0 > rho - self.radius
        return self._values(*points.T), np.where(cap, np.where(dz > 0, 1, 2), 0)

    def _patch_values(self, labels, points):
        cx, cy, cz = self._c
        _, _, rho = radial(points[:, 0], points[:, 1], cx, cy)
        dz = points[:, 2] - cz
        return np.select([labels == 0, labels == 1], [rho - self.radius, dz - self.height / 2.0], -dz - self.height / 2.0)

    def _values_into(self, target: np.ndarray, x, y, z) -> None:
        cx, cy, cz = self._c
        _, _, rho = radial(x, y, cx, cy)
        orthant_distance([rho - self.radius, np.abs(z - cz) - self.height / 2.0], out=target)

    def _values_and_gradient(self, x, y, z) -> tuple[np.ndarray, Coords]:
        cx, cy, cz = self._c
        dx, dy, rho = radial(x, y, cx, cy)
        ux, uy = radial_direction(dx, dy, rho)
        parts = [rho - self.radius, np.abs(z - cz) - self.height / 2.0]
        return orthant_gradient(parts, [(ux, uy, 0.0), (0.0, 0.0, axis_sign(z - cz))])


def cylinder(
    radius: float = 1.0, height: float = 1.0, center: Any = (0.0, 0.0, 0.0), axis: Any = "z"
) -> SDF:
    """Capped cylinder of ``radius`` and ``height`` centred at ``center``, along ``axis``.

    ``axis`` is ``"x"``, ``"y"``, ``"z"`` (default) or any 3-vector. Exact, including the rims.

    Examples
    --------
    >>> from fepre import sdf
    >>> rod = sdf.cylinder(radius=1.0, height=2.0)
    >>> float(rod([0.0, 0.0, 3.0])), float(rod([4.0, 0.0, 0.0]))
    (2.0, 3.0)
    >>> pin = sdf.cylinder(radius=1.0, height=2.0, axis="x")
    >>> float(pin([3.0, 0.0, 0.0])), float(pin([0.0, 0.0, 4.0]))
    (2.0, 3.0)
    """
    radius, height = positive_float(radius, "radius"), positive_float(height, "height")
    return _placed(lambda c: Cylinder(radius, height, c), center, axis)


class Cone(SDF):
    """Solid right circular cone: base disk at z = cz, apex at z = cz + height (exact).

    In the meridian half-plane (r, h) the cross-section is the triangle (0, 0), (radius, 0),
    (0, height); its edge on the axis is not a surface, so the distance is the smaller of the
    distances to the slanted edge and to the base segment.
    """

    analytic_gradient = True

    def __init__(self, radius: float, height: float, center: np.ndarray) -> None:
        self.radius, self.height, self.center = radius, height, center
        self._c = floats(center)
        slant = float(np.hypot(radius, height))
        self._slant_normal = (height / slant, radius / slant)  # outward, in (r, h)
        lo = center - np.array([radius, radius, 0.0])
        hi = center + np.array([radius, radius, height])
        super().__init__(bounds=(tuple(lo), tuple(hi)), exact=True)

    def _parameters(self) -> dict[str, Any]:
        return {"radius": self.radius, "height": self.height, "center": self.center}

    def _label(self) -> str:
        return "cone"

    def _meridian(self, r, h):
        """Offsets from the nearest points of the slanted edge and the base, and the side of p."""
        radius, height = self.radius, self.height
        wh = h - height
        # Slanted edge from the apex (0, height) to the rim (radius, 0).
        t = (r * radius - wh * height) * (1.0 / (radius * radius + height * height))
        np.clip(t, 0.0, 1.0, out=t)
        slant = (r - radius * t, wh + height * t)
        # Base segment from (0, 0) to (radius, 0).
        base = (np.maximum(r - radius, 0.0), h)
        outside = np.maximum(r * height + h * radius - radius * height, -h) > 0
        return slant, base, outside

    def _values(self, x, y, z):
        cx, cy, cz = self._c
        _, _, r = radial(x, y, cx, cy)
        (sr, sh), (br, bh), outside = self._meridian(r, z - cz)
        distance = np.sqrt(np.minimum(sr * sr + sh * sh, br * br + bh * bh))
        np.negative(distance, out=distance, where=~outside)
        return distance

    @property
    def patch_count(self) -> int:
        return 2  # the slanted side, the base disk

    def _patch_labels(self, points):
        cx, cy, cz = self._c
        _, _, r = radial(points[:, 0], points[:, 1], cx, cy)
        (sr, sh), (br, bh), _ = self._meridian(r, points[:, 2] - cz)
        return self._values(*points.T), (sr * sr + sh * sh > br * br + bh * bh).astype(np.int64)

    def _patch_values(self, labels, points):
        cx, cy, cz = self._c
        _, _, r = radial(points[:, 0], points[:, 1], cx, cy)
        h = points[:, 2] - cz
        nr, nh = self._slant_normal
        side = nr * (r - self.radius) + nh * h  # distance to the slanted line, in the meridian plane
        return np.where(labels == 0, side, -h)

    def singular_points(self) -> np.ndarray:
        cx, cy, cz = self._c
        return np.array([[cx, cy, cz + self.height]])

    def _values_and_gradient(self, x, y, z) -> tuple[np.ndarray, Coords]:
        cx, cy, cz = self._c
        dx, dy, r = radial(x, y, cx, cy)
        ux, uy = radial_direction(dx, dy, r)
        (sr, sh), (br, bh), outside = self._meridian(r, z - cz)
        slant2, base2 = sr * sr + sh * sh, br * br + bh * bh
        use_slant = slant2 <= base2
        vr, vh = np.where(use_slant, sr, br), np.where(use_slant, sh, bh)
        distance = np.sqrt(np.minimum(slant2, base2))
        on_surface = distance == 0
        sign = np.where(outside, 1.0, -1.0)
        scale = sign / np.where(on_surface, 1.0, distance)
        nr, nh = self._slant_normal
        gr = np.where(on_surface, np.where(use_slant, nr, 0.0), vr * scale)
        gh = np.where(on_surface, np.where(use_slant, nh, -1.0), vh * scale)
        # nearest to the inside of the slanted edge or of the base, the gradient is that edge's
        # normal: the offset's direction is round-off for a point within 1e-15 of the surface
        # (a seed projected onto the side got (0.24, -0.97) for (0.98, 0.20), issue 33)
        t = (r * self.radius - (z - cz - self.height) * self.height) / (self.radius**2 + self.height**2)
        flat = np.where(use_slant, (t > 0.0) & (t < 1.0), r < self.radius)
        gr = np.where(flat, np.where(use_slant, nr, 0.0), gr)
        gh = np.where(flat, np.where(use_slant, nh, -1.0), gh)
        values, gr, gh, ux, uy = np.broadcast_arrays(sign * distance, gr, gh, ux, uy)
        dtype = np.result_type(x, y, z, 1.0)
        return values.astype(dtype), ((gr * ux).astype(dtype), (gr * uy).astype(dtype), gh.astype(dtype))


def cone(radius: float = 1.0, height: float = 1.0, center: Any = (0.0, 0.0, 0.0), axis: Any = "z") -> SDF:
    """Solid cone: base disk of ``radius`` centred at ``center``, apex at ``center + height * axis``.

    ``axis`` is ``"x"``, ``"y"``, ``"z"`` (default) or any 3-vector (exact).

    Examples
    --------
    >>> from fepre import sdf
    >>> tip = sdf.cone(radius=1.0, height=2.0)
    >>> float(tip([0.0, 0.0, 3.0])), float(tip([0.0, 0.0, -1.0]))
    (1.0, 1.0)
    >>> float(sdf.cone(radius=1.0, height=2.0, axis=(0, -1, 0))([0.0, -3.0, 0.0]))
    1.0
    """
    radius, height = positive_float(radius, "radius"), positive_float(height, "height")
    return _placed(lambda c: Cone(radius, height, c), center, axis)


class Torus(SDF):
    """Ring torus in the plane z = cz around (cx, cy) (exact)."""

    analytic_gradient = True

    def __init__(self, major_radius: float, minor_radius: float, center: np.ndarray) -> None:
        self.major_radius, self.minor_radius, self.center = major_radius, minor_radius, center
        self._c = floats(center)
        outer = major_radius + minor_radius
        extent = np.array([outer, outer, minor_radius])
        super().__init__(bounds=(tuple(center - extent), tuple(center + extent)), exact=True)

    def _parameters(self) -> dict[str, Any]:
        return {"major_radius": self.major_radius, "minor_radius": self.minor_radius, "center": self.center}

    def _label(self) -> str:
        return "torus"

    def _values(self, x, y, z):
        cx, cy, cz = self._c
        _, _, rho = radial(x, y, cx, cy)
        ring = rho - self.major_radius
        dz = z - cz
        squared = ring * ring + dz * dz  # a fresh array: finish in place
        np.sqrt(squared, out=squared)
        squared -= self.minor_radius
        return squared

    def _values_into(self, target: np.ndarray, x, y, z) -> None:
        cx, cy, cz = self._c
        _, _, rho = radial(x, y, cx, cy)
        ring = rho - self.major_radius
        dz = z - cz
        np.add(ring * ring, dz * dz, out=target)  # same operations as _values, without temporaries
        np.sqrt(target, out=target)
        target -= self.minor_radius

    def _values_and_gradient(self, x, y, z) -> tuple[np.ndarray, Coords]:
        cx, cy, cz = self._c
        dx, dy, rho = radial(x, y, cx, cy)
        ux, uy = radial_direction(dx, dy, rho)
        ring, dz, ux, uy = np.broadcast_arrays(rho - self.major_radius, z - cz, ux, uy)
        length = np.sqrt(ring * ring + dz * dz)
        on_circle = length == 0
        safe = np.where(on_circle, 1.0, length)
        gr = np.where(on_circle, 1.0, ring / safe)
        gz = np.where(on_circle, 0.0, dz / safe)
        return length - self.minor_radius, (gr * ux, gr * uy, gz)


def torus(
    major_radius: float = 1.0, minor_radius: float = 0.25, center: Any = (0.0, 0.0, 0.0), axis: Any = "z"
) -> SDF:
    """Torus: a tube of ``minor_radius`` around a circle of ``major_radius`` about ``axis`` (exact).

    ``minor_radius`` must be smaller than ``major_radius`` (a ring torus). ``axis`` (``"x"``,
    ``"y"``, ``"z"`` by default, or a 3-vector) is normal to the circle's plane.

    Examples
    --------
    >>> from fepre import sdf
    >>> ring = sdf.torus(2.0, 0.5)
    >>> float(ring([2.0, 0.0, 0.0])), float(ring([0.0, 0.0, 0.0]))
    (-0.5, 1.5)
    """
    major = positive_float(major_radius, "major_radius")
    minor = positive_float(minor_radius, "minor_radius")
    if minor >= major:
        raise ValueError(f"minor_radius must be < major_radius ({major:g}) for a ring torus; got {minor:g}")
    return _placed(lambda c: Torus(major, minor, c), center, axis)
