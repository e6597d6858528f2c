"""Exceptions and warnings raised by fepre."""

from __future__ import annotations

__all__ = ["MeshingError", "ConvergenceWarning", "FeatureWarning", "ResolutionWarning"]


class MeshingError(RuntimeError):
    """An algorithm could not produce a valid result from valid input.

    Raised, for example, when a model's negative region misses the meshing bounds or when a
    triangulation fails. Bad arguments raise ``ValueError``/``TypeError`` instead.
    """


class ConvergenceWarning(UserWarning):
    """An iterative algorithm stopped at ``maxiter`` before meeting its tolerance.

    The result returned alongside the warning is the best one reached.
    """


class FeatureWarning(UserWarning):
    """Sharp features were found that a mesh of the requested size cannot hold, and were skipped.

    Raised by :func:`fepre.features` (and so by :func:`fepre.distmesh`) for features closer
    together than about ``h/2`` (thin walls, tiny steps, small holes); the message names what was
    skipped. Meshing goes on without those features.
    """


class ResolutionWarning(UserWarning):
    """The mesh leaves out material of the model that is thinner than its ``h`` resolves.

    Raised by :func:`fepre.distmesh` when walls, fins or pins under about ``h`` thick came out
    thinner, perforated or missing (see :func:`fepre.distmesh.lost_material`); the message
    names where, how thick the material is, about how much volume is missing and the ``h``
    that would keep it. :func:`fepre.size_field` (and so ``distmesh(model, h=(hmin, hmax))``)
    warns with it too, naming the walls, gaps and close sharp edges that would need elements
    smaller than ``hmin`` (the field stops at ``hmin``).
    """


class RepairWarning(UserWarning):
    """Repairing a triangle-mesh model changed the solid noticeably.

    Raised by :func:`fepre.sdf.mesh` when the patches that close its holes add or remove more
    than 0.5% of its volume beyond flat caps across the holes, or reach past the input's bounds;
    the message gives the figures, so that the user can decide whether the fill is what the part
    should be (planar holes are closed flat and never warn).
    """


def warn_user(message: str, category: type[Warning]) -> None:
    """``warnings.warn`` pointing at the first caller outside fepre (the user's line), however
    deep inside fepre the warning is raised (``stacklevel`` counted by hand pointed into fepre's
    own call wrappers, e.g. ``fepre/distmesh/__init__.py:27``)."""
    import os
    import sys
    import warnings

    package = os.path.dirname(os.path.abspath(__file__)) + os.sep
    frame, level = sys._getframe(1), 2
    while frame is not None and os.path.abspath(frame.f_code.co_filename).startswith(package):
        frame, level = frame.f_back, level + 1
    warnings.warn(message, category, stacklevel=level)
