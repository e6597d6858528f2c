"""fepre.distmesh: the arguments checked, the constraints built, the pipeline run."""

from __future__ import annotations

from typing import Any, Callable

import numpy as np

from ..arguments import diagonal_lengths, domain_bounds, positive_float, shown
from ..constraint_keywords import constraint_for
from ..errors import MeshingError
from ..sdf.core import SDF, require_solid_model
from .constraints import FeatureNodes, FixedPoints
from .initial_points import evaluate_size
from .loop import DistMeshState
from .options import DistMeshOptions, resolve_options
from .job import MeshingJob
from .pipeline import run_pipeline

__all__ = ["distmesh", "MAX_CELLS"]

#: largest mesh (estimated cells) fepre.distmesh starts on by default (``max_cells``); a 24 GB
#: machine holds about 17M
MAX_CELLS = DistMeshOptions.max_cells
#: memory the meshing of one cell takes, about (bytes)
BYTES_PER_CELL = 1400


def _is_dataset(value: Any) -> bool:
    import pyvista as pv

    return isinstance(value, pv.DataSet)


def _resolve_sizes(model: SDF, h: Any, size: Any, bounds: Any, regions: Any = None):
    """``(h, size, absolute)``: the smallest edge length, the size callable and whether its
    values are edge lengths (a size field) rather than relative sizes. With ``regions``, the
    automatic field is the smallest of the part's and each region's (a region thinner than the
    part, a bone's cortical shell round its core, gets the sizes its own walls need)."""
    import pyvista as pv

    from ..sizing import SizeField, size_field
    from ..sizing.under_hmin import one_warning

    if isinstance(h, (tuple, list, np.ndarray)):
        pair = np.asarray(h, dtype=object).reshape(-1)
        if pair.size != 2:
            raise ValueError(f"h must be a number or a pair (hmin, hmax); got {shown(h)}")
        with one_warning() as named:  # the part's and each region's field name a wall they share once
            field = size_field(model, pair[0], pair[1], bounds=bounds)
            if isinstance(regions, dict) and len(regions) > 1:
                own = [region if getattr(region, "within", None) is model else model & region for region in regions.values()]
                field = field.minimum(*(size_field(part, pair[0], pair[1], bounds=bounds) for part in own))
        field.unresolved = named
        if size is not None:
            field = field.minimum(_as_field(size, model, bounds) if isinstance(size, pv.DataSet) else size)
        return field.hmin, field, True
    if isinstance(size, pv.DataSet):
        size = _as_field(size, model, bounds)
    if isinstance(size, SizeField):
        if h is not None:
            size = size.clip(positive_float(h, "h"), max(size.hmax, positive_float(h, "h")))
        return size.hmin, size, True
    if h is None:
        raise ValueError("h is required (a number, or a pair (hmin, hmax) for an automatic size field) unless size is a SizeField or a background mesh")
    return positive_float(h, "h"), size, False


def _as_field(mesh, model: SDF, bounds: Any):
    """A background mesh as a size field, checked to cover the part."""
    from ..sizing import SizeField

    field = SizeField.from_mesh(mesh)
    lower, upper = (np.asarray(v, dtype=np.float64) for v in domain_bounds(model, bounds))
    axes = [np.linspace(lower[k], upper[k], 24) for k in range(3)]
    grid = np.stack(np.meshgrid(*axes, indexing="ij"), axis=-1).reshape(-1, 3)
    inside = grid[model(grid) < 0]
    uncovered = field.coverage.uncovered(inside) if len(inside) else np.zeros(0, bool)
    if uncovered.any():
        raise ValueError(
            f"the background mesh (size=) does not cover the part: {int(uncovered.sum())} of {len(inside)} probe "
            f"points inside the part lie outside it, e.g. {np.round(inside[uncovered][0], 6).tolist()}; "
            "give a mesh of the whole part"
        )
    return field


