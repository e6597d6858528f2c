"""Deformations: offset, shell, elongate, twist, bend and repetition.

Every node here keeps the 1-Lipschitz property by construction:

* ``offset`` and ``shell`` combine 1-Lipschitz values with constants, ``max`` and negation;
* ``elongate`` composes with the 1-Lipschitz map ``q = p - clamp(p, -h, h)``;
* ``twist`` and ``bend`` warp space by a map ``w`` whose Jacobian norm is at most ``L`` on a
  convex cylinder ``C`` that contains the warped solid, and evaluate
  ``max(f(w(P_C(p))) / L, sdf_C(p))`` where ``P_C`` is the projection onto ``C`` (1-Lipschitz)
  and ``sdf_C`` its exact distance: a maximum of 1-Lipschitz functions, whose negative region
  is exactly the warped solid because that solid lies inside ``C``;
* ``repeat`` evaluates only the copies of the 2^dim cells nearest to the point, each clipped to
  its own cell, plus the distance to the faces of that block of cells beyond which further
  copies lie. The pieces agree where the block changes, so the result is continuous and
  1-Lipschitz, and its negative region is exactly the union of all copies.
"""

from __future__ import annotations

import itertools
from typing import Any

import numpy as np

from ..arguments import as_vector, finite_float, nonnegative_float, positive_float, positive_int, shown
from .booleans import union
from .box_distance import box_distance, box_distance_and_gradient
from .core import SDF, operation

__all__ = ["offset", "shell", "elongate", "twist", "bend", "repeat"]


# ---------------------------------------------------------------------- offset and shell
class Offset(SDF):
    """``f - distance``: grows the solid by ``distance`` (shrinks when negative)."""

    analytic_gradient = True

    def __init__(self, child: SDF, distance: float) -> None:
        self.dim = child.dim
        self.distance = distance
        bounds = child.bounds
        self._guard = None
        if bounds is not None and distance > 0:
            bounds = (tuple(np.asarray(bounds[0]) - distance), tuple(np.asarray(bounds[1]) + distance))
            if not child.exact:
                # A lower-bound child may fall below ``distance`` far from its solid.
                self._guard = bounds
        # f - d is exact outside an offset of an exact f, but inside near concave features the
        # boundary can be farther than |f - d|: never claimed exact.
        super().__init__(bounds=bounds, exact=False, children=(child,))

    def _parameters(self) -> dict[str, Any]:
        return {"distance": self.distance}

    def _values(self, *coords):
        values = self.children[0]._values(*coords) - self.distance
        if self._guard is not None:
            values = np.maximum(values, box_distance(coords, self._guard))
        return values

    @property
    def patch_count(self) -> int:
        return self.children[0].patch_count

    def _patch_labels(self, points):
        return self._values(*points.T), self.children[0]._patch_labels(points)[1]

    def _patch_values(self, labels, points):
        return np.asarray(self.children[0]._patch_values(labels, points)) - self.distance

    def _values_and_gradient(self, *coords):
        values, gradient = self.children[0]._values_and_gradient(*coords)
        values = values - self.distance
        if self._guard is not None:
            guard, guard_gradient = box_distance_and_gradient(coords, self._guard)
            take = guard > values
            values = np.where(take, guard, values)
            gradient = tuple(np.where(take, a, b) for a, b in zip(guard_gradient, gradient))
        return values, gradient


class Shell(SDF):
    """Hollow solid keeping the outer surface: ``max(f, -f - thickness)``."""

    analytic_gradient = True

    def __init__(self, child: SDF, thickness: float) -> None:
        self.dim = child.dim
        self.thickness = thickness
        super().__init__(bounds=child.bounds, exact=False, children=(child,))

    def _parameters(self) -> dict[str, Any]:
        return {"thickness": self.thickness}

    def _values(self, *coords):
        values = self.children[0]._values(*coords)
        return np.maximum(values, -values - self.thickness)

    @property
    def patch_count(self) -> int:
        return 2 * self.children[0].patch_count  # the outer surface's patches, then the inner's

    def _patch_labels(self, points):
        values, labels = self.children[0]._patch_labels(points)
        inner = -np.asarray(values) - self.thickness
        take = inner > values
        return np.where(take, inner, values), np.where(take, labels + self.children[0].patch_count, labels)

    def _patch_values(self, labels, points):
        count = self.children[0].patch_count
        inner = labels >= count
        values = np.asarray(self.children[0]._patch_values(np.where(inner, labels - count, labels), points))
        return np.where(inner, -values - self.thickness, values)

    def _values_and_gradient(self, *coords):
        values, gradient = self.children[0]._values_and_gradient(*coords)
        inner = -values - self.thickness
        take = inner > values
        return np.where(take, inner, values), tuple(np.where(take, -g, g) for g in gradient)


