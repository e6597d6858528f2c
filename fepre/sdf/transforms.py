"""Affine transforms: translate, rotate, scale, mirror and general matrices, collapsed into one node.

A transformed shape evaluates ``sigma * f(A^-1 p)`` where ``A`` is the forward affine map and
``sigma`` the smallest singular value of its linear part: ``|grad| <= sigma * ||A^-1|| = 1``, so
the value stays a 1-Lipschitz lower bound (exact for rigid motions and uniform scaling of an exact
child). Transforming a transformed shape multiplies the matrices: a chain of any length is one
:class:`Affine` node.

On grids the inverse map is applied term by term, skipping zero matrix entries, so translations,
axis-aligned scalings and axis permutations keep x, y and z on their own small axis arrays.
"""

from __future__ import annotations

import itertools
from typing import Any

import numpy as np

from ..arguments import _numeric_array, as_vector, finite_float, shown
from ..kernel_threads import one_blas_thread
from .core import SDF, Coords, operation

__all__ = ["Affine", "translate", "rotate", "scale", "mirror", "transform"]


def _corners(bounds, dim: int) -> np.ndarray:
    lo, hi = bounds
    return np.array([[(lo, hi)[c][axis] for axis, c in enumerate(choice)] for choice in itertools.product((0, 1), repeat=dim)])


class Affine(SDF):
    """A child seen through the affine map ``matrix`` ((dim+1) x (dim+1), forward direction)."""

    analytic_gradient = True

    def __init__(self, child: SDF, matrix: np.ndarray, steps: tuple[str, ...]) -> None:
        dim = child.dim
        self.dim = dim
        self.matrix = matrix
        self.steps = steps
        linear = matrix[:dim, :dim]
        singular = np.linalg.svd(linear, compute_uv=False)
        self.factor = float(singular.min())
        inverse = np.linalg.inv(matrix)
        self.inverse = inverse
        inv_linear = inverse[:dim, :dim].copy()
        inv_linear[np.abs(inv_linear) < 1e-15 * np.abs(inv_linear).max()] = 0.0
        self._linear = inv_linear
        # Per output axis: the (input axis, coefficient) terms and the offset, as Python floats
        # so that float32 grids stay float32.
        self._rows = [
            ([(j, float(inv_linear[i, j])) for j in range(dim) if inv_linear[i, j] != 0.0], float(inverse[i, dim]))
            for i in range(dim)
        ]
        exact = child.exact and bool(singular.max() - singular.min() <= 1e-12 * singular.max())
        bounds = None
        if child.bounds is not None:
            corners = _corners(child.bounds, dim) @ linear.T + matrix[:dim, dim]
            bounds = (tuple(corners.min(axis=0)), tuple(corners.max(axis=0)))
        super().__init__(bounds=bounds, exact=exact, children=(child,))

    def describe(self) -> str:
        """``transform[step → step ...]``, with the value's factor when it is not 1."""
        text = "transform[" + " → ".join(self.steps) + "]"
        if abs(self.factor - 1.0) > 1e-12:
            text += f"(lipschitz_factor={self.factor:.6g})"
        return text

    def _pulled_back(self, coords: Coords) -> list:
        pulled = []
        for terms, offset in self._rows:
            acc = None
            for j, coefficient in terms:
                term = coords[j] if coefficient == 1.0 else coords[j] * coefficient
                acc = term if acc is None else acc + term
            if offset != 0.0:
                acc = acc + offset
            pulled.append(acc)
        return pulled

    def _values(self, *coords):
        values = self.children[0]._values(*self._pulled_back(coords))
        if self.factor != 1.0:
            values = values * self.factor
        return values

    def _pulled_back_points(self, points: np.ndarray) -> np.ndarray:
        with one_blas_thread():  # memory-bound: BLAS's threads only spin on busy cores
            return points @ self.inverse[: self.dim, : self.dim].T + self.inverse[: self.dim, self.dim]

    @property
    def patch_count(self) -> int:
        return self.children[0].patch_count

    def _patch_labels(self, points):
        values, labels = self.children[0]._patch_labels(self._pulled_back_points(points))
        return np.asarray(values) * self.factor, labels

    def _patch_values(self, labels, points):
        return np.asarray(self.children[0]._patch_values(labels, self._pulled_back_points(points))) * self.factor

    @property
    def facet_curvature(self):
        """A faceted child's :meth:`~fepre.sdf.MeshModel.facet_curvature` seen through the map,
        when the map is a similarity (curvatures divide by its scale); else no such attribute.
        The size field asks for it on the translation that meshes a part far from the origin in
        a local frame: without it a triangle-mesh model at 1e4 lost its curvature sizes (a
        bracket's fillet got 4.08 instead of 2.5)."""
        child = self.children[0]
        singular = np.linalg.svd(self.matrix[: self.dim, : self.dim], compute_uv=False)
        if not hasattr(child, "facet_curvature") or singular.max() - singular.min() > 1e-12 * singular.max():
            raise AttributeError("facet_curvature")
        scale = float(singular.max())

        def curvature(points, length):
            pulled = self._pulled_back_points(np.asarray(points, dtype=np.float64).reshape(-1, self.dim))
            return np.asarray(child.facet_curvature(pulled, length / scale)) / scale

        return curvature

    def singular_points(self) -> np.ndarray:
        points = self.children[0].singular_points()
        return points @ self.matrix[: self.dim, : self.dim].T + self.matrix[: self.dim, self.dim]

    def _values_into(self, target: np.ndarray, *coords) -> None:
        self.children[0]._values_into(target, *self._pulled_back(coords))
        if self.factor != 1.0:
            target *= self.factor

    def _values_and_gradient(self, *coords):
        values, gradient = self.children[0]._values_and_gradient(*self._pulled_back(coords))
        out = []
        for i in range(self.dim):
            acc = 0.0
            for j in range(self.dim):
                coefficient = self._linear[j, i] * self.factor
                if coefficient != 0.0:
                    acc = acc + gradient[j] * coefficient
            out.append(acc)
        return values * self.factor, tuple(out)


