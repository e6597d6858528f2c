"""Exact signed distance to a simple polygon (2D), and the check that a polygon is simple.

The distance is the smallest distance to an edge; the sign comes from the parity of edge
crossings of a ray in +x (the even-odd rule, which equals inside/outside for a simple polygon of
either orientation). Points and edges are evaluated together in (points x edges) blocks.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from ..arguments import _numeric_array
from .core import SDF, Coords

__all__ = ["polygon", "Polygon"]

_BLOCK_ELEMENTS = 1 << 16  # points x edges per block: a few hundred kB per temporary


class Polygon(SDF):
    """Simple polygon with vertices ``vertices`` (either orientation; exact)."""

    dim = 2
    analytic_gradient = True

    def __init__(self, vertices: np.ndarray) -> None:
        self.vertices = vertices
        self._start = vertices
        self._end = np.roll(vertices, -1, axis=0)
        self._edge = self._end - vertices
        self._inverse_length2 = 1.0 / np.einsum("ij,ij->i", self._edge, self._edge)
        self.area = 0.5 * float(np.sum(vertices[:, 0] * self._edge[:, 1] - vertices[:, 1] * self._edge[:, 0]))
        # Outward unit normals (for the gradient on the boundary itself).
        outward = np.column_stack([self._edge[:, 1], -self._edge[:, 0]]) * np.sign(self.area)
        self._outward = outward / np.linalg.norm(outward, axis=1)[:, None]
        self._scale = float(np.max(np.abs(vertices))) or 1.0
        super().__init__(bounds=(tuple(vertices.min(axis=0)), tuple(vertices.max(axis=0))), exact=True)

    def _parameters(self) -> dict[str, Any]:
        return {"vertices": len(self.vertices), "area": abs(self.area)}

    def _label(self) -> str:
        return "polygon"

    def _nearest(self, px: np.ndarray, py: np.ndarray, offsets: bool = False):
        """Signed distance per point and, if ``offsets``, the offset from the nearest boundary
        point and the index of the nearest edge.

        Blocks are (edges x points) arrays; the longer of the two runs along the last axis, so
        numpy's inner loops stay long whether there are few edges or many.
        """
        count, edges = px.size, len(self._start)
        dtype = px.dtype
        distance = np.empty(count, dtype=dtype)
        offset = np.empty((count, 2), dtype=dtype) if offsets else None
        nearest = np.empty(count, dtype=np.intp) if offsets else None
        edges_first = edges <= 256
        axis = 0 if edges_first else 1

        def along_edges(values: np.ndarray) -> np.ndarray:
            values = values.astype(dtype)
            return values[:, None] if edges_first else values[None, :]

        sx, sy, ty = (along_edges(v) for v in (self._start[:, 0], self._start[:, 1], self._end[:, 1]))
        ex, ey = along_edges(self._edge[:, 0]), along_edges(self._edge[:, 1])
        ex_scaled = along_edges(self._edge[:, 0] * self._inverse_length2)
        ey_scaled = along_edges(self._edge[:, 1] * self._inverse_length2)
        ey_sign = along_edges(np.sign(self._edge[:, 1]))
        step = max(1024 if edges_first else 1, _BLOCK_ELEMENTS // edges)
        for lo in range(0, count, step):
            hi = min(lo + step, count)
            qx = px[None, lo:hi] if edges_first else px[lo:hi, None]
            qy = py[None, lo:hi] if edges_first else py[lo:hi, None]
            wx, wy = qx - sx, qy - sy
            # Offset (bx, by) from the nearest point of each edge, in place to limit temporaries.
            t = wx * ex_scaled
            t += wy * ey_scaled
            np.clip(t, 0.0, 1.0, out=t)
            bx = ex * t
            np.subtract(wx, bx, out=bx)
            by = np.multiply(ey, t, out=t)
            np.subtract(wy, by, out=by)
            if offsets:
                squared = bx * bx + by * by
                index = np.argmin(squared, axis=axis)
                pick = index[None, :] if edges_first else index[:, None]
                d = np.sqrt(np.take_along_axis(squared, pick, axis).ravel())
                offset[lo:hi, 0] = np.take_along_axis(bx, pick, axis).ravel()
                offset[lo:hi, 1] = np.take_along_axis(by, pick, axis).ravel()
                nearest[lo:hi] = index
            else:
                np.square(bx, out=bx)
                bx += np.square(by, out=by)
                d = np.sqrt(bx.min(axis=axis))
            # Even-odd rule: an edge crosses the ray from p in +x when p.y lies between its end
            # points' y (half-open) and p is on the left of the edge, seen along +y.
            side = ex * wy
            side -= np.multiply(ey, wx, out=wx)
            side *= ey_sign
            crossing = (qy >= sy) != (qy >= ty)
            crossing &= side > 0
            inside = np.logical_xor.reduce(crossing, axis=axis)
            distance[lo:hi] = np.negative(d, out=d, where=inside)
        return distance, offset, nearest

    @staticmethod
    def _flat(x, y):
        """Broadcast coordinates as contiguous 1D arrays in their common float type (float32 grids
        stay float32: half the memory traffic), and the broadcast shape."""
        dtype = np.result_type(x, y, 1.0)
        px, py = (np.ascontiguousarray(a, dtype=dtype).ravel() for a in np.broadcast_arrays(x, y))
        return px, py, np.broadcast_shapes(np.shape(x), np.shape(y))

    def _values(self, x, y):
        px, py, shape = self._flat(x, y)
        distance, _, _ = self._nearest(px, py)
        return distance.reshape(shape)

    @property
    def patch_count(self) -> int:
        return len(self.vertices)  # edge i runs from vertex i to vertex i + 1

    def _patch_labels(self, points):
        px, py, _ = self._flat(points[:, 0], points[:, 1])
        distance, _, nearest = self._nearest(px, py, offsets=True)
        return distance, nearest.astype(np.int64)

    def _patch_values(self, labels, points):
        offset = points - self._start[labels]
        return np.einsum("ij,ij->i", offset, self._outward[labels])

    def _values_and_gradient(self, x, y) -> tuple[np.ndarray, Coords]:
        px, py, shape = self._flat(x, y)
        distance, offset, nearest = self._nearest(px, py, offsets=True)
        length = np.abs(distance)
        # A point on an edge is left a few ulps off it by rounding (r = sqrt(x^2 + y^2) of a
        # revolved profile): the offset's direction is noise there, the edge's normal is not.
        on_boundary = length <= 1e-12 * self._scale
        # Outside, the gradient points away from the nearest point; inside, towards it.
        direction = np.where(distance < 0, -1.0, 1.0) / np.where(on_boundary, 1.0, length)
        gradient = np.where(on_boundary[:, None], self._outward[nearest], offset * direction[:, None])
        dtype = np.result_type(x, y, 1.0)
        return (
            distance.reshape(shape).astype(dtype, copy=False),
            tuple(gradient[:, axis].reshape(shape).astype(dtype, copy=False) for axis in range(2)),
        )


def _orientation(ax, ay, bx, by, cx, cy):
    return (bx - ax) * (cy - ay) - (by - ay) * (cx - ax)


def _overlapping_pairs(a: np.ndarray, b: np.ndarray, chunk: int = 1 << 18):
    """Index arrays (i, j) of all segment pairs whose x extents overlap, in chunks.

    A sweep in x: after sorting the segments by their left end, the partners of a segment are
    the following ones whose left end lies before its right end. The work is proportional to
    the number of such pairs, not to the square of the number of segments.
    """
    count = len(a)
    left = np.minimum(a[:, 0], b[:, 0])
    right = np.maximum(a[:, 0], b[:, 0])
    order = np.argsort(left, kind="stable")
    stop = np.searchsorted(left[order], right[order], side="right")
    partners = np.maximum(stop - np.arange(count) - 1, 0)
    cumulative = np.cumsum(partners)
    start = 0
    while start < count:
        done = int(cumulative[start - 1]) if start else 0
        end = max(start + 1, int(np.searchsorted(cumulative, done + chunk, side="right")))
        counts = partners[start:end]
        total = int(counts.sum())
        if total:
            first = np.repeat(np.arange(start, end), counts)
            offset = np.arange(total) - np.repeat(np.cumsum(counts) - counts, counts)
            yield order[first], order[first + 1 + offset]
        start = end


def check_simple(vertices: np.ndarray, name: str = "vertices") -> None:
    """Raise ValueError unless the closed polygon ``vertices`` is simple and has non-zero area."""
    count = len(vertices)
    edge = np.roll(vertices, -1, axis=0) - vertices
    lengths = np.hypot(edge[:, 0], edge[:, 1])
    if np.any(lengths == 0):
        i = int(np.argmax(lengths == 0))
        raise ValueError(f"{name} must not repeat a vertex; vertices {i} and {(i + 1) % count} coincide")
    # Adjacent edges only meet at their shared vertex unless they fold back onto each other.
    following = np.roll(edge, -1, axis=0)
    cross = edge[:, 0] * following[:, 1] - edge[:, 1] * following[:, 0]
    folded = (cross == 0) & (np.einsum("ij,ij->i", edge, following) < 0)
    if np.any(folded):
        i = (int(np.argmax(folded)) + 1) % count
        raise ValueError(
            f"{name} must describe a simple polygon; the boundary folds back on itself at vertex {i}"
        )
    a, b = vertices, np.roll(vertices, -1, axis=0)
    for i, j in _overlapping_pairs(a, b):
        gap = (j - i) % count
        keep = (gap > 1) & (gap < count - 1)  # adjacent edges were checked above
        i, j = i[keep], j[keep]
        ax, ay, bx, by = a[i, 0], a[i, 1], b[i, 0], b[i, 1]
        cx, cy, dx, dy = a[j, 0], a[j, 1], b[j, 0], b[j, 1]
        d1 = _orientation(cx, cy, dx, dy, ax, ay)
        d2 = _orientation(cx, cy, dx, dy, bx, by)
        d3 = _orientation(ax, ay, bx, by, cx, cy)
        d4 = _orientation(ax, ay, bx, by, dx, dy)
        crossing = (d1 * d2 <= 0) & (d3 * d4 <= 0)
        collinear = (d1 == 0) & (d2 == 0) & (d3 == 0) & (d4 == 0)
        # Collinear segments meet when their extents overlap in y too (x overlap is given).
        overlap = (np.maximum(ay, by) >= np.minimum(cy, dy)) & (np.maximum(cy, dy) >= np.minimum(ay, by))
        bad = crossing & (~collinear | overlap)
        if bad.any():
            first, second = sorted((int(i[bad][0]), int(j[bad][0])))
            raise ValueError(
                f"{name} must describe a simple polygon; edge {first} "
                f"({a[first].tolist()} -> {b[first].tolist()}) intersects edge {second} "
                f"({a[second].tolist()} -> {b[second].tolist()})"
            )
    area = 0.5 * float(np.sum(vertices[:, 0] * edge[:, 1] - vertices[:, 1] * edge[:, 0]))
    if area == 0.0:
        raise ValueError(f"{name} must enclose a non-zero area")


def polygon(vertices: Any) -> Polygon:
    """Simple polygon through ``vertices`` (2D, exact distance; either orientation).

    Parameters
    ----------
    vertices : (N, 2) array_like, N >= 3
        Corners in order; the polygon closes itself (a repeated first vertex at the end is
        dropped). Self-intersecting or degenerate polygons are refused with ``ValueError``.

    Examples
    --------
    >>> from fepre import sdf
    >>> ell = sdf.polygon([(0, 0), (2, 0), (2, 1), (1, 1), (1, 2), (0, 2)])
    >>> float(ell([1.5, 1.5])), float(ell([0.5, 0.5]))
    (0.5, -0.5)
    """
    array = _numeric_array(vertices, "vertices").astype(np.float64)
    if array.ndim != 2 or array.shape[1] != 2:
        raise ValueError(f"vertices must have shape (N, 2); got {array.shape}")
    if not np.isfinite(array).all():
        raise ValueError("vertices must be finite; got NaN or infinite coordinates")
    if len(array) > 3 and np.array_equal(array[0], array[-1]):
        array = array[:-1]
    if len(array) < 3:
        raise ValueError(f"vertices must hold at least 3 distinct corners; got {len(array)}")
    check_simple(array)
    return Polygon(np.ascontiguousarray(array))
