"""fepre.distmesh: argument checks, initial points, the loop, the final mesh."""

from __future__ import annotations

import sys
import time
from typing import Any, Callable

import numpy as np

from ..arguments import as_points, domain_bounds, positive_float
from ..errors import ConvergenceWarning, FeatureWarning, MeshingError, ResolutionWarning, warn_user
from ..features import features as detect_features
from ..sdf.core import SDF
from .feature_protection import FeatureProtection
from .finalize import final_mesh
from .initial_points import evaluate_size, initial_points
from .loop import DistMeshState, iterate
from .options import DistMeshOptions, resolve_options
from .output import to_grid

__all__ = ["distmesh"]


def _check_domain(model: SDF, lower: np.ndarray, upper: np.ndarray, h: float) -> None:
    """Called when no lattice point fell inside: tell an empty domain from a too-large h."""
    axes = [np.linspace(lower[k], upper[k], 48) for k in range(3)]
    if float(model.values_on_axes(*axes, dtype=np.float64).min()) >= 0:
        raise MeshingError(
            f"the model's negative region misses the bounds {(tuple(lower), tuple(upper))}: "
            "nothing to mesh (check the model's sign and the bounds)"
        )
    raise ValueError(f"h={h!r} is too large for the domain: fewer than 4 points fit inside; use a smaller h")


