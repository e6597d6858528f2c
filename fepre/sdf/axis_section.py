"""The meridian section of a polygon profile that touches or crosses the axis of revolution.

Revolving a profile drawn from the axis (a shaft's half-section) sweeps the profile and its mirror
image about the axis into one solid: in a meridian plane the solid's section is the union
``U = P | mirror(P)``. The union's sharp value ``min(d_P, d_mirror)`` is a valid bound but not a
distance: near the axis it is about ``-r`` (the axis edge of each half is still "boundary"), so a
point 0.5 from the axis of a radius-10 shaft reads -0.5 instead of -9.5 and DistMesh pulls nodes
onto the axis. :class:`AxisSection` holds the true boundary of ``U`` (the edges of both halves
split where they meet, without the pieces that have ``U`` on both sides, such as the axis edge) and
so gives the exact signed distance of the section, hence of the solid.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from .polygon import Polygon

__all__ = ["AxisSection", "mirrored_section"]


class AxisSection(Polygon):
    """Exact signed distance to the union of a polygon and its mirror image about x = 0.

    The boundary is a set of closed loops of segments (``_start``, ``_end``), each oriented with
    the region on its left; the even-odd rule of :class:`Polygon` gives the sign.
    """

    def __init__(self, start: np.ndarray, end: np.ndarray) -> None:
        self._start, self._end = start, end
        self._edge = end - start
        self._inverse_length2 = 1.0 / np.einsum("ij,ij->i", self._edge, self._edge)
        self.area = 0.5 * float(np.sum(start[:, 0] * self._edge[:, 1] - start[:, 1] * self._edge[:, 0]))
        self.vertices = start
        self._outward = np.column_stack([self._edge[:, 1], -self._edge[:, 0]])
        self._outward /= np.linalg.norm(self._outward, axis=1)[:, None]
        corners = np.concatenate([start, end])
        self._scale = float(np.max(np.abs(corners))) or 1.0
        super(Polygon, self).__init__(bounds=(tuple(corners.min(axis=0)), tuple(corners.max(axis=0))), exact=True)

    def _parameters(self) -> dict[str, Any]:
        return {"segments": len(self._start), "area": abs(self.area)}

    def _label(self) -> str:
        return "axis section"


def _split_parameters(start: np.ndarray, end: np.ndarray, tol: float) -> list[np.ndarray]:
    """For each segment, the sorted parameters in [0, 1] where another segment meets it."""
    edge = end - start
    length2 = np.einsum("ij,ij->i", edge, edge)
    # ends of other segments lying on a segment (touching and collinear overlaps)
    ends = np.concatenate([start, end])
    w = ends[None, :, :] - start[:, None, :]
    t_end = np.einsum("ijk,ik->ij", w, edge) / length2[:, None]
    foot = start[:, None, :] + t_end[..., None] * edge[:, None, :]
    on = (np.linalg.norm(ends[None] - foot, axis=2) <= tol) & (t_end > 0) & (t_end < 1)
    # proper crossings
    cross = edge[:, None, 0] * edge[None, :, 1] - edge[:, None, 1] * edge[None, :, 0]
    d = start[None, :, :] - start[:, None, :]
    with np.errstate(divide="ignore", invalid="ignore"):
        t = (d[..., 0] * edge[None, :, 1] - d[..., 1] * edge[None, :, 0]) / cross
        s = (d[..., 0] * edge[:, None, 1] - d[..., 1] * edge[:, None, 0]) / cross
    crossing = (np.abs(cross) > tol * tol) & (t > 0) & (t < 1) & (s >= 0) & (s <= 1)
    return [np.unique(np.concatenate([[0.0, 1.0], t_end[i, on[i]], t[i, crossing[i]]])) for i in range(len(start))]


def mirrored_section(profile: Polygon, offset: float = 0.0) -> AxisSection:
    """The section ``P | mirror(P)`` of ``profile`` shifted by ``offset`` in x, as an :class:`AxisSection`.

    Examples
    --------
    >>> from fepre import sdf
    >>> half = sdf.polygon([(0, 0), (10, 0), (10, 40), (0, 40)])
    >>> section = mirrored_section(half)
    >>> float(section([0.5, 20.0])), float((half | half.mirror((1, 0)))([0.5, 20.0]))
    (-9.5, -0.5)
    """
    vertices = profile.vertices + np.array([offset, 0.0])
    mirrored = vertices * np.array([-1.0, 1.0])
    start = np.concatenate([vertices, mirrored])
    end = np.concatenate([np.roll(vertices, -1, axis=0), np.roll(mirrored, -1, axis=0)])
    scale = float(np.max(np.abs(vertices)))
    tol = 1e-9 * scale
    pieces_start, pieces_end = [], []
    for a, b, params in zip(start, end, _split_parameters(start, end, tol)):
        points = a + params[:, None] * (b - a)
        keep = np.linalg.norm(np.diff(points, axis=0), axis=1) > tol
        pieces_start.append(points[:-1][keep])
        pieces_end.append(points[1:][keep])
    a, b = np.concatenate(pieces_start), np.concatenate(pieces_end)
    middle = 0.5 * (a + b)
    direction = (b - a) / np.linalg.norm(b - a, axis=1)[:, None]
    left = np.column_stack([-direction[:, 1], direction[:, 0]])
    step = 1e-7 * scale

    def inside(p: np.ndarray) -> np.ndarray:
        shifted = p - np.array([offset, 0.0])
        mirror = (p * np.array([-1.0, 1.0])) - np.array([offset, 0.0])
        return (profile._values(shifted[:, 0], shifted[:, 1]) < 0) | (profile._values(mirror[:, 0], mirror[:, 1]) < 0)

    in_left, in_right = inside(middle + step * left), inside(middle - step * left)
    boundary = in_left != in_right
    a, b = np.where(in_right[:, None], b, a), np.where(in_right[:, None], a, b)
    a, b = a[boundary], b[boundary]
    # the same piece from both halves (a profile drawn symmetric about the axis) is kept once
    key = np.round(np.concatenate([a, b], axis=1) / tol).astype(np.int64)
    _, first = np.unique(key, axis=0, return_index=True)
    first = np.sort(first)
    return AxisSection(np.ascontiguousarray(a[first]), np.ascontiguousarray(b[first]))