def _apply(shape: SDF, matrix: np.ndarray, step: str) -> SDF:
    if not isinstance(shape, SDF):
        raise TypeError(f"shape must be an SDF; got {type(shape).__name__}")
    if isinstance(shape, Affine):
        combined = matrix @ shape.matrix
        steps = shape.steps + (step,)
        child = shape.children[0]
    else:
        combined, steps, child = matrix, (step,), shape
    if np.allclose(combined, np.eye(shape.dim + 1), rtol=0, atol=1e-15):
        return child
    return Affine(child, combined, steps)


def _fmt(vector: np.ndarray) -> str:
    return "(" + ", ".join(f"{v:g}" for v in vector) + ")"


def _homogeneous(linear: np.ndarray, translation: np.ndarray) -> np.ndarray:
    dim = linear.shape[0]
    matrix = np.eye(dim + 1)
    matrix[:dim, :dim] = linear
    matrix[:dim, dim] = translation
    return matrix


@operation
def translate(shape: SDF, offset: Any) -> SDF:
    """Move ``shape`` by ``offset`` (exactness preserved).

    Examples
    --------
    >>> from fepre import sdf
    >>> float(sdf.sphere(1).translate((2, 0, 0))([2.0, 0.0, 0.0]))
    -1.0
    """
    offset = as_vector(offset, shape.dim, "offset")
    return _apply(shape, _homogeneous(np.eye(shape.dim), offset), f"translate{_fmt(offset)}")


def rotation_matrix(angle: float, axis: np.ndarray | None, dim: int) -> np.ndarray:
    """Rotation by ``angle`` degrees (about unit ``axis`` in 3D, counter-clockwise in 2D)."""
    theta = np.deg2rad(angle)
    c, s = np.cos(theta), np.sin(theta)
    if dim == 2:
        return np.array([[c, -s], [s, c]])
    u = axis / np.linalg.norm(axis)
    cross = np.array([[0, -u[2], u[1]], [u[2], 0, -u[0]], [-u[1], u[0], 0]])
    return c * np.eye(3) + s * cross + (1 - c) * np.outer(u, u)