def distmesh(
    model: SDF,
    h: float,
    *,
    bounds: Any = None,
    size: Callable[[np.ndarray], np.ndarray] | None = None,
    fixed: Any = None,
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
    h : float
        Target edge length (where ``size`` is smallest, for graded meshes).
    bounds : ((xmin, ymin, zmin), (xmax, ymax, zmax)), optional
        Box holding the solid; defaults to ``model.bounds``.
    size : callable, optional
        Relative edge length ``size(points (N, 3)) -> (N,)`` (the reference's ``fh``): edges are
        about ``h * size(x) / min(size)``.
    fixed : (M, 3) array, optional
        Points kept in the mesh that never move; they must lie in the solid (sdf <= 1e-3 h).
        They combine with the detected features (``features=True``): feature nodes closer
        than ``h/2`` to one of them are left out.
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
        ``feature_nodes``, ``converged``).

    Warns
    -----
    fepre.ConvergenceWarning
        When the loop reaches ``maxiter``; the mesh reached so far is returned.
    fepre.FeatureWarning
        When sharp features closer together than ``h/2`` were skipped (``features=True``).

    Examples
    --------
    >>> import fepre
    >>> from fepre import sdf
    >>> mesh = fepre.distmesh(sdf.sphere(1.0), h=0.3)
    >>> bool((mesh["volume"] > 0).all()), 3.5 < mesh.volume < 4.19
    (True, True)
    """
    start = time.perf_counter()
    if not isinstance(model, SDF) or model.dim != 3:
        raise TypeError(f"model must be a 3D fepre.sdf.SDF; got {type(model).__name__}")
    h = positive_float(h, "h")
    o = resolve_options(options, overrides)
    lower, upper = (np.asarray(v, dtype=np.float64) for v in domain_bounds(model, bounds))
    extent = float((upper - lower).max())
    if h >= extent:
        raise ValueError(f"h={h!r} must be smaller than the domain's largest extent {extent:g}")
    if size is not None and not callable(size):
        raise TypeError(f"size must be a callable (N, 3) -> (N,) or None; got {type(size).__name__}")
    if callback is not None and not callable(callback):
        raise TypeError(f"callback must be a callable or None; got {type(callback).__name__}")
    if fixed is None:
        fixed_points = np.zeros((0, 3))
    else:
        fixed_points, _ = as_points(fixed, 3, "fixed")
        values = model(fixed_points)
        outside = values > 1e-3 * h
        if outside.any():
            raise ValueError(
                f"fixed points must lie in the domain (sdf <= 1e-3 h); point {fixed_points[outside][0].tolist()} "
                f"has sdf {values[outside][0]:.4g}"
            )
        if len(np.unique(fixed_points, axis=0)) != len(fixed_points):
            raise ValueError("fixed must not contain duplicate points")
    if size is not None:
        evaluate_size(size, np.stack([lower, 0.5 * (lower + upper), upper]))

    t0 = time.perf_counter()
    found, protection, feature_nodes = None, None, 0
    if o.features:
        found = detect_features(model, h, angle=o.feature_angle, bounds=(lower, upper), size=size, warn=False)
        for message in found.skipped:
            warn_user(f"distmesh: {message}", FeatureWarning)
        if found:
            nodes = found.nodes
            feature_nodes = len(nodes)
            if len(fixed_points):
                from scipy.spatial import cKDTree

                distance, _ = cKDTree(fixed_points).query(nodes)
                nodes = nodes[distance >= 0.5 * h]
            fixed_points = np.concatenate([fixed_points, nodes])
            protection = FeatureProtection(found, model, h)
    features_seconds = time.perf_counter() - t0

    rng = np.random.default_rng(o.seed)
    points = initial_points(
        model, lower, upper, h, o.distribution, o.geps * h, o.jitter, size, fixed_points, rng, o.boundary_layer
    )
    if protection is not None:
        free = np.arange(len(points)) >= len(fixed_points)
        points = points[~(free & protection.inside(points))]
    if len(points) - len(fixed_points) < 4:
        _check_domain(model, lower, upper, h)
    fixed_mask = np.zeros(len(points), bool)
    fixed_mask[: len(fixed_points)] = True

    loop = iterate(model, h, points, fixed_mask, size, o, progress=progress, callback=callback,
                   protect=None if protection is None else protection.push)
    previous = loop.delaunay_tets if loop.moved_since_delaunay < o.ttol * h else None
    points, tets, fixed_mask = final_mesh(model, loop.points, loop.fixed_mask, h, o.geps, o.delaunay, previous)
    loop_seconds = time.perf_counter() - start

    sliver_seconds = 0.0
    if o.slivers:
        from .slivers import improve_arrays

        t0 = time.perf_counter()
        from .improve_mesh import stage_pins

        pinned = stage_pins(points, tets, fixed_mask, None if fixed is None else as_points(fixed, 3, "fixed")[0], model, h)
        try:
            points, tets, _ = improve_arrays(points, tets, model, h, fixed_mask=pinned, size=size, seed=o.seed)
        except MeshingError as exc:
            # the stage checks its own result and refuses it; the loop's mesh is valid
            warn_user(
                f"the quality stage (slivers=True) failed and was skipped: {exc}; returning the "
                "DistMesh mesh without it",
                ConvergenceWarning,
            )
        sliver_seconds = time.perf_counter() - t0
        if progress:
            from ..quality import tet_quality

            measured = tet_quality(points, tets)
            sys.stderr.write(
                f"distmesh: quality stage: worst dihedral {measured['min_dihedral_angle'].min():.1f} deg, "
                f"largest {measured['max_dihedral_angle'].max():.1f} deg, smallest radius ratio "
                f"{measured['radius_ratio'].min():.3f}  {sliver_seconds:7.2f} s\n"
            )
            sys.stderr.flush()

    from .lost_material import added_material, added_material_message, lost_material, lost_material_message

    lost = lost_material(model, points, tets, h) if o.check_resolution else []
    if lost:
        warn_user(f"distmesh: {lost_material_message(lost, h)}", ResolutionWarning)
    added = added_material(model, points, tets, h) if o.check_resolution else []
    if added:
        warn_user(f"distmesh: {added_material_message(added, h)}", ResolutionWarning)
    history = dict(loop.history)
    history.update(
        iterations=np.array([loop.iterations]),
        converged=np.array([int(loop.converged)]),
        triangulations=np.array([loop.triangulations]),
        loop_seconds=np.array([loop_seconds]),
        slivers_seconds=np.array([sliver_seconds]),
        features_seconds=np.array([features_seconds]),
        feature_nodes=np.array([feature_nodes]),
        lost_volume=np.array([sum(region.volume for region in lost) if o.check_resolution else np.nan]),
        added_volume=np.array([sum(region.volume for region in added) if o.check_resolution else np.nan]),
        seconds=np.array([time.perf_counter() - start]),
    )
    grid = to_grid(points, tets, model, history, found)
    if not loop.converged:
        warn_user(
            f"distmesh stopped at maxiter={o.maxiter} before meeting its tolerance "
            f"(last interior move {loop.history['max_dp'][-1]:.3g} h > ptol={o.ptol:g}); returning the mesh reached",
            ConvergenceWarning,
        )
    return grid