def distmesh(
    model: SDF,
    h: Any = None,
    *,
    bounds: Any = None,
    size: Any = None,
    fixed: Any = None,
    periodic: Any = None,
    regions: Any = None,
    options: DistMeshOptions | None = None,
    progress: bool = False,
    callback: Callable[[DistMeshState], object] | None = None,
    **overrides: Any,
):
    """Tetrahedral mesh of the solid ``model < 0`` by DistMesh (Persson 2004, DistMesh.jl).

    Parameters
    ----------
    model : fepre.sdf.SDF
        The solid (negative inside).
    h : float, str or (hmin, hmax)
        Target edge length (where ``size`` is smallest, for graded meshes), or ``"D/N"``: the
        diagonal of the domain's box (``bounds``, else the model's) over N, as in the command
        line's ``--h D/50``; a pair (of lengths or ``"D/N"``) meshes with
        the automatic size field :func:`fepre.size_field` ``(model, hmin, hmax)`` (fine at thin
        walls, gaps, small holes and curvature, up to ``hmax`` elsewhere). ``hmin`` is the
        smallest size that field gives: walls thinner than three ``hmin``, gaps narrower than
        ``hmin`` and sharp edges closer than ``hmin`` get ``hmin``, named in a
        :class:`fepre.ResolutionWarning` with the size each would need. Optional when
        ``size`` is a size field or a background mesh (then it clamps the sizes from below).
        With ``regions``, the field is the smallest of the part's and each region's (a
        region's thin walls get their sizes even where the part is thick).
    bounds : ((xmin, ymin, zmin), (xmax, ymax, zmax)), optional
        Box holding the solid; defaults to ``model.bounds``. Where the solid reaches through
        the box (an unbounded lattice, or part of a part), the part inside it is meshed:
        ``model & sdf.box(...)`` of the box.
    size : callable, fepre.SizeField or pyvista.DataSet, optional
        A callable ``size(points (N, 3)) -> (N,)`` gives relative edge lengths (the reference's
        ``fh``): edges are about ``h * size(x) / min(size)``. A :class:`fepre.SizeField`, or a
        background mesh with one point or cell array of sizes (e.g. from a solver's error
        estimate; it must cover the part), gives edge lengths in world units. With
        ``h=(hmin, hmax)`` it is combined with the automatic field by the smaller size.
    fixed : (M, 3) array, optional
        Points kept in the mesh that never move; they must lie in the solid (sdf <= 1e-3 h).
        They combine with the detected features (``features=True``): feature nodes closer
        than ``h/2`` to one of them are left out.
    periodic : float or (Lx, Ly, Lz), optional
        Mesh one cell of a periodic model: ``model`` is the unbounded periodic model and
        ``bounds`` the cell (default ``[0, L]``; its extents must equal the periods). fepre cuts
        the model with the cell, lays nodes on each face, edge and corner identically on its
        opposite (offset by the period, exactly) and keeps every other node off the faces. The
        mesh's field data ``periodic_lower`` and ``periodic_period`` record the cell;
        :func:`fepre.periodic_nodes` gives the node pairs, :func:`fepre.homogenize` the
        effective stiffness. Takes one ``h`` (no ``size``).
    regions : dict name -> fepre.sdf.SDF, optional
        Mesh a part made of several materials: two or more regions (e.g. ``{"skin": part -
        core, "core": core}``) that split ``model`` (no overlap, nothing left over). Each
        interface between regions is made of faces of the mesh, its nodes on the interface
        (to ``1e-3 h``; its sharp edges and the curves where it meets the part's surface
        kept); every cell lies in one region, cell data ``region_id`` indexes field data
        ``region_names``, and point data ``interface`` marks the interface nodes.
        :func:`fepre.export` writes one element set per region and each interface as a named
        face set (``interface_<a>_<b>``). ``region_names`` is a string array: ``mesh.save``
        writes it to a VTU that ParaView and PyVista read but meshio cannot (it reads no string
        arrays); ``fepre.export(mesh, "part.vtu")`` writes the names as integer field data that
        meshio reads.
    options : fepre.DistMeshOptions, optional
        Parameters of the algorithm; keyword ``overrides`` (e.g. ``deltat=0.05``) apply on top.
    progress : bool
        Print a progress line (iteration, points, worst dihedral angle, seconds) on stderr.
    callback : callable, optional
        Called with a :class:`fepre.distmesh.DistMeshState` after every iteration.

    Returns
    -------
    pyvista.UnstructuredGrid
        VTK_TETRA cells of positive volume; point data ``sdf``, ``boundary``, ``feature``
        (1 on a feature curve, 2 at a corner); cell data
        ``min_dihedral_angle``, ``max_dihedral_angle``, ``radius_ratio``, ``volume_edge_ratio``,
        ``volume``; field data ``distmesh_*`` (history per iteration: ``max_move``, ``max_dp``,
        ``min_quality``, ``mean_quality``, ``retriangulated``; totals: ``iterations``,
        ``seconds``, ``loop_seconds``, ``slivers_seconds``, ``features_seconds``,
        ``feature_nodes``, ``converged``, ``split_edges``, ``inserted_nodes``, and
        ``trimmed_cells``/``trimmed_volume``: the cells in places thinner than an element left
        out so that the cells there meet the quality targets, ``dropped_cells``/``dropped_volume``:
        the small pieces such places cut off from the rest, see ``thin_parts``).

    Warns
    -----
    fepre.ConvergenceWarning
        When the loop reaches ``maxiter``; the mesh reached so far is returned.
    fepre.FeatureWarning
        When sharp features closer together than ``h/2`` were skipped (``features=True``).

    Notes
    -----
    A part far from the origin (the centre of its box more than its largest extent away on an
    axis) is meshed near it and the grid moved back (:func:`fepre.placement.local_offset`): a
    part placed by a round translation gets the mesh it has at the origin, moved.

    Examples
    --------
    >>> import fepre
    >>> from fepre import sdf
    >>> mesh = fepre.distmesh(sdf.sphere(1.0), h=0.3)
    >>> bool((mesh["volume"] > 0).all()), 3.5 < mesh.volume < 4.19
    (True, True)
    """
    require_solid_model(model)
    offset = _frame_offset(model, bounds)
    if offset.any():
        return _in_local_frame(offset, model, h, bounds=bounds, size=size, fixed=fixed, periodic=periodic,
                               regions=regions, options=options, progress=progress, callback=callback, **overrides)
    return _mesh(model, h, bounds=bounds, size=size, fixed=fixed, periodic=periodic, regions=regions, options=options,
                 progress=progress, callback=callback, **overrides)