@operation
def rotate(shape: SDF, angle: float, axis: Any = None, center: Any = None) -> SDF:
    """Rotate ``shape`` by ``angle`` degrees about ``axis`` (default z) through ``center``.

    For a 2D shape there is no axis: ``rotate(angle, center)``.

    Examples
    --------
    >>> from fepre import sdf
    >>> rod = sdf.sphere(1, center=(2, 0, 0)).rotate(90)
    >>> round(float(rod([0.0, 2.0, 0.0])), 12)
    -1.0
    """
    angle = finite_float(angle, "angle")
    dim = shape.dim
    if dim == 2:
        if axis is not None and center is not None:
            raise ValueError("axis is not accepted for a 2D shape: rotate(angle, center)")
        center = as_vector(center if center is not None else (axis if axis is not None else (0.0, 0.0)), 2, "center")
        axis_vector = None
        label = f"rotate({angle:g}, center={_fmt(center)})"
    else:
        axis_vector = as_vector((0.0, 0.0, 1.0) if axis is None else axis, 3, "axis")
        if np.linalg.norm(axis_vector) == 0:
            raise ValueError(f"axis must be a non-zero vector; got {axis!r}")
        center = as_vector((0.0, 0.0, 0.0) if center is None else center, 3, "center")
        label = f"rotate({angle:g}, axis={_fmt(axis_vector)}, center={_fmt(center)})"
    rotation = rotation_matrix(angle, axis_vector, dim)
    return _apply(shape, _homogeneous(rotation, center - rotation @ center), label)


@operation
def scale(shape: SDF, factor: Any) -> SDF:
    """Scale ``shape`` about the origin by a number or one positive factor per axis.

    Non-uniform scaling gives a lower bound: the value is multiplied by the smallest factor.

    Examples
    --------
    >>> from fepre import sdf
    >>> float(sdf.sphere(1).scale(2)([3.0, 0.0, 0.0]))
    1.0
    """
    factors = as_vector(factor, shape.dim, "factor", allow_scalar=True)
    if np.any(factors <= 0):
        raise ValueError(f"factor must be > 0 on every axis (use mirror to reflect); got {shown(factor)}")
    return _apply(shape, _homogeneous(np.diag(factors), np.zeros(shape.dim)), f"scale{_fmt(factors)}")


@operation
def mirror(shape: SDF, normal: Any, point: Any = None) -> SDF:
    """Reflect ``shape`` across the plane (line in 2D) through ``point`` with ``normal``.

    Examples
    --------
    >>> from fepre import sdf
    >>> float(sdf.sphere(1, center=(2, 0, 0)).mirror((1, 0, 0))([-2.0, 0.0, 0.0]))
    -1.0
    """
    dim = shape.dim
    normal = as_vector(normal, dim, "normal")
    length = np.linalg.norm(normal)
    if length == 0:
        raise ValueError(f"normal must be a non-zero vector; got {normal.tolist()}")
    n = normal / length
    point = as_vector(np.zeros(dim) if point is None else point, dim, "point")
    reflection = np.eye(dim) - 2.0 * np.outer(n, n)
    return _apply(shape, _homogeneous(reflection, point - reflection @ point), f"mirror(normal={_fmt(normal)}, point={_fmt(point)})")


@operation
def transform(shape: SDF, matrix: Any) -> SDF:
    """Apply a general affine ``matrix``: (dim+1) x (dim+1) homogeneous or dim x dim linear.

    The value is multiplied by the smallest singular value of the linear part, which keeps it a
    1-Lipschitz lower bound. Singular and projective matrices are refused.

    Examples
    --------
    >>> from fepre import sdf
    >>> shear = [[1, 0.5, 0, 0], [0, 1, 0, 0], [0, 0, 1, 0], [0, 0, 0, 1]]
    >>> sdf.sphere(1).transform(shear).exact
    False
    """
    dim = shape.dim
    array = _numeric_array(matrix, "matrix").astype(np.float64)
    if array.shape == (dim, dim):
        array = _homogeneous(array, np.zeros(dim))
    if array.shape != (dim + 1, dim + 1):
        raise ValueError(
            f"matrix must be a {dim + 1}x{dim + 1} homogeneous or {dim}x{dim} linear array for a {dim}D shape; "
            f"got shape {array.shape}"
        )
    if not np.isfinite(array).all():
        raise ValueError("matrix must be finite; got NaN or infinite entries")
    if not np.allclose(array[dim], np.eye(dim + 1)[dim], rtol=0, atol=1e-12):
        raise ValueError(f"matrix must be affine: its last row must be (0, ..., 0, 1); got {array[dim].tolist()}")
    singular = np.linalg.svd(array[:dim, :dim], compute_uv=False)
    if singular.min() <= 1e-12 * max(singular.max(), 1e-300):
        raise ValueError(f"matrix must be invertible; its linear part is singular (singular values {singular.tolist()})")
    with np.printoptions(precision=4, suppress=True):
        label = "matrix" + np.array2string(array[:dim], separator=",").replace("\n", "")
    return _apply(shape, array, label)
