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

from contextlib import contextmanager
from contextvars import ContextVar
from typing import Any, Iterator

import numpy as np

#: the offset from the frame fepre works in to the user's (None: the same frame)
_USER_OFFSET: ContextVar = ContextVar("fepre_user_offset", default=None)


@contextmanager
def user_frame(offset: np.ndarray) -> Iterator[None]:
    """While inside, fepre works in a frame moved by ``-offset`` from the user's: messages that
    name a place add it back (:func:`in_user_frame`)."""
    token = _USER_OFFSET.set(in_user_frame(np.asarray(offset, dtype=np.float64)) if _USER_OFFSET.get() is not None
                             else np.asarray(offset, dtype=np.float64))
    try:
        yield
    finally:
        _USER_OFFSET.reset(token)


def in_user_frame(points: Any) -> np.ndarray:
    """``points`` (or an offset) of the working frame in the user's coordinates.

    Examples
    --------
    >>> with user_frame([1000.0, 0.0, 0.0]):
    ...     in_user_frame([0.5, 0.0, 0.0]).tolist()
    [1000.5, 0.0, 0.0]
    """
    offset = _USER_OFFSET.get()
    points = np.asarray(points, dtype=np.float64)
    return points if offset is None else points + offset

__all__ = ["FAR", "local_offset", "moved_size", "moved_features", "user_frame", "in_user_frame"]

#: a box whose centre is farther from the origin than this many times its largest extent is
#: moved to the origin
FAR = 1.0


def local_offset(lower, upper) -> np.ndarray:
    """The translation the local frame subtracts from a box ``(lower, upper)``, (3,) floats.

    Per axis: zero where the box's centre is within ``FAR`` times its largest extent ``L`` of
    the origin (a part near the origin keeps its mesh); else the roundest number (a multiple of
    the largest power of ten) within ``FAR * L`` of the centre. A part is usually placed by a
    round translation: ``part.translate((1e4, 0, 0))`` is moved back by exactly ``1e4`` even when
    its box is not centred on its own origin, and meshes as it does there. The moved box's centre
    is within ``L`` of the origin on every axis.

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
    >>> local_offset((10000, 0, 0), (10002, 1, 1)).tolist()   # box(2) translated by (10001, 0, 0)
    [10000.0, 0.0, 0.0]
    >>> local_offset((1233.9, 0, 0), (1325.2, 50, 50)).tolist()
    [1300.0, 0.0, 0.0]
    """
    lower, upper = (np.asarray(v, dtype=np.float64).reshape(-1) for v in (lower, upper))
    extent = float((upper - lower).max())
    centre = 0.5 * (lower + upper)
    if not (np.isfinite(extent) and extent > 0 and np.isfinite(centre).all()):
        return np.zeros_like(centre)
    offset = np.zeros_like(centre)
    for axis in np.flatnonzero(np.abs(centre) > FAR * extent):
        c = float(centre[axis])
        # the roundest number within FAR * extent of the centre: 10^k down to 10^floor(log10 L),
        # whose multiples are at most L / 2 away, so one always is
        for k in range(int(np.floor(np.log10(abs(c)))) + 1, int(np.floor(np.log10(extent))) - 1, -1):
            candidate = float(np.round(c / 10.0**k)) * 10.0**k
            if abs(c - candidate) <= FAR * extent:
                offset[axis] = candidate
                break
    return offset + 0.0  # no -0.0


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
    # its crease search (``creases``) stays with the model it was made on
    return dataclasses.replace(found, corners=found.corners + shift, curves=curves, creases=None)
