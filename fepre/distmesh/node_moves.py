"""Choosing the best of several candidate positions for a node, by the worst cell around it."""

from __future__ import annotations

import numpy as np

from .tet_shape import signed_volume

__all__ = ["best_candidate"]


def best_candidate(moved: np.ndarray, current: float, score) -> int | None:
    """Index of the candidate whose cells score best, or None if none beats ``current``.

    Parameters
    ----------
    moved : (C, S, 4, 3) float array
        The S cells around the moving node(s), once for each of C candidate positions.
    current : float
        The worst score of those cells now; a candidate must beat it (by 1e-9).
    score : callable
        ``score((K, 4, 3)) -> (K,)``, e.g. :meth:`~fepre.distmesh.tet_shape.ShapeTargets.score`.

    Examples
    --------
    >>> import numpy as np
    >>> from fepre.distmesh.tet_shape import ShapeTargets
    >>> flat = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0.3, 0.3, 0.05]], float)
    >>> tall = flat.copy(); tall[3, 2] = 0.8
    >>> best_candidate(np.stack([flat[None], tall[None]]), 0.0, ShapeTargets().score)
    1
    """
    candidates, cells = moved.shape[:2]
    flat = moved.reshape(-1, 4, 3)
    valid = (signed_volume(flat) > 0).reshape(candidates, cells).all(axis=1)
    worst = np.where(valid, score(flat).reshape(candidates, cells).min(axis=1), -np.inf)
    best = int(np.argmax(worst))
    return best if worst[best] > current + 1e-9 else None
