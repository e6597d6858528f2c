"""Sharp features of a model: the corners and edges where its smooth surface pieces meet.

Engineering parts have sharp edges and corners, and loads and supports are applied exactly
there. The model's tree knows which primitive's surface is active near a point
(:meth:`fepre.sdf.SDF.patch_labels`), so the lines where two of them meet at an angle, and the
points where three meet, can be found exactly. DistMesh makes them mesh nodes
(``features=True``) and dual contouring keeps surfaces sharp along them.

Examples
--------
>>> import fepre
>>> from fepre import sdf
>>> part = sdf.box(2.0) - sdf.cylinder(radius=0.5, height=3.0)
>>> found = fepre.features(part, h=0.25)
>>> len(found.corners), len(found.curves), sum(c.closed for c in found.curves)
(8, 14, 2)
"""

from __future__ import annotations

from typing import Any, Callable

import numpy as np

from ..callable_package import make_callable
from ..arguments import domain_bounds, evaluate_size, finite_float, positive_float
from ..errors import FeatureWarning, warn_user
from ..placement import local_offset, moved_features, moved_size
from ..sdf.core import SDF, require_solid_model
from .conflicts import resolve_conflicts
from .curves import FeatureCurve, build_curves
from .detect import find_creases
from .mesh_creases import from_triangles, triangle_creases
from .result import Features

__all__ = ["features", "Features", "FeatureCurve", "DEFAULT_ANGLE", "MAX_GRID_NODES"]

#: Default crease threshold: patches whose normals differ by more than this are a sharp edge.
DEFAULT_ANGLE = 30.0
#: The fine grid features are found on has at most about this many nodes; a finer ``spacing`` is
#: coarsened (and the warning says so).
MAX_GRID_NODES = 30_000_000


