"""Solids that touch: the zero set of a sharp boolean must not hold faces shared by its operands.

Two solids standing on each other (a hub on a disk, the two halves of a T-section) share a face.
Their sharp union ``min(a, b)`` is exactly 0 there, on points that are inside the union: a grid
whose nodes fall on that face (round dimensions, round spacing) sees an internal double wall, a
second component and a wrong genus. Likewise ``max(a, -b)`` is 0 over the opening of a pocket
whose tool ends flush with the body's face, on points that are outside.

Grid sampling (:meth:`fepre.sdf.SDF.values_on_axes` and the narrow band) looks, block by block,
for nodes within ``TOUCH_TOLERANCE`` of zero (wider on float32 grids, whose rounding puts a 0
either side by about ``eps |x|``; one pass, and most blocks have none). Those few nodes are
evaluated again in float64 with every sharp boolean of the model settling its own value: where
two of its operands are within the tolerance of zero with opposite normals (within 60 degrees),
the point lies on a shared face rather than on the boundary, and the value becomes
``-tolerance`` for a union (inside) or ``+tolerance`` for an intersection or difference
(outside). Only the nodes whose value this changes are written back; the zero set moves by at
most that tolerance anywhere. Point evaluations (``model(points)``) are left as they are: DistMesh
meshes touching solids correctly without it (flange: no boundary face on the shared disk face).
"""

from __future__ import annotations

import threading
from contextlib import contextmanager
from typing import TYPE_CHECKING, Iterator, Sequence

import numpy as np

from .scratch import give_scratch, take_scratch

if TYPE_CHECKING:  # core samples grids with settle_grid_block: this module lies below it
    from .core import SDF, Coords

__all__ = ["settle_shared_faces", "settle_grid_block", "settling", "TOUCH_TOLERANCE", "OPPOSITE_COSINE"]

#: Values this close to zero (times the model's length scale) count as on the zero set.
TOUCH_TOLERANCE = 1e-9
#: Normals whose cosine is below this are opposite: the two solids lie on either side.
OPPOSITE_COSINE = -0.5

_state = threading.local()


def active() -> bool:
    """True while the nodes near zero of a grid are evaluated again (see :func:`settling`)."""
    return getattr(_state, "settling", False)


@contextmanager
def settling() -> Iterator[None]:
    """Within this block, sharp booleans settle their values on shared faces."""
    before = active()
    _state.settling = True
    try:
        yield
    finally:
        _state.settling = before


def has_sharp_boolean(model: SDF) -> bool:
    """True when a sharp union, intersection or difference is in the model's tree (cached)."""
    cached = getattr(model, "_sharp_boolean", None)
    if cached is None:
        own = getattr(model, "settles_shared_faces", False) and getattr(model, "k", 1.0) == 0
        cached = own or any(has_sharp_boolean(child) for child in model.children)
        model._sharp_boolean = cached
    return cached


def settle_grid_block(model: SDF, values: np.ndarray, coords: Coords) -> None:
    """Re-evaluate, with shared faces settled, the nodes of a sampled block that are on zero."""
    if not has_sharp_boolean(model):
        return
    scale = model.length_scale
    tolerance = TOUCH_TOLERANCE * scale
    if values.dtype != np.float64:
        # float32 blocks round a shared face's 0 to about eps * |x|, either side: look wider and
        # evaluate those nodes again in float64
        reach = max(float(np.abs(c).max()) for c in coords) + scale
        tolerance = max(tolerance, 16.0 * float(np.finfo(values.dtype).eps) * reach)
    if float(values.min()) > tolerance or float(values.max()) < -tolerance:
        return  # the common case: the block is on one side
    magnitude = take_scratch(values.shape, values.dtype)
    np.abs(values, out=magnitude)
    if float(magnitude.min()) > tolerance:
        give_scratch(magnitude)
        return
    where = np.nonzero(magnitude <= tolerance)
    give_scratch(magnitude)
    points = [np.broadcast_to(c, values.shape)[where].astype(np.float64) for c in coords]
    plain = np.broadcast_to(model._values(*points), points[0].shape)
    with settling():
        settled = np.broadcast_to(model._values(*points), points[0].shape)
    moved = settled != plain  # only shared faces change: every other node keeps its value
    if moved.any():
        values[tuple(w[moved] for w in where)] = settled[moved]