# ---------------------------------------------------------------------- elongate
class Elongate(SDF):
    """Stretch the solid by ``2 h`` per axis at ``center``: ``f(q)``, ``q = p - clamp(p, -h, h)``."""

    analytic_gradient = True

    def __init__(self, child: SDF, half: np.ndarray, center: np.ndarray) -> None:
        self.dim = child.dim
        self.half = half
        self.center = center
        bounds = None
        if child.bounds is not None:
            lo, hi = np.asarray(child.bounds[0]), np.asarray(child.bounds[1])
            # Points with |p - c| <= h map onto q = c; the others move by h away from c.
            bounds = (tuple(np.minimum(lo - half, center - half)), tuple(np.maximum(hi + half, center + half)))
        super().__init__(bounds=bounds, exact=False, children=(child,))

    def _parameters(self) -> dict[str, Any]:
        return {"h": self.half, "center": self.center}

    def _mapped(self, coords):
        mapped = []
        for c, m, h in zip(coords, self.center, self.half):
            m, h = float(m), float(h)
            mapped.append(c - np.clip(c, m - h, m + h) + m if h > 0 else c)
        return mapped

    def _values(self, *coords):
        return self.children[0]._values(*self._mapped(coords))

    def _values_and_gradient(self, *coords):
        values, gradient = self.children[0]._values_and_gradient(*self._mapped(coords))
        scaled = []
        for g, c, m, h in zip(gradient, coords, self.center, self.half):
            scaled.append(g if h == 0 else np.where(np.abs(c - float(m)) > float(h), g, 0.0))
        return values, tuple(scaled)


# ---------------------------------------------------------------------- twist and bend
class _CylinderWarp(SDF):
    """Shared machinery of twist and bend: projection onto a z-aligned capped cylinder C."""

    def __init__(self, child: SDF, rate: float, name: str) -> None:
        if child.dim != 3:
            raise ValueError(f"{name} needs a 3D shape; got a {child.dim}D shape")
        if child.bounds is None:
            raise ValueError(f"{name} needs a bounded shape (bounds is None); intersect it with a box first")
        self.rate = rate
        lo, hi = np.asarray(child.bounds[0]), np.asarray(child.bounds[1])
        size = float(np.max(hi - lo))
        margin = 1e-3 * size
        corners_xy = np.array([[x, y] for x in (lo[0], hi[0]) for y in (lo[1], hi[1])])
        self.radius = float(np.max(np.hypot(corners_xy[:, 0], corners_xy[:, 1]))) + margin
        self.z_range = (float(lo[2]) - margin, float(hi[2]) + margin)
        self.lipschitz = self._warp_lipschitz()
        r = self.radius
        super().__init__(bounds=((-r, -r, self.z_range[0]), (r, r, self.z_range[1])), exact=False, children=(child,))

    def _parameters(self) -> dict[str, Any]:
        return {"rate": self.rate, "lipschitz": round(self.lipschitz, 6)}

    def _project(self, x, y, z):
        r = np.sqrt(x * x + y * y)
        shrink = np.minimum(1.0, self.radius / np.maximum(r, 1e-300))
        return x * shrink, y * shrink, np.clip(z, *self.z_range), r

    def _cylinder_distance(self, r, z):
        z0, z1 = self.z_range
        dr = r - self.radius
        dz = np.abs(z - (z0 + z1) / 2.0) - (z1 - z0) / 2.0
        return np.minimum(np.maximum(dr, dz), 0.0) + np.sqrt(np.maximum(dr, 0.0) ** 2 + np.maximum(dz, 0.0) ** 2)

    def _values(self, x, y, z):
        px, py, pz, r = self._project(x, y, z)
        warped = self.children[0]._values(*self._warp(px, py, pz))
        return np.maximum(warped * (1.0 / self.lipschitz), self._cylinder_distance(r, z))


