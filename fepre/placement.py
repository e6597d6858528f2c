"""Placement: the local frame fepre meshes and detects in, near the origin.

A part placed far from the origin (assembly coordinates in mm: 1e3 to 1e5) has coordinates
whose rounding (``|x| * 2.2e-16``, 2e-12 at 1e4) is no longer small next to the tolerances
that are relative to its size and to ``h``: Newton's method on a feature curve stops at
``1e-13`` of the part's size (:mod:`fepre.features`), flat cells are told by volumes of ``1e-10
h^3`` (:mod:`fepre.distmesh.delaunay`). :func:`fepre.distmesh`, :func:`fepre.features` and
:func:`fepre.size_field` therefore work on the part moved near the origin, by
:func:`local_offset`, and move their result back; the model is composed with the translation
(``model.translate(-offset)``), which cancels a part's own translation exactly when it was
placed by ``translate``.

A part already near the origin (the centre of its box within :data:`FAR` times its largest
extent) is not moved, so its mesh is the one it always had.
"""

from __future__ import annotations

from typing import Any

import numpy as np

__all__ = ["FAR", "local_offset", "moved_size", "moved_features"]

#: a box whose centre is farther from the origin than this many times its largest extent is
#: moved to the origin
FAR = 1.0


def local_offset(lower, upper) -> np.ndarray:
    """The translation the local frame subtracts from a box ``(lower, upper)``, (3,) floats.

    Zero for a box near the origin (centre within ``FAR`` times the largest extent ``L``);
    otherwise the box's centre rounded to a multiple of ``10^floor(log10 L)``, per axis. The
    rounding keeps the offset a round number: a part placed by ``translate((1e4, 0, 0))`` is
    moved back by exactly ``1e4`` and meshes as it does at the origin; the centre of the moved
    box is within ``L / 2`` of the origin.

    Parameters
    ----------
    lower, upper : (3,) array_like
        The box's corners.

    Returns
    -------
    (3,) float64 array

    Examples
    --------
    >>> local_offset((-1, -1, -1), (1, 1, 1)).tolist()
    [0.0, 0.0, 0.0]
    >>> local_offset((9999, 9999, -1), (10001, 10001, 1)).tolist()
    [10000.0, 10000.0, 0.0]
    >>> local_offset((1233.9, 0, 0), (1325.2, 50, 50)).tolist()   # 10s for a part 91 long
    [1280.0, 0.0, 0.0]
    """
    lower, upper = (np.asarray(v, dtype=np.float64).reshape(-1) for v in (lower, upper))
    extent = float((upper - lower).max())
    centre = 0.5 * (lower + upper)
    if not (np.isfinite(extent) and extent > 0 and np.isfinite(centre).all()):
        return np.zeros_like(centre)
    if float(np.abs(centre).max()) <= FAR * extent:
        return np.zeros_like(centre)
    quantum = 10.0 ** np.floor(np.log10(extent))
    return np.round(centre / quantum) * quantum + 0.0  # no -0.0


def moved_size(size: Any, shift: np.ndarray) -> Any:
    """A ``size=`` argument moved by ``shift``: a size field (``translated``) or a background
    mesh moved, a relative size callable composed with the translation; anything else as given
    (the argument checks say what is wrong with it)."""
    if size is None:
        return None
    shift = np.asarray(shift, dtype=np.float64)
    if getattr(size, "world_units", False) and hasattr(size, "translated"):
        return size.translated(shift)
    if callable(size):
        return lambda points: size(np.asarray(points, dtype=np.float64) - shift)
    if hasattr(size, "translate"):  # a pyvista dataset (a background mesh)
        return size.translate(tuple(float(v) for v in shift), inplace=False)
    return size


def moved_features(found: Any, shift: np.ndarray) -> Any:
    """A :class:`fepre.Features` with its corners and curve nodes moved by ``shift``."""
    import dataclasses

    shift = np.asarray(shift, dtype=np.float64)
    curves = tuple(dataclasses.replace(curve, points=curve.points + shift) for curve in found.curves)
    return dataclasses.replace(found, corners=found.corners + shift, curves=curves)