#: Probe distance (times the model's size) on either side of a candidate shared face.
PROBE = 1e-6


def _both_sides(points, shared, operands, signs, normals, on_zero, inside, scale) -> np.ndarray:
    """For the candidate points (``shared``): is the boolean's value clearly on the same side of
    zero a probe step away along the face normal, in both directions?"""
    index = np.flatnonzero(shared)
    rows = sorted(normals)
    # the normal of the first operand on zero at each point
    normal = np.zeros((index.size, len(points)))
    found = np.zeros(index.size, dtype=bool)
    candidates = np.flatnonzero(on_zero.sum(axis=0) >= 2)
    position = np.searchsorted(candidates, index)
    for row in rows:
        take = ~found & on_zero[row, index]
        normal[take] = normals[row][position[take]]
        found |= take
    step = PROBE * scale
    result = np.ones(index.size, dtype=bool)
    for direction in (1.0, -1.0):
        probe = [p[index] + direction * step * normal[:, axis] for axis, p in enumerate(points)]
        values = np.array([sign * np.broadcast_to(o._values(*probe), (index.size,)) for o, sign in zip(operands, signs)])
        combined = values.min(axis=0) if inside else values.max(axis=0)
        result &= (combined < -0.5 * step) if inside else (combined > 0.5 * step)
    keep = np.zeros(shared.size, dtype=bool)
    keep[index[result]] = True
    return keep


def settle_shared_faces(
    out: np.ndarray, coords: Coords, operands: Sequence[SDF], signs: Sequence[float], inside: bool, scale: float
) -> None:
    """Move ``out`` (a boolean's values on ``coords``) off zero on faces shared by its operands.

    ``signs[i]`` is +1 for an operand taken as it is and -1 for one taken negated (the tools of a
    difference; only the relative signs matter, so a boolean's own ``_signs`` serve). ``inside``
    is True for a union (shared faces are inside) and False for an intersection or a difference.
    Only called while :func:`settling`: on the few grid nodes found on zero.
    """
    tolerance = TOUCH_TOLERANCE * scale
    near = np.abs(out) <= tolerance
    if not near.any():
        return
    where = np.nonzero(near)
    points = [np.broadcast_to(c, out.shape)[where].astype(np.float64) for c in coords]
    count = points[0].shape[0]
    values = np.empty((len(operands), count))
    for row, operand in enumerate(operands):
        with settling():
            values[row] = np.broadcast_to(operand._values(*points), (count,))  # settled inside too
    on_zero = np.abs(values) <= tolerance  # (operands, K)
    candidates = np.flatnonzero(on_zero.sum(axis=0) >= 2)  # a shared face needs two operands on zero
    if candidates.size == 0:
        return
    sub = [p[candidates] for p in points]
    normals = {}
    for row, (operand, sign) in enumerate(zip(operands, signs)):
        if on_zero[row, candidates].any():
            _, gradient = operand._values_and_gradient(*sub)
            normal = sign * np.stack([np.broadcast_to(g, (candidates.size,)) for g in gradient], axis=1)
            normals[row] = normal / np.maximum(np.linalg.norm(normal, axis=1), 1e-300)[:, None]
    shared_sub = np.zeros(candidates.size, dtype=bool)
    rows = sorted(normals)
    for i_index, i in enumerate(rows):
        for j in rows[i_index + 1 :]:
            cosine = np.einsum("kd,kd->k", normals[i], normals[j])
            shared_sub |= on_zero[i, candidates] & on_zero[j, candidates] & (cosine < OPPOSITE_COSINE)
    shared = np.zeros(count, dtype=bool)
    shared[candidates[shared_sub]] = True
    if shared.any():
        # a shared face has the boolean's solid (union) or its outside (difference) on both sides;
        # where it meets the real boundary (a shaft's axis at its end face) one side is on zero
        shared &= _both_sides(points, shared, operands, signs, normals, on_zero, inside, scale)
    if shared.any():
        index = tuple(w[shared] for w in where)
        out[index] = -tolerance if inside else tolerance
