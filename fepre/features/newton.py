"""Points on two or three patch surfaces at once: Newton's method on the patches' functions.

A feature curve is where two patches of a model meet, a corner where three do. Each patch has a
smooth function (:meth:`fepre.sdf.SDF.patch_values`) that is zero on it; a point of the curve
solves ``f_a(x) = f_b(x) = 0``, a corner ``f_a = f_b = f_c = 0``. With two equations the step is
the minimum-norm one, ``dx = -J^T (J J^T)^-1 F``, which lands on the curve point nearest the
start; with three it is the plain Newton step. Gradients are central differences of the patch
functions (smooth by construction), so every node type takes part without an analytic gradient.
"""

from __future__ import annotations

import numpy as np

__all__ = ["patch_gradients", "solve_on_patches", "crease_angles"]


def patch_gradients(model, labels: np.ndarray, points: np.ndarray, step: float) -> np.ndarray:
    """Central-difference gradients (N, 3) of patch ``labels[i]`` at ``points[i]``."""
    gradient = np.empty(points.shape)
    for axis in range(3):
        shift = np.zeros(3)
        shift[axis] = step
        gradient[:, axis] = (
            model._patch_values(labels, points + shift) - model._patch_values(labels, points - shift)
        ) / (2.0 * step)
    return gradient


def _patch_system(model, labels: np.ndarray, points: np.ndarray, step: float) -> tuple[np.ndarray, np.ndarray]:
    """Values (N, m) and Jacobians (N, m, 3) of the m patch functions of each row of ``labels``."""
    count, m = labels.shape
    values = np.empty((count, m))
    jacobian = np.empty((count, m, 3))
    for column in range(m):
        values[:, column] = model._patch_values(labels[:, column], points)
        jacobian[:, column, :] = patch_gradients(model, labels[:, column], points, step)
    return values, jacobian


def solve_on_patches(
    model,
    labels: np.ndarray,
    start: np.ndarray,
    *,
    tol: float,
    step: float,
    reach: float,
    iterations: int = 30,
) -> tuple[np.ndarray, np.ndarray]:
    """Move each start point onto the intersection of its 2 or 3 patches.

    Parameters
    ----------
    model : fepre.sdf.SDF
    labels : (N, m) int array, m = 2 (a curve) or 3 (a corner)
    start : (N, 3) float array
    tol : float
        Converged once every ``|f|`` is below ``tol``.
    step : float
        Central-difference step of the gradients.
    reach : float
        Solutions farther than this from their start are refused (the patches' extensions may
        meet far from where the patches themselves do).
    iterations : int

    Returns
    -------
    points : (N, 3) the solutions (the last iterate where not converged)
    converged : (N,) bool

    Examples
    --------
    >>> import numpy as np
    >>> from fepre import sdf
    >>> cube = sdf.box(2.0)   # faces +x (label 1) and +y (label 3) meet on x = y = 1
    >>> points, ok = solve_on_patches(cube, np.array([[1, 3]]), np.array([[0.8, 1.1, 0.3]]),
    ...                               tol=1e-12, step=1e-6, reach=1.0)
    >>> np.round(points, 12).tolist(), ok.tolist()
    [[[1.0, 1.0, 0.3]], [True]]
    """
    labels = np.asarray(labels, dtype=np.int64)
    x = np.array(start, dtype=np.float64)
    count, m = labels.shape
    converged = np.zeros(count, dtype=bool)
    active = np.arange(count)
    for _ in range(iterations):
        if active.size == 0:
            break
        values, jacobian = _patch_system(model, labels[active], x[active], step)
        done = np.abs(values).max(axis=1) <= tol
        converged[active[done]] = True
        active, values, jacobian = active[~done], values[~done], jacobian[~done]
        if active.size == 0:
            break
        if m == 3:
            square = jacobian
            rhs = values
        else:
            square = jacobian @ np.swapaxes(jacobian, 1, 2)
            rhs = values
        # rows whose patches are parallel here (or whose system is singular) are given up
        determinant = np.linalg.det(square)
        scale = np.prod(np.einsum("nij,nij->ni", jacobian, jacobian), axis=1)  # |a|^2 |b|^2 (|c|^2)
        if m == 3:
            scale = np.sqrt(scale)
        solvable = np.abs(determinant) > 1e-10 * np.maximum(scale, 1e-300)
        active, square, rhs, jacobian = active[solvable], square[solvable], rhs[solvable], jacobian[solvable]
        if active.size == 0:
            break
        solution = np.linalg.solve(square, rhs[:, :, None])[:, :, 0]
        if m == 3:
            delta = solution
        else:
            delta = np.einsum("nij,ni->nj", jacobian, solution)
        x[active] -= delta
    far = np.linalg.norm(x - start, axis=1) > reach
    return x, converged & ~far


def crease_angles(model, labels: np.ndarray, points: np.ndarray, step: float) -> np.ndarray:
    """Angle in degrees between the outward normals of the two patches ``labels`` (N, 2) at ``points``.

    0 where the patches continue each other smoothly, 90 at a box edge, up to 180 at a knife edge.
    """
    a = patch_gradients(model, labels[:, 0], points, step)
    b = patch_gradients(model, labels[:, 1], points, step)
    a /= np.maximum(np.linalg.norm(a, axis=1), 1e-300)[:, None]
    b /= np.maximum(np.linalg.norm(b, axis=1), 1e-300)[:, None]
    return np.degrees(np.arccos(np.clip(np.einsum("ij,ij->i", a, b), -1.0, 1.0)))