class Twist(_CylinderWarp):
    """Twist about z by ``rate`` degrees per unit length (Lipschitz-corrected).

    The warp ``w(x, y, z) = (R(-a z)(x, y), z)`` has Jacobian norm
    ``a r / 2 + sqrt(1 + (a r / 2)^2)`` at radius ``r`` (``a`` in radians per unit length).
    """

    def _warp_lipschitz(self) -> float:
        half = abs(np.deg2rad(self.rate)) * self.radius / 2.0
        return float(half + np.sqrt(1.0 + half * half))

    def _warp(self, x, y, z):
        angle = z * float(-np.deg2rad(self.rate))
        c, s = np.cos(angle), np.sin(angle)
        return x * c - y * s, x * s + y * c, z


class Bend(_CylinderWarp):
    """Bend in the xy-plane by ``rate`` degrees per unit length along x (Lipschitz-corrected).

    The cross-section at ``x`` is rotated by ``a x`` about z (Inigo Quilez's bend of a beam along
    x). The warp's Jacobian is ``R(a x) [[1 - a y, 0], [a x, 1]]``, of norm at most ``1 + a r``.
    """

    def _warp_lipschitz(self) -> float:
        return float(1.0 + abs(np.deg2rad(self.rate)) * self.radius)

    def _warp(self, x, y, z):
        angle = x * float(np.deg2rad(self.rate))
        c, s = np.cos(angle), np.sin(angle)
        return x * c - y * s, x * s + y * c, z


# ---------------------------------------------------------------------- repeat
class Repeat(SDF):
    """``count`` copies of a bounded child at ``spacing`` (the first copy stays in place).

    Evaluates the copies of the 2^dim nearest cells (cell = the child's box centre + i*spacing,
    size ``spacing``), each clipped to its cell, and the distance to the faces of that block
    of cells behind which further copies lie. Needs the child's box to fit in one cell.
    """

    def __init__(self, child: SDF, spacing: np.ndarray, count: np.ndarray) -> None:
        self.dim = child.dim
        self.spacing = spacing
        self.count = count
        lo, hi = np.asarray(child.bounds[0]), np.asarray(child.bounds[1])
        self.origin = (lo + hi) / 2.0
        extent = (count - 1) * spacing
        super().__init__(bounds=(tuple(lo), tuple(hi + extent)), exact=False, children=(child,))

    def _parameters(self) -> dict[str, Any]:
        return {"spacing": self.spacing, "count": tuple(int(n) for n in self.count)}

    def _values(self, *coords):
        child = self.children[0]
        firsts, faces = [], []
        for c, o, s, n in zip(coords, self.origin, self.spacing, self.count):
            o, s, n = float(o), float(s), int(n)
            if n == 1:
                firsts.append(None)
                continue
            # The block is cells (first, first + 1): the two centres nearest to c.
            first = np.clip(np.floor((c - o) / s), 0, n - 2)
            firsts.append(first)
            lower = c - (o + (first - 0.5) * s)  # distance to the block's lower face
            upper = (o + (first + 1.5) * s) - c
            face = np.where(first > 0, lower, np.inf)
            face = np.minimum(face, np.where(first < n - 2, upper, np.inf))
            faces.append(face)
        out = None
        half = [float(s) / 2.0 for s in self.spacing]
        for corner in itertools.product((0, 1), repeat=self.dim):
            if any(k == 1 and f is None for k, f in zip(corner, firsts)):
                continue
            local = []
            for c, o, s, f, k in zip(coords, self.origin, self.spacing, firsts, corner):
                shift = float(o) if f is None else (f + k) * float(s) + float(o)
                local.append(c - shift)
            values = child._values(*(q + float(o) for q, o in zip(local, self.origin)))
            values = np.maximum(values, _box_from_offsets(local, half))
            out = values if out is None else np.minimum(out, values)
        for face in faces:
            out = np.minimum(out, face)
        return out


def _box_from_offsets(local, half):
    d = [np.abs(q) - h for q, h in zip(local, half)]
    outside = np.sqrt(sum(np.maximum(di, 0.0) ** 2 for di in d))
    inside = d[0]
    for di in d[1:]:
        inside = np.maximum(inside, di)
    return outside + np.minimum(inside, 0.0)


# ---------------------------------------------------------------------- public functions
def _check_shape(shape: Any, name: str) -> SDF:
    if not isinstance(shape, SDF):
        raise TypeError(f"{name} must be an SDF; got {type(shape).__name__}")
    return shape