def _mesh(model: SDF, h: Any, *, bounds: Any, size: Any, fixed: Any, periodic: Any, regions: Any,
          options: DistMeshOptions | None, progress: bool, callback: Any, _frame: Any = None, **overrides: Any):
    """:func:`distmesh` in the frame given (``_frame``: the user's frame is this one moved by
    it; the resolution warnings add it to the places they name)."""
    job = MeshingJob(model=model, given_model=model, h=h, size=size, options=resolve_options(options, overrides),
                     bounds=bounds, progress=progress, callback=callback, keywords={"periodic": periodic, "regions": regions})
    if size is not None and not callable(size) and not _is_dataset(size):
        raise TypeError(f"size must be a callable (N, 3) -> (N,), a fepre.SizeField, a background mesh or None; got {type(size).__name__}")
    keyword_constraints = [constraint_for(key, value, job) for key, value in job.keywords.items() if value is not None]
    h = diagonal_lengths(h, *domain_bounds(model, job.bounds)) if _names_diagonal(h) else h
    job.h, job.size, job.absolute = _resolve_sizes(model, h, size, job.bounds, regions)
    for constraint in keyword_constraints:
        constraint.restrict_domain(job)
    job.lower, job.upper = (np.asarray(v, dtype=np.float64) for v in domain_bounds(job.model, job.bounds))
    extent = float((job.upper - job.lower).max())
    if job.h >= extent:
        raise ValueError(f"h={shown(job.h)} must be smaller than the domain's largest extent {extent:g}")
    if bounds is not None and not keyword_constraints:
        job.model = _cut_by_bounds(job.model, job.lower, job.upper, job.h)
    for constraint in keyword_constraints:
        constraint.check_domain(job)
    if callback is not None and not callable(callback):
        raise TypeError(f"callback must be a callable or None; got {type(callback).__name__}")
    user_fixed = FixedPoints.checked(job, fixed, keyword_constraints)
    job.user_fixed = None if user_fixed is None else user_fixed.points
    _check_sizes(job)
    job.constraints = [c for c in (user_fixed, FeatureNodes() if job.options.features else None) if c is not None]
    job.constraints += keyword_constraints
    if _frame is not None:
        job.frame_offset = np.asarray(_frame, np.float64)
    return run_pipeline(job)


def _names_diagonal(h: Any) -> bool:
    """True when ``h`` (or one of a pair) is a string: ``"D/N"``, or a mistake to name."""
    return isinstance(h, str) or (isinstance(h, (tuple, list)) and any(isinstance(value, str) for value in h))


#: faces of the bounds are sampled this many times per h (at most CUT_SAMPLES along a side)
CUT_DENSITY = 2.0
CUT_SAMPLES = 256


def _cut_by_bounds(model: SDF, lower: np.ndarray, upper: np.ndarray, h: float) -> SDF:
    """``model`` cut by the box ``lower``-``upper`` when its solid reaches through a face of
    the box, else ``model`` itself: the bounds given to an unbounded lattice, or a box round part
    of a part, mesh what lies inside them (the lattice's cells there were refused as "cells
    outside the part; try a smaller h", since its solid went on past the box)."""
    from ..sdf import box

    counts = np.clip(np.ceil((upper - lower) * CUT_DENSITY / h).astype(int) + 1, 2, CUT_SAMPLES)
    for axis in range(3):
        axes = [np.linspace(lower[k], upper[k], counts[k]) for k in range(3)]
        axes[axis] = np.array([lower[axis], upper[axis]])
        if float(model.values_on_axes(*axes, dtype=np.float64).min()) < -1e-3 * h:
            return model & box(tuple(upper - lower), center=tuple(0.5 * (lower + upper)))
    return model


