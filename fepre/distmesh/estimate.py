"""How long a DistMesh run has left: the loop's end from its quality trend, the stages after it
from the loop's own Delaunay time."""

from __future__ import annotations

import numpy as np

__all__ = ["iterations_left", "seconds_after_loop"]

#: the stages after the loop (final mesh, quality stage, checks, output grid) cost about this
#: many of the loop's Delaunay triangulations of the same points (measured on the sphere, a box
#: with holes and a gyroid block from 50k to 2.4M cells: 2.9-4.4)
AFTER_LOOP_TRIANGULATIONS = 4.0


def iterations_left(mean_quality, window: int, tol: float, maxiter: int) -> float | None:
    """Iterations the loop still needs by its quality criterion, or None while it cannot tell.

    The loop stops when the best mean volume-edge ratio of the last ``window`` iterations beats
    the best before them by less than ``tol`` (:class:`~fepre.distmesh.options.DistMeshOptions`).
    That gain shrinks about geometrically as the points settle: a line through the logarithm
    of the recent gains says where it falls under ``tol``.

    Examples
    --------
    >>> k = np.arange(25)
    >>> quality = 0.9 - 0.05 * np.exp(-k / 8)  # settles with a time constant of 8 iterations
    >>> round(iterations_left(quality, 10, 0.002, 1000))  # the criterion stops it at iteration 35
    9
    """
    quality = np.asarray(mean_quality, dtype=np.float64)
    done = len(quality)
    if done < window + 3:
        return None
    best = np.maximum.accumulate(quality)
    gains = (best[window:] - best[:-window])[-2 * window :]
    at = np.arange(done - len(gains), done, dtype=np.float64)
    floor = max(2 * window - done, 0)
    growing = gains > 0
    if gains[-1] < tol:
        return float(min(floor, maxiter - done))
    if growing.sum() < 3:
        return None
    slope, intercept = np.polyfit(at[growing], np.log(gains[growing]), 1)
    if slope >= 0:
        return None
    end = (np.log(tol) - intercept) / slope
    return float(np.clip(end - done + 1, floor, maxiter - done))


def seconds_after_loop(delaunay_seconds: float) -> float:
    """The final mesh, quality stage, checks and output, from one loop triangulation's time."""
    return AFTER_LOOP_TRIANGULATIONS * delaunay_seconds
