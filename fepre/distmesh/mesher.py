"""fepre.distmesh: argument checks, initial points, the loop, the final mesh."""

from __future__ import annotations

import time
from typing import Any, Callable

import numpy as np

from ..arguments import as_points, domain_bounds, positive_float
from ..errors import ConvergenceWarning, FeatureWarning, MeshingError, ResolutionWarning, warn_user
from ..features import features as detect_features
from ..sdf.core import SDF
from .estimate import StageLog
from .feature_protection import FeatureProtection
from .finalize import final_mesh
from .initial_points import evaluate_size, initial_points
from .loop import DistMeshState, iterate
from .options import DistMeshOptions, resolve_options
from .output import to_grid

__all__ = ["distmesh", "MAX_CELLS"]

#: largest mesh (estimated cells) fepre.distmesh starts on; a 24 GB machine holds about 17M
MAX_CELLS = 20_000_000


def _is_dataset(value: Any) -> bool:
    import pyvista as pv

    return isinstance(value, pv.DataSet)


def _check_domain(model: SDF, lower: np.ndarray, upper: np.ndarray, h: float) -> None:
    """Called when no lattice point fell inside: tell an empty domain from a too-large h."""
    axes = [np.linspace(lower[k], upper[k], 48) for k in range(3)]
    if float(model.values_on_axes(*axes, dtype=np.float64).min()) >= 0:
        raise MeshingError(
            f"the model's negative region misses the bounds {(tuple(lower), tuple(upper))}: "
            "nothing to mesh (check the model's sign and the bounds)"
        )
    raise ValueError(f"h={h!r} is too large for the domain: fewer than 4 points fit inside; use a smaller h")