@operation
def offset(shape: SDF, distance: float) -> SDF:
    """Grow ``shape`` by ``distance`` (shrink when negative).

    Examples
    --------
    >>> from fepre import sdf
    >>> float(sdf.sphere(1).offset(0.5)([2.0, 0.0, 0.0]))
    0.5
    """
    shape = _check_shape(shape, "shape")
    return Offset(shape, finite_float(distance, "distance"))


@operation
def shell(shape: SDF, thickness: float) -> SDF:
    """Hollow ``shape`` inwards, keeping its outer surface and a wall of ``thickness``.

    Examples
    --------
    >>> from fepre import sdf
    >>> float(sdf.sphere(1).shell(0.25)([0.0, 0.0, 0.0]))
    0.75
    """
    shape = _check_shape(shape, "shape")
    return Shell(shape, positive_float(thickness, "thickness"))


@operation
def elongate(shape: SDF, h: Any, center: Any = None) -> SDF:
    """Stretch ``shape`` by ``2 h`` per axis, cutting it at ``center`` (default the origin).

    Uses ``q = p - clamp(p, c - h, c + h) + c``: the half of the shape on each side of ``center``
    moves out by ``h``; the gap is filled with the cross-section at ``center``.

    Examples
    --------
    >>> from fepre import sdf
    >>> float(sdf.sphere(1).elongate((2, 0, 0))([3.0, 0.0, 0.0]))
    0.0
    """
    shape = _check_shape(shape, "shape")
    half = as_vector(h, shape.dim, "h", allow_scalar=True)
    if np.any(half < 0):
        raise ValueError(f"h must be >= 0 on every axis; got {shown(h)}")
    center = as_vector(np.zeros(shape.dim) if center is None else center, shape.dim, "center")
    return Elongate(shape, half, center)


@operation
def twist(shape: SDF, rate: float) -> SDF:
    """Twist a bounded 3D ``shape`` about z by ``rate`` degrees per unit length.

    Examples
    --------
    >>> from fepre import sdf
    >>> bar = sdf.sphere(1).scale((2, 0.5, 0.5)).twist(45)
    >>> bar.exact
    False
    """
    shape = _check_shape(shape, "shape")
    return Twist(shape, finite_float(rate, "rate"), "twist")


@operation
def bend(shape: SDF, rate: float) -> SDF:
    """Bend a bounded 3D ``shape`` in the xy-plane by ``rate`` degrees per unit length along x.

    Examples
    --------
    >>> from fepre import sdf
    >>> sdf.sphere(1).scale((3, 0.5, 0.5)).bend(10).bounds is not None
    True
    """
    shape = _check_shape(shape, "shape")
    return Bend(shape, finite_float(rate, "rate"), "bend")


def repeat(shape: SDF, spacing: Any, count: Any) -> SDF:
    """``count`` copies of ``shape`` spaced by ``spacing`` per axis, starting at the shape itself.

    When the shape's box fits in one ``spacing`` cell, only the 2^dim nearest copies are
    evaluated; otherwise the result is the plain union of all translated copies.

    Examples
    --------
    >>> from fepre import sdf
    >>> row = sdf.repeat(sdf.sphere(0.4), spacing=1, count=(3, 1, 1))
    >>> float(row([2.0, 0.0, 0.0]))
    -0.4
    """
    shape = _check_shape(shape, "shape")
    if shape.bounds is None:
        raise ValueError("repeat needs a bounded shape (bounds is None)")
    dim = shape.dim
    spacing = as_vector(spacing, dim, "spacing", allow_scalar=True)
    if np.any(spacing <= 0):
        raise ValueError(f"spacing must be > 0 on every axis; got {spacing.tolist()}")
    counts = np.atleast_1d(np.asarray(count))
    if counts.ndim == 1 and counts.size == 1:
        counts = np.full(dim, counts[0])
    if counts.shape != (dim,):
        raise ValueError(f"count must be a positive integer or {dim} of them; got {shown(count)}")
    counts = np.array([positive_int(n if not isinstance(n, np.generic) else n.item(), "count") for n in counts])
    lo, hi = np.asarray(shape.bounds[0]), np.asarray(shape.bounds[1])
    if np.prod(counts) <= 2**dim or np.any((hi - lo) > spacing):
        copies = [
            shape.translate(np.array(index) * spacing) for index in itertools.product(*(range(n) for n in counts))
        ]
        return union(*copies)
    return Repeat(shape, spacing, counts)