def _frame_offset(model: SDF, bounds: Any) -> np.ndarray:
    """The local frame's offset (:func:`fepre.placement.local_offset`) of the box given or the
    model's own; zero when there is none yet (the argument checks will say why)."""
    from ..placement import local_offset

    try:
        lower, upper = domain_bounds(model, bounds)
    except (TypeError, ValueError):
        return np.zeros(3)
    return local_offset(lower, upper)


def _moved_region(region: Any, model: SDF, local_model: SDF, offset: np.ndarray) -> Any:
    """A region moved into the local frame; a region that lies ``within`` the part (a label
    image's, an assembly's solid: its own part for sizes and interfaces) stays within the moved
    part (else ``part & region`` doubles every evaluation, and the size field found walls 0.0008
    thick where a pin's face lies on the part's, 1e3 from the origin)."""
    if not isinstance(region, SDF):
        return region  # not a model: the region checks say so
    moved = region.translate(-offset)
    if getattr(region, "within", None) is model:
        moved.within = local_model
    return moved


def _in_local_frame(offset: np.ndarray, model: SDF, h: Any, *, bounds: Any, size: Any, fixed: Any, periodic: Any,
                    regions: Any, callback: Any, **rest: Any):
    """``distmesh`` of the part moved by ``-offset`` (every argument with it), its grid moved back.

    The model is composed with the translation, which cancels a ``translate`` of the part
    exactly; sizes, fixed points, regions and the callback's points are moved too; the output's
    points (and ``periodic_lower``) are moved back, and the user's fixed points are put back
    bit for bit. Messages naming a place name it in the user's coordinates (the note on an
    exception, the resolution warnings' ``job.frame_offset``).
    """
    import dataclasses

    from ..arguments import as_bounds
    from ..placement import moved_size, user_frame

    local_bounds = None if bounds is None else tuple(np.asarray(b, np.float64) - offset for b in as_bounds(bounds, 3, "bounds"))
    try:
        local_fixed = None if fixed is None else np.asarray(fixed, np.float64) - offset
    except (TypeError, ValueError):  # not points: the checks say so
        local_fixed, fixed = fixed, None
    local_model = model.translate(-offset)
    if isinstance(regions, dict):
        regions = {name: _moved_region(part, model, local_model, offset) for name, part in regions.items()}
    if callable(callback):
        given_callback = callback

        def callback(state):  # noqa: F811 - the user's callback sees the user's coordinates
            return given_callback(dataclasses.replace(state, points=state.points + offset))

    try:
        with user_frame(offset):  # warnings raised below name places in the user's coordinates
            grid = _mesh(local_model, h, bounds=local_bounds, size=moved_size(size, -offset),
                         fixed=local_fixed, periodic=periodic, regions=regions, callback=callback,
                         _frame=offset, **rest)
    except (ValueError, MeshingError) as exc:
        if hasattr(exc, "add_note"):  # Python 3.11
            exc.add_note(f"fepre meshed the part moved by {shown(tuple(0.0 - offset))} (fepre.placement); the "
                         "places named are in your coordinates")
        raise
    grid.points = np.asarray(grid.points) + offset
    if fixed is not None:
        from scipy.spatial import cKDTree

        distance, index = cKDTree(np.asarray(grid.points)).query(local_fixed + offset)
        exact = distance <= 1e-12 * max(float(np.abs(offset).max()), 1.0)  # rounding of (x - offset) + offset
        points = np.asarray(grid.points).copy()
        points[index[exact]] = np.asarray(fixed, np.float64)[exact]
        grid.points = points
    if "periodic_lower" in grid.field_data:
        grid.field_data["periodic_lower"] = np.asarray(grid.field_data["periodic_lower"]) + offset
    return grid


def _check_sizes(job: MeshingJob) -> None:
    """The size function answers, and the mesh's estimated cells stay under ``max_cells``."""
    from ..sampling import _format_bytes
    from ..sizing.estimate import estimated_cells

    if job.size is not None:
        evaluate_size(job.size, np.stack([job.lower, 0.5 * (job.lower + job.upper), job.upper]))
    limit = job.options.max_cells
    expected = estimated_cells(job.model, job.size, job.h, job.lower, job.upper, job.absolute, ceiling=limit)
    if expected > limit:
        advice = "a larger hmin or hmax" if job.absolute else "a larger h (or h=(hmin, hmax) for a graded mesh)"
        raise ValueError(
            f"the mesh would have about {expected:,.0f} cells, more than max_cells = {limit:,} (CLI: --max-cells); "
            f"meshing takes about 1.4 KB of memory per cell, {_format_bytes(expected * BYTES_PER_CELL)} for this one; "
            f"use {advice}, or raise max_cells if the machine has the memory"
        )