def _resolve_sizes(model: SDF, h: Any, size: Any, bounds: Any):
    """``(h, size, absolute)``: the smallest edge length, the size callable and whether its
    values are edge lengths (a size field) rather than relative sizes."""
    import pyvista as pv

    from ..sizing import SizeField, size_field

    if isinstance(h, (tuple, list, np.ndarray)):
        pair = np.asarray(h, dtype=object).reshape(-1)
        if pair.size != 2:
            raise ValueError(f"h must be a number or a pair (hmin, hmax); got {h!r}")
        field = size_field(model, pair[0], pair[1], bounds=bounds)
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
    h : float or (hmin, hmax)
        Target edge length (where ``size`` is smallest, for graded meshes); a pair meshes with
        the automatic size field :func:`fepre.size_field` ``(model, hmin, hmax)`` (fine at thin
        walls, gaps, small holes and curvature, up to ``hmax`` elsewhere). Optional when
        ``size`` is a size field or a background mesh (then it clamps the sizes from below).
    bounds : ((xmin, ymin, zmin), (xmax, ymax, zmax)), optional
        Box holding the solid; defaults to ``model.bounds``.
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
        face set (``interface_<a>_<b>``).
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
    o = resolve_options(options, overrides)
    if size is not None and not callable(size) and not _is_dataset(size):
        raise TypeError(f"size must be a callable (N, 3) -> (N,), a fepre.SizeField, a background mesh or None; got {type(size).__name__}")
    if periodic is not None and (size is not None or isinstance(h, (tuple, list, np.ndarray))):
        raise ValueError("periodic meshes take one h (a number); size= and h=(hmin, hmax) are not supported with periodic=")
    if periodic is not None and regions is not None:
        raise ValueError("periodic= and regions= cannot be combined yet; mesh the periodic cell of one material")
    if periodic is not None and bounds is None:
        from ..periodic.cell import periodic_cell

        bounds = (tuple(np.zeros(3)), tuple(np.broadcast_to(periodic_cell(periodic, None).period, 3)))
    h, size, absolute = _resolve_sizes(model, h, size, bounds)
    cell = None
    if periodic is not None:
        from ..periodic.cell import check_periodic_model, periodic_cell

        cell = periodic_cell(periodic, bounds)
        check_periodic_model(model, cell, h)
        periodic_model, model = model, cell.solid(model)
        bounds = (tuple(cell.lower), tuple(cell.upper))
    lower, upper = (np.asarray(v, dtype=np.float64) for v in domain_bounds(model, bounds))
    extent = float((upper - lower).max())
    if h >= extent:
        raise ValueError(f"h={h!r} must be smaller than the domain's largest extent {extent:g}")
    region_set = None
    if regions is not None:
        from ..regions import region_set as checked_regions

        region_set = checked_regions(regions, model, h, lower, upper)
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
        if cell is not None and cell.on_planes(fixed_points, cell.tolerance(h)).any():
            raise ValueError("fixed points must not lie on the faces of the periodic cell (fepre lays the periodic face nodes itself)")
    if size is not None:
        evaluate_size(size, np.stack([lower, 0.5 * (lower + upper), upper]))
    from ..sizing.estimate import estimated_cells

    expected = estimated_cells(model, size, h, lower, upper, absolute, ceiling=MAX_CELLS)
    if expected > MAX_CELLS:
        advice = "a larger hmin or hmax" if absolute else "a larger h (or h=(hmin, hmax) for a graded mesh)"
        raise ValueError(
            f"the mesh would have about {expected:,.0f} cells, more than fepre.distmesh.mesher.MAX_CELLS = "
            f"{MAX_CELLS:,} (about 1.4 KB of memory each); use {advice}, or raise MAX_CELLS if the machine has the memory"
        )

    t0 = time.perf_counter()
    found = None
    periodic_count = 0
    if cell is not None:
        from ..periodic.boundary_nodes import boundary_nodes

        face_nodes = boundary_nodes(periodic_model, cell, h, seed=o.seed)
        periodic_count = len(face_nodes)
        fixed_points = np.concatenate([face_nodes, fixed_points])
    if region_set is not None:
        from ..regions import interface_nodes

        if o.features:  # the part's features, laid on the interfaces too
            found = detect_features(model, h, angle=o.feature_angle, bounds=(lower, upper), size=size, warn=False)
        on_interface, interface_triangles, interface_inner = interface_nodes(
            model, region_set, h, (lower, upper), o, progress, part_features=found)
        if len(fixed_points) and len(on_interface):  # a fixed point on an interface stands for its node
            from scipy.spatial import cKDTree

            distance, _ = cKDTree(fixed_points).query(on_interface)
            on_interface = on_interface[distance > 1e-9 * h]
        fixed_points = np.concatenate([on_interface, fixed_points])
        from ..regions.protection import InterfaceProtection

        guard = InterfaceProtection(interface_triangles, interface_inner, region_set.region_of)
    protection, feature_nodes = None, 0
    if o.features:
        if found is None:
            found = detect_features(model, h, angle=o.feature_angle, bounds=(lower, upper), size=size, warn=False)
        # a periodic cell's faces get their own nodes: warn only of the model's own features
        skipped = found.skipped if cell is None else detect_features(
            periodic_model, h, angle=o.feature_angle, bounds=(lower, upper), size=size, warn=False).skipped
        for message in skipped:
            warn_user(f"distmesh: {message}", FeatureWarning)
        if found:
            nodes = found.nodes
            if cell is not None:  # the face nodes stand for the features on the cell's faces
                nodes = nodes[~cell.on_planes(nodes, 1e-3 * h).any(axis=1)]
            feature_nodes = len(nodes)
            if len(fixed_points) and len(nodes):
                from scipy.spatial import cKDTree

                distance, _ = cKDTree(fixed_points).query(nodes)
                nodes = nodes[distance >= 0.5 * h]
            fixed_points = np.concatenate([fixed_points, nodes])
            protection = FeatureProtection(found, model, h)
    features_seconds = time.perf_counter() - t0

    rng = np.random.default_rng(o.seed)
    points = initial_points(
        model, lower, upper, h, o.distribution, o.geps * h, o.jitter, size, fixed_points, rng, o.boundary_layer,
        absolute=absolute,
    )
    if protection is not None:
        free = np.arange(len(points)) >= len(fixed_points)
        points = points[~(free & protection.inside(points))]
    protect = None if protection is None else protection.push
    if cell is not None:
        from ..periodic.cell import FACE_MARGIN, compose

        free = np.arange(len(points)) >= len(fixed_points)
        near_face = (np.minimum(points - cell.lower, cell.upper - points) < FACE_MARGIN * h).any(axis=1)
        points = points[~(free & near_face)]
        protect = compose(protect, cell.keep_off_faces(FACE_MARGIN * h))
    if region_set is not None:
        from ..periodic.cell import compose

        free = np.arange(len(points)) >= len(fixed_points)
        points = points[~(free & guard.inside(points))]
        protect = compose(protect, guard.push)
    if len(points) - len(fixed_points) < 4:
        _check_domain(model, lower, upper, h)
    fixed_mask = np.zeros(len(points), bool)
    fixed_mask[: len(fixed_points)] = True

    loop = iterate(model, h, points, fixed_mask, size, o, progress=progress, callback=callback,
                   protect=protect, local_size=size if absolute else None)
    stage_log = StageLog(progress, loop.timings["forces"] / max(loop.iterations, 1))  # the final mesh starts now
    # the loop's last triangulation goes to the final mesh only (90 MB at 2.6M cells)
    previous, loop.delaunay_tets = (loop.delaunay_tets if loop.moved_since_delaunay < o.ttol * h else None), None
    if region_set is None:
        points, tets, fixed_mask = final_mesh(model, loop.points, loop.fixed_mask, h, o.geps, o.delaunay, previous)
    else:
        from ..regions.conform import final_region_mesh
        from ..regions.protection import drop_protected

        loop_points, loop_fixed, dropped = drop_protected(model, loop.points, loop.fixed_mask, guard, h)
        points, tets, fixed_mask, region_ids, repaired, crossing = final_region_mesh(
            model, loop_points, loop_fixed, h, o.geps, o.delaunay, previous if dropped == 0 else None, region_set,
            kept=np.concatenate([on_interface] + ([] if fixed is None else [as_points(fixed, 3, "fixed")[0]])))
    del previous
    loop_seconds = time.perf_counter() - start
    stage_log("final mesh", f"{len(points):,} nodes, {len(tets):,} cells")
    interface_mask = None
    if region_set is not None:
        from ..regions.interface import interface_node_mask

        if crossing.any():
            raise MeshingError(
                f"distmesh: {int(crossing.sum())} cell(s) cross an interface between regions after dropping "
                f"{repaired} node(s) near it (e.g. at {np.round(points[tets[crossing][0]].mean(axis=0), 6).tolist()}: "
                f"a gap or wedge of the part thinner than h next to an interface); the interfaces are not "
                f"resolved at h={h:g} (try a smaller h)"
            )
        interface_mask = interface_node_mask(tets, region_ids, len(points))

    sliver_seconds = 0.0
    if o.slivers:
        from .slivers import improve_arrays

        t0 = time.perf_counter()
        from .improve_mesh import stage_pins

        pinned = stage_pins(points, tets, fixed_mask, None if fixed is None else as_points(fixed, 3, "fixed")[0], model, h)
        try:
            locked = None if cell is None else cell.on_planes(points, cell.tolerance(h)).any(axis=1)
            if region_set is not None:
                from ..regions.conform import region_quality_stage

                points, tets, region_ids = region_quality_stage(
                    points, tets, region_ids, region_set, model, h, pinned, interface_mask, o.seed, size)
            else:
                points, tets, _ = improve_arrays(points, tets, model, h, fixed_mask=pinned, size=size, seed=o.seed, locked=locked)
        except MeshingError as exc:
            # the stage checks its own result and refuses it; the loop's mesh is valid
            warn_user(
                f"the quality stage (slivers=True) failed and was skipped: {exc}; returning the "
                "DistMesh mesh without it",
                ConvergenceWarning,
            )
        if cell is not None:
            from ..periodic.face_smoothing import smooth_face_nodes
            from .tet_shape import ShapeTargets

            points, moves = smooth_face_nodes(points, tets, cell, periodic_model, h, ShapeTargets(), seed=o.seed)
            if moves:  # the cells around the moved face nodes may now be improved further
                try:
                    points, tets, _ = improve_arrays(points, tets, model, h, fixed_mask=pinned, size=size, seed=o.seed, locked=locked)
                except MeshingError:
                    pass
        sliver_seconds = time.perf_counter() - t0
        if progress:
            from ..quality import tet_quality

            measured = tet_quality(points, tets)
            stage_log.started = t0
            stage_log("quality stage", f"worst dihedral {measured['min_dihedral_angle'].min():.1f} deg, largest "
                      f"{measured['max_dihedral_angle'].max():.1f} deg, smallest radius ratio "
                      f"{measured['radius_ratio'].min():.3f}")

    from .lost_material import added_material_message, lost_material_message, material_checks

    local = size if absolute else None
    lost, added = material_checks(model, points, tets, h, local) if o.check_resolution else ([], [])
    if lost:
        warn_user(f"distmesh: {lost_material_message(lost, None if absolute else h)}", ResolutionWarning)
    if added:
        warn_user(f"distmesh: {added_material_message(added, None if absolute else h)}", ResolutionWarning)
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
    if cell is not None:
        from ..periodic.nodes import match_faces

        *_, unpaired = match_faces(points, cell, cell.tolerance(h), model, h)  # MeshingError: a node off the surface
        if unpaired.size:
            warn_user(
                f"distmesh: {unpaired.size} node(s) on the rim of the periodic cell's faces have no partner on the "
                "opposite face (the mesh kept their cells on one face only); they are left unconstrained",
                ResolutionWarning,
            )
        history.update(periodic_nodes=np.array([periodic_count]), periodic_unpaired=np.array([unpaired.size]))
    if region_set is not None:
        from ..regions.conform import check_interfaces

        interface_faces, _ = check_interfaces(points, tets, region_ids, region_set, model, h)  # MeshingError
        history.update(interface_faces=np.array([len(interface_faces)]), interface_nodes_dropped=np.array([repaired]))
    grid = to_grid(points, tets, model, history, found)
    if region_set is not None:
        grid.cell_data["region_id"] = region_ids
        grid.field_data["region_names"] = np.array(region_set.names)
        grid.point_data["interface"] = interface_node_mask(tets, region_ids, len(points)).astype(np.uint8)
    if cell is not None:
        grid.field_data["periodic_lower"] = cell.lower
        grid.field_data["periodic_period"] = cell.period
    stage_log("checks and output", f"{grid.n_points:,} nodes, {grid.n_cells:,} cells, {time.perf_counter() - start:.1f} s in all")
    if not loop.converged:
        warn_user(
            f"distmesh stopped at maxiter={o.maxiter} before meeting its tolerance "
            f"(last interior move {loop.history['max_dp'][-1]:.3g} h > ptol={o.ptol:g}); returning the mesh reached",
            ConvergenceWarning,
        )
    return grid
