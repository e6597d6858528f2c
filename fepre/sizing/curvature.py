"""Largest principal curvature of the surface at surface points, from the smooth patch's Hessian.

The model's own Hessian is useless at sharp edges (a box's distance has curvature ``1/r`` on
the rounded offsets around every edge, infinite on the edge itself), so the differences are
taken of the function of the smooth piece of surface the point lies on
(:meth:`fepre.sdf.SDF.patch_values`): a box face is a plane there, a hole's wall a cylinder.
For a level set of ``f`` the shape operator is ``P H P / |grad f|`` with ``P`` the projection on
the tangent plane; its largest eigenvalue in magnitude is the largest principal curvature.
"""

from __future__ import annotations

import numpy as np

__all__ = ["max_curvature"]


def max_curvature(model, points: np.ndarray, step: float) -> np.ndarray:
    """``max |k|`` at ``points`` (on or next to the surface), by central differences of ``step``.

    Examples
    --------
    >>> import numpy as np
    >>> from fepre import sdf
    >>> part = sdf.box((4.0, 4.0, 4.0)) - sdf.cylinder(0.5, 6.0)
    >>> k = max_curvature(part, np.array([[0.5, 0.0, 0.0], [2.0, 1.0, 1.0]]), 1e-3)
    >>> np.round(k, 3).tolist()   # the hole's wall, a face of the box
    [2.0, 0.0]
    """
    n = len(points)
    if n == 0:
        return np.zeros(0)
    _, labels = model.patch_labels(points)
    e = np.eye(3) * step
    offsets = [np.zeros(3)]
    for i in range(3):
        offsets += [e[i], -e[i]]
    for i in range(3):
        for j in range(i + 1, 3):
            offsets += [e[i] + e[j], e[i] - e[j], -e[i] + e[j], -e[i] - e[j]]
    offsets = np.array(offsets)  # (19, 3)
    stencil = (points[:, None, :] + offsets[None, :, :]).reshape(-1, 3)
    values = model.patch_values(np.repeat(labels, len(offsets)), stencil).reshape(n, len(offsets))
    center = values[:, 0]
    gradient = np.stack([(values[:, 1 + 2 * i] - values[:, 2 + 2 * i]) / (2 * step) for i in range(3)], axis=1)
    hessian = np.empty((n, 3, 3))
    for i in range(3):
        hessian[:, i, i] = (values[:, 1 + 2 * i] + values[:, 2 + 2 * i] - 2 * center) / step**2
    column = 7
    for i in range(3):
        for j in range(i + 1, 3):
            pp, pm, mp, mm = (values[:, column + k] for k in range(4))
            hessian[:, i, j] = hessian[:, j, i] = (pp - pm - mp + mm) / (4 * step**2)
            column += 4
    norm = np.linalg.norm(gradient, axis=1)
    normal = gradient / np.where(norm > 0, norm, 1.0)[:, None]
    projection = np.eye(3)[None] - normal[:, :, None] * normal[:, None, :]
    shape = projection @ hessian @ projection / np.where(norm > 0, norm, np.inf)[:, None, None]
    return np.abs(np.linalg.eigvalsh(shape)).max(axis=1)
