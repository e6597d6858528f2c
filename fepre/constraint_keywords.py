"""The keyword arguments of :func:`fepre.distmesh` that packages above it provide.

``periodic=`` and ``regions=`` are constraints made by :mod:`fepre.periodic` and
:mod:`fepre.regions`, which import :mod:`fepre.distmesh`; the mesher cannot import them back.
fepre's top-level package (the layer above all three) registers each keyword's factory here,
and the mesher looks the factory up by the keyword's name. This module imports nothing of fepre.
"""

from __future__ import annotations

from typing import Any, Callable

__all__ = ["register", "constraint_for"]

#: keyword -> factory(value, job) of a fepre.distmesh.constraints.MeshConstraint
_FACTORIES: dict[str, Callable[[Any, Any], Any]] = {}


def register(keyword: str, factory: Callable[[Any, Any], Any]) -> None:
    """Make ``distmesh(..., keyword=value)`` add the constraint ``factory(value, job)``."""
    _FACTORIES[keyword] = factory


def constraint_for(keyword: str, value: Any, job: Any):
    """The constraint of ``keyword=value`` for the meshing ``job`` (its argument checks run now)."""
    if keyword not in _FACTORIES:
        raise TypeError(f"distmesh() got the keyword {keyword}= but no package registered it")
    return _FACTORIES[keyword](value, job)
