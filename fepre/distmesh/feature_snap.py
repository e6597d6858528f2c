"""Put the pinned sharp-edge nodes of another mesher's mesh back on the model's edges.

:func:`fepre.improve` pins the boundary nodes on a model's sharp edges and corners (sliding
them would round the crease off). Another mesher (gmsh, pytetwild) places those nodes on its
own surface triangulation, up to a few thousandths of h off the model, and a pinned node would
keep that error against the stage's promise of ``1e-3 h`` (BACKGROUND.md section 10, root cause
7). :func:`snap_pinned_nodes` moves each such node, once before the stage, onto the nearest
point of the nearest feature: a corner as found, a curve point by Newton's method on the
curve's two patches (:func:`fepre.features.newton.solve_on_patches`); a node with no feature
within reach is projected onto the zero set. A node whose move would invert one of its cells
stays where it was.
"""

from __future__ import annotations

import numpy as np

from .tet_shape import signed_volume

__all__ = ["snap_pinned_nodes", "SNAP_REACH"]

#: Largest move, times h, of a pinned node onto a feature.
SNAP_REACH = 0.25


def _onto_features(model, points: np.ndarray, found, h: float) -> tuple[np.ndarray, np.ndarray]:
    """Nearest feature points (K, 3) of ``points`` and a mask (K,) of those found within reach."""
    from ..features.geometry import nearest_on_segments
    from ..features.newton import solve_on_patches

    curves = [c for c in found.curves if len(c.points) > 1]
    segments = found.segments
    distance, nearest, index = nearest_on_segments(points, segments, found.corners, with_index=True, within=SNAP_REACH * h)
    near = distance <= SNAP_REACH * h
    on_curve = np.flatnonzero(near & (index >= 0))
    if on_curve.size:
        patches = np.concatenate([np.repeat([c.patches], len(c.segments), axis=0) for c in curves])
        # the polyline's point is a chord's: Newton takes it onto the curve itself
        solved, converged = solve_on_patches(
            model, patches[index[on_curve]], nearest[on_curve], tol=1e-6 * h, step=1e-4 * h, reach=SNAP_REACH * h
        )
        nearest[on_curve] = solved
        near[on_curve[~converged]] = False
    return nearest, near


def snap_pinned_nodes(model, points: np.ndarray, tets: np.ndarray, pinned: np.ndarray, found, h: float) -> tuple[np.ndarray, int]:
    """Move the pinned nodes farther than ``1e-4 h`` from the zero set onto the model.

    Parameters
    ----------
    model : fepre.sdf.SDF
    points : (N, 3) float array
    tets : (M, 4) int array, positively oriented
    pinned : (N,) bool
        The nodes the stage will keep fixed (boundary nodes on sharp edges and corners).
    found : fepre.features.Features or None
        The model's features; without them nodes are projected onto the zero set.
    h : float

    Returns
    -------
    points : (N, 3) a copy with the nodes moved
    moved : number of nodes moved

    Examples
    --------
    >>> import numpy as np
    >>> from fepre import sdf
    >>> cube = sdf.box(2.0)
    >>> points = np.array([[0.99, 0.99, 0.0], [0, 0, 0], [0, -1, 0.5], [-1, 0, 0.5]])
    >>> tets = np.array([[0, 1, 2, 3]])   # positively oriented
    >>> new, moved = snap_pinned_nodes(cube, points, tets, np.array([True, False, False, False]), None, 0.5)
    >>> moved, float(abs(cube(new[:1])[0])) < 1e-9
    (1, True)
    """
    off = np.flatnonzero(pinned & (np.abs(model(points)) > 1e-4 * h))
    if off.size == 0:
        return points, 0
    target = model.project(points[off], iterations=20, warn=False)
    if found:
        nearest, near = _onto_features(model, points[off], found, h)
        target[near] = nearest[near]
    new_points = points.copy()
    new_points[off] = target
    moved = np.zeros(points.shape[0], dtype=bool)
    moved[off] = True
    around = np.flatnonzero(moved[tets].any(axis=1))
    while True:
        inverted = around[signed_volume(new_points[tets[around]]) <= 0]
        back = np.intersect1d(tets[inverted].ravel(), np.flatnonzero(moved))
        if back.size == 0:
            return new_points, int(moved.sum())
        new_points[back] = points[back]
        moved[back] = False
