"""Exact distance to an intersection of mutually orthogonal slabs, from each slab's distance.

A box is the intersection of three orthogonal slabs ``|x_i - c_i| <= h_i``; a capped cylinder
is the intersection of an infinite cylinder and a slab in z; an extrusion is the intersection of
a 2D prism and a slab. When the parts' signed distances ``q_i`` measure along mutually
orthogonal directions, the exact signed distance of the intersection is::

    sqrt(sum(max(q_i, 0)**2)) + min(max(q_i), 0)

This module evaluates that formula (cheaply on broadcast axis arrays) and its gradient.
"""

from __future__ import annotations

from typing import Sequence

import numpy as np

__all__ = ["orthant_distance", "orthant_gradient", "axis_sign"]


def orthant_distance(parts: Sequence[np.ndarray]) -> np.ndarray:
    """Exact signed distance of the intersection of orthogonal regions with distances ``parts``.

    ``parts`` are broadcastable arrays. Work on each part stays at that part's shape; only the
    final sums run at the full broadcast shape, in place.
    """
    # The formula is associative, so parts are folded in pairs, smallest first: the final
    # operations are the only ones at full size.
    order = sorted(range(len(parts)), key=lambda i: np.size(parts[i]))
    result = parts[order[0]]
    for i in order[1:]:
        result = _pair(result, parts[i])
    return result


def _pair(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Exact distance of two orthogonal parts; never modifies ``a`` or ``b``."""
    if np.size(a) < np.size(b):
        a, b = b, a
    if 8 * np.size(b) <= _broadcast_size(np.shape(a), np.shape(b)):
        # b is small next to the result (e.g. the z part of a grid block, or the y part against
        # the x part): one sign for all of it is cheap to test and saves most full-size work.
        if np.all(b <= 0):
            return np.maximum(a, b)
        if np.all(b >= 0):
            total = np.square(np.maximum(a, 0.0))
            total = _combine(np.add, total, np.square(b))
            return np.sqrt(total, out=total)
    # min(max(a, b), 0) == max(min(a, 0), min(b, 0)); both full-size results have the same
    # shape and dtype, so the final sum runs in place.
    total = np.add(np.square(np.maximum(a, 0.0)), np.square(np.maximum(b, 0.0)))
    np.sqrt(total, out=total)
    total += np.maximum(np.minimum(a, 0.0), np.minimum(b, 0.0))
    return total


def _broadcast_size(first: tuple[int, ...], second: tuple[int, ...]) -> int:
    """Number of elements of the broadcast of two shapes (no checks: they are compatible)."""
    size = 1
    for i in range(1, max(len(first), len(second)) + 1):
        size *= max(first[-i] if i <= len(first) else 1, second[-i] if i <= len(second) else 1)
    return size


def _combine(ufunc: np.ufunc, fresh: np.ndarray, other: np.ndarray) -> np.ndarray:
    """``ufunc(fresh, other)``, in place when ``fresh`` (a temporary) already has the result shape.

    The shape test is done by hand: ``np.broadcast_shapes`` costs as much as a small ufunc call.
    """
    shape, other_shape = fresh.shape, np.shape(other)
    fits = len(other_shape) <= len(shape) and all(
        o == 1 or o == f for o, f in zip(reversed(other_shape), reversed(shape))
    )
    if fits and fresh.dtype == getattr(other, "dtype", fresh.dtype):
        return ufunc(fresh, other, out=fresh)
    return ufunc(fresh, other)


def orthant_gradient(
    parts: Sequence[np.ndarray], gradients: Sequence[Sequence[np.ndarray | float]]
) -> tuple[np.ndarray, tuple[np.ndarray, ...]]:
    """Value and gradient of :func:`orthant_distance` by the chain rule.

    ``gradients[i]`` holds the components of the gradient of ``parts[i]`` (arrays or floats,
    broadcastable). Outside, the gradient is the normalised sum ``sum(max(q_i, 0) * grad q_i)``;
    inside, it is the gradient of the part nearest to its boundary (the largest ``q_i``).
    """
    full = np.broadcast_arrays(*parts)
    dtype = np.result_type(*full)
    positive = [np.maximum(part, 0.0) for part in full]
    norm = np.sqrt(sum(p * p for p in positive))
    outside = norm > 0
    safe = np.where(outside, norm, 1.0)
    nearest = np.argmax(np.stack(full), axis=0)
    values = norm + np.minimum(np.max(np.stack(full), axis=0), 0.0)
    weights = [np.where(outside, p / safe, (nearest == i).astype(dtype)) for i, p in enumerate(positive)]
    dim = len(gradients[0])
    components = []
    for axis in range(dim):
        component = np.zeros(full[0].shape, dtype=dtype)
        for weight, gradient in zip(weights, gradients):
            g = gradient[axis]
            if isinstance(g, float) and g == 0.0:
                continue
            component += weight * g
        components.append(component)
    return values.astype(dtype, copy=False), tuple(components)


def axis_sign(d):
    """sign(d) with +1 at 0: the gradient of ``|d|``, never zero."""
    return np.where(d >= 0, 1.0, -1.0).astype(np.result_type(d, 1.0), copy=False)