def features(
    model: SDF,
    h: float,
    *,
    angle: float = DEFAULT_ANGLE,
    spacing: float | None = None,
    bounds: Any = None,
    size: Callable[[np.ndarray], np.ndarray] | None = None,
    warn: bool = True,
    creases: Any = None,
) -> Features:
    """Corners and feature curves of ``model``, with curve nodes about ``h`` apart.

    Parameters
    ----------
    model : fepre.sdf.SDF
        A 3D model. Sharp booleans, boxes, cylinders, cones, polygon extrusions, polyhedra,
        transforms, offsets and shells contribute their edges; smooth blends (``k > 0``) and
        smooth primitives have none.
    h : float
        Spacing of the nodes along the curves (the mesh's edge length).
    angle : float
        Crease threshold in degrees, in (0, 180): two patches form a feature where their normals
        differ by more than this (default 30).
    spacing : float, optional
        Spacing of the fine grid the features are searched on (default ``h/4``). Features
        closer together than a few spacings may be missed.
    bounds : ((xmin, ymin, zmin), (xmax, ymax, zmax)), optional
        Box searched; default the model's bounds.
    size : callable, optional
        Relative size function ``size(points (N, 3)) -> (N,)``, as for :func:`fepre.distmesh`:
        curve nodes are about ``h * size(x) / min(size)`` apart.
    warn : bool
        Warn with :class:`fepre.FeatureWarning` when features had to be skipped.
    creases : optional
        ``Features.creases`` of an earlier call: used instead of searching again when that
        search was of this model (the same object) at the same grid spacing and ``angle`` over a
        box holding ``bounds`` (the size field's search and the mesher's are one); its points in
        ``bounds`` are taken. Otherwise ignored.

    Returns
    -------
    Features
        ``corners``, ``curves``, ``nodes``, ``segments``, ``to_polydata()`` to look at them,
        ``skipped`` in words.

    Notes
    -----
    A part far from the origin is handled near it and the result moved back
    (:mod:`fepre.placement`), so it does not depend on where the part is placed.

    Examples
    --------
    >>> import fepre
    >>> from fepre import sdf
    >>> found = fepre.features(sdf.box((2, 1, 1)), h=0.5)
    >>> found.corners.min(axis=0).tolist(), found.corners.max(axis=0).tolist()
    ([-1.0, -0.5, -0.5], [1.0, 0.5, 0.5])
    >>> bool(fepre.features(sdf.sphere(1.0), h=0.2))   # a sphere has no features
    False
    """
    require_solid_model(model)
    h = positive_float(h, "h")
    angle = finite_float(angle, "angle")
    if not 0.0 < angle < 180.0:
        raise ValueError(f"angle must be in (0, 180) degrees; got {angle!r}")
    if size is not None and not callable(size):
        raise TypeError(f"size must be a callable (N, 3) -> (N,) or None; got {type(size).__name__}")
    lower, upper = (np.asarray(b, dtype=np.float64) for b in domain_bounds(model, bounds))
    offset = local_offset(lower, upper)
    if offset.any():  # found near the origin, where Newton's tolerances can be met (fepre.placement)
        found = features(model.translate(-offset), h, angle=angle, spacing=spacing, bounds=(lower - offset, upper - offset),
                         size=moved_size(size, -offset), warn=warn)  # a new model: nothing to reuse
        return moved_features(found, offset)
    scale = float(np.max(upper - lower))
    spacing = h / 4.0 if spacing is None else positive_float(spacing, "spacing")
    if spacing >= scale:
        raise ValueError(f"spacing={spacing!r} must be smaller than the model's largest extent {scale:g}")
    skipped: list[str] = []
    empty = Features(np.zeros((0, 3)), (), h, angle, spacing, ())
    if model.patch_count == 1 and len(model.singular_points()) == 0:
        return empty
    nodes = np.prod((upper - lower) / spacing + 6.0)
    if from_triangles(model):  # a label image's region, a closed STL: its triangles' edges, no grid
        nodes = 0.0
    if nodes > MAX_GRID_NODES:
        coarser = spacing * float(nodes / MAX_GRID_NODES) ** (1.0 / 3.0)
        skipped.append(
            f"the search grid was coarsened from spacing {spacing:.4g} to {coarser:.4g} "
            f"(fepre.features.MAX_GRID_NODES = {MAX_GRID_NODES}): features smaller than about {2 * coarser:.3g} may be missed"
        )
        spacing = coarser

    if creases is not None and creases.reusable(model, spacing, lower, upper, angle):
        creases = creases.within(lower, upper, 1e-9 * scale)
    elif from_triangles(model):
        creases = triangle_creases(model, spacing, (lower, upper), angle)
    else:
        creases = find_creases(model, spacing, (lower, upper), angle, scale)
        creases.source = (model, lower, upper, angle)
    local_h = _local_spacing(model, h, size, (lower, upper))
    curves = build_curves(model, creases, local_h, scale)
    corners, curves, conflicts = resolve_conflicts(creases.corners, curves, local_h, scale, angle)
    skipped.extend(conflicts)
    if skipped and warn:
        warn_user("fepre.features: " + "; ".join(skipped), FeatureWarning)
    return Features(corners, tuple(curves), h, angle, spacing, tuple(skipped), creases)


def _local_spacing(model: SDF, h: float, size: Callable | None, bounds) -> Callable[[np.ndarray], np.ndarray]:
    """``x -> h * size(x) / min(size)``, the minimum taken over the solid (on a 32^3 grid, as
    DistMesh takes it over its initial lattice); ``x -> h`` without a size function."""
    if size is None:
        return lambda points: np.full(len(points), h)
    if getattr(size, "world_units", False):  # a fepre.SizeField: edge lengths in world units
        return lambda points: np.maximum(size(points), h)
    axes = [np.linspace(lo, hi, 32) for lo, hi in zip(*bounds)]
    grid = np.stack(np.meshgrid(*axes, indexing="ij"), axis=-1).reshape(-1, 3)
    inside = grid[model(grid) <= 0]
    smallest = float(evaluate_size(size, inside if len(inside) else grid).min())
    return lambda points: h * evaluate_size(size, points) / smallest


make_callable(__name__, features)
