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

from .scratch import give_scratch, take_scratch

__all__ = ["orthant_distance", "orthant_gradient", "axis_sign"]


def orthant_distance(parts: Sequence[np.ndarray], out: np.ndarray | None = None) -> np.ndarray:
    """Exact signed distance of the intersection of orthogonal regions with distances ``parts``.

    ``parts`` are broadcastable arrays; the result is written into ``out`` (an array of the
    broadcast shape) when given. The formula is associative, so parts are folded in pairs in
    their given order: on a grid block a box's x and y parts fold on the (y, x) plane and only
    the fold with the z part runs at full size. A fixed order (not one that depends on the
    parts' sizes) also makes the rounding the same for blocks of every shape, so a grid gives
    the same values whichever way it is cut into blocks (dense or narrow-band sampling).
    """
    result = parts[0]
    last = len(parts) - 1
    for index in range(1, last + 1):
        result = _pair(result, parts[index], out if index == last else None)
    if last == 0 and out is not None:
        out[...] = result
        result = out
    return result


def _pair(a: np.ndarray, b: np.ndarray, out: np.ndarray | None = None) -> np.ndarray:
    """Exact distance of two orthogonal parts (into ``out`` when given); never modifies ``a`` or ``b``.

    An operand small next to the result (the z part of a grid block, or a plane against a full
    block) is tested for one sign over all of it, which is cheap and saves full-size work:
    where a part is <= 0 the formula is ``max(a, b)``, where it is >= 0 the inside term vanishes.
    Both shortcuts give the general formula's value exactly (in IEEE arithmetic
    ``sqrt(a * a) == |a|`` unless ``a * a`` underflows; max and min are exact).
    """
    size = _broadcast_size(np.shape(a), np.shape(b))
    sign_a = _sign(a) if 8 * np.size(a) <= size else 0
    sign_b = _sign(b) if 8 * np.size(b) <= size else 0
    if sign_a < 0 or sign_b < 0:
        return _maximum(a, b, out)
    positive_a = a if sign_a > 0 else np.maximum(a, 0.0)
    positive_b = b if sign_b > 0 else np.maximum(b, 0.0)
    total = np.add(np.square(positive_a), np.square(positive_b), out=out)
    np.sqrt(total, out=total)
    if sign_a > 0 or sign_b > 0:
        return total
    # min(max(a, b), 0) == max(min(a, 0), min(b, 0))
    inside = _maximum(np.minimum(a, 0.0), np.minimum(b, 0.0), take_scratch(total.shape, total.dtype))
    total += inside
    give_scratch(inside)
    return total


def _sign(part: np.ndarray) -> int:
    """-1 if every entry is <= 0, 1 if every entry is >= 0, else 0."""
    if part.max() <= 0:
        return -1
    if part.min() >= 0:
        return 1
    return 0


def _maximum(a: np.ndarray, b: np.ndarray, out: np.ndarray | None) -> np.ndarray:
    """``np.maximum(a, b)`` into ``out`` (allocated when None).

    numpy's maximum has no SIMD loop for an operand that is constant along the inner loop (a
    broadcast z part: 0.32 ns per point): ``out`` is filled with the operand that varies least
    along the last axis, then the maximum with the other runs contiguous (0.13 ns in all).
    """
    shape = np.broadcast_shapes(np.shape(a), np.shape(b)) if out is None else out.shape
    if np.shape(a) == shape or np.shape(b) == shape:
        return np.maximum(a, b, out=out)
    if out is None:
        out = np.empty(shape, dtype=np.result_type(a, b))
    if _row_length(a) > _row_length(b):
        a, b = b, a
    np.copyto(out, a)
    return np.maximum(out, b, out=out)


def _row_length(part: np.ndarray) -> int:
    shape = np.shape(part)
    return shape[-1] if shape else 1


def _broadcast_size(first: tuple[int, ...], second: tuple[int, ...]) -> int:
    """Number of elements of the broadcast of two shapes (no checks: they are compatible)."""
    size = 1
    for i in range(1, max(len(first), len(second)) + 1):
        size *= max(first[-i] if i <= len(first) else 1, second[-i] if i <= len(second) else 1)
    return size


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
