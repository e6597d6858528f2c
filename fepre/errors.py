"""Exceptions and warnings raised by fepre."""

from __future__ import annotations

__all__ = ["MeshingError", "ConvergenceWarning"]


class MeshingError(RuntimeError):
    """An algorithm could not produce a valid result from valid input.

    Raised, for example, when a model's negative region misses the meshing bounds or when a
    triangulation fails. Bad arguments raise ``ValueError``/``TypeError`` instead.
    """


class ConvergenceWarning(UserWarning):
    """An iterative algorithm stopped at ``maxiter`` before meeting its tolerance.

    The result returned alongside the warning is the best one reached.
    """
