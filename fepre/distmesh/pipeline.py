"""The mesher as a pipeline: named stages, each a function of one :class:`MeshingJob`.

``constraint_nodes -> starting_points -> run_loop -> make_final_mesh -> quality_stage ->
validate_mesh -> check_mesh -> output_grid``; every stage consults the job's constraints
(:class:`~fepre.distmesh.constraints.MeshConstraint`) and never names one.
"""

from __future__ import annotations

import time
from dataclasses import replace

import numpy as np

from ..arguments import shown
from ..errors import ConvergenceWarning, MeshingError, ResolutionWarning, warn_user
from ..sdf.core import SDF
from .constraints import compose
from .estimate import StageLog
from .finalize import final_mesh
from .initial_points import initial_points
from .job import MeshingJob
from .loop import iterate
from .output import to_grid

__all__ = ["MeshingJob", "STAGES", "run_pipeline", "constraint_nodes", "starting_points", "run_loop",
           "make_final_mesh", "quality_stage", "validate_mesh", "check_mesh", "output_grid",
           "fill_surface_gaps", "removable_nodes", "local_size", "relative_size"]  # the last four: for constraints


def _check_domain(model: SDF, lower: np.ndarray, upper: np.ndarray, h: float) -> None:
    """Called when no lattice point fell inside: tell an empty domain from a too-large h."""
    axes = [np.linspace(lower[k], upper[k], 48) for k in range(3)]
    if float(model.values_on_axes(*axes, dtype=np.float64).min()) >= 0:
        raise MeshingError(
            f"the model's negative region misses the bounds {(tuple(lower), tuple(upper))}: "
            "nothing to mesh (check the model's sign and the bounds)"
        )
    raise ValueError(f"h={shown(h)} is too large for the domain: fewer than 4 points fit inside; use a smaller h")


def constraint_nodes(job: MeshingJob) -> None:
    """The fixed nodes: each constraint's in front of those laid before it, then the yielding
    ones (feature nodes) after all of them."""
    started = time.perf_counter()
    fixed = np.zeros((0, 3))
    for constraint in job.constraints:
        fixed = np.concatenate([constraint.fixed_nodes(job, fixed), fixed])
    for constraint in job.constraints:
        fixed = np.concatenate([fixed, constraint.yielding_nodes(job, fixed)])
    job.points, job.fixed_count = fixed, len(fixed)
    job.seconds["features"] = time.perf_counter() - started


def starting_points(job: MeshingJob) -> None:
    """The loop's starting points (the fixed nodes first), less those the constraints drop."""
    o, h = job.options, job.h
    fixed = job.points
    rng = np.random.default_rng(o.seed)
    points = initial_points(
        job.model, job.lower, job.upper, h, o.distribution, o.geps * h, o.jitter, job.size, fixed, rng,
        o.boundary_layer, absolute=job.absolute,
    )
    for constraint in job.constraints:
        drop = constraint.drop_starting(job, points)
        if drop is not None:
            free = np.arange(len(points)) >= job.fixed_count
            points = points[~(free & drop)]
        job.protect = compose(job.protect, constraint.push(job))
    if len(points) - job.fixed_count < 4:
        _check_domain(job.model, job.lower, job.upper, h)
    job.points = points
    job.fixed_mask = np.zeros(len(points), bool)
    job.fixed_mask[: job.fixed_count] = True


def run_loop(job: MeshingJob) -> None:
    """The DistMesh loop; hands its last triangulation on when the points barely moved since."""
    o = job.options
    loop = iterate(job.model, job.h, job.points, job.fixed_mask, job.size, o, progress=job.progress,
                   callback=job.callback, protect=job.protect, local_size=job.size if job.absolute else None)
    job.stage_log = StageLog(job.progress, loop.timings["forces"] / max(loop.iterations, 1))  # the final mesh starts now
    # the loop's last triangulation goes to the final mesh only (90 MB at 2.6M cells)
    job.previous, loop.delaunay_tets = (loop.delaunay_tets if loop.moved_since_delaunay < o.ttol * job.h else None), None
    job.loop = loop


def make_final_mesh(job: MeshingJob) -> None:
    """The final triangulation of the loop's points, by a constraint or by default."""
    o, loop = job.options, job.loop
    if not any(constraint.final_mesh(job) for constraint in job.constraints):
        job.points, job.tets, job.fixed_mask = final_mesh(
            job.model, loop.points, loop.fixed_mask, job.h, o.geps, o.delaunay, job.previous, job.size, job.absolute)
    job.previous = None
    job.seconds["loop"] = time.perf_counter() - job.started
    job.stage_log("final mesh", f"{len(job.points):,} nodes, {len(job.tets):,} cells")


def _either(*masks: np.ndarray | None) -> np.ndarray | None:
    """The union of the masks given (None: none given)."""
    given = [mask for mask in masks if mask is not None]
    return np.logical_or.reduce(given) if len(given) > 1 else (given[0] if given else None)


def quality_stage(job: MeshingJob) -> None:
    """Slivers out and shapes improved (``slivers=True``), with the nodes the stage must keep."""
    from .improve_mesh import stage_pins
    from .slivers import improve_arrays

    o, h = job.options, job.h
    job.seconds["slivers"] = 0.0
    if not o.slivers:
        return
    started = time.perf_counter()
    job.unimproved = (job.points, job.tets, job.fixed_mask)  # what validate_mesh falls back on
    if _default_quality_stage(job) and not any(c.locked_nodes(job) is not None for c in job.constraints):
        recover_crease_segments(job)
        fill_surface_gaps(job)
    pinned = stage_pins(job.points, job.tets, job.fixed_mask, job.user_fixed, job.model, h)
    pinned = _either(pinned, *(constraint.pinned_nodes(job) for constraint in job.constraints))
    locked = _either(*(constraint.locked_nodes(job) for constraint in job.constraints))
    try:
        if not any(constraint.quality_stage(job, pinned, locked) for constraint in job.constraints):
            if locked is None and _default_quality_stage(job):
                from .insertion_stage import stage_with_insertions

                stage_with_insertions(job, pinned, removable_nodes, local_size(job))
            else:
                job.points, job.tets, _ = improve_arrays(
                    job.points, job.tets, job.model, h, fixed_mask=pinned, size=job.size, seed=o.seed, locked=locked,
                    collapse=removable_nodes(job), local_size=local_size(job))
            if locked is None:
                recover_crease_segments(job, flips=False)  # cells the stage left in a crease's corner
            _drop_unused_nodes(job)
    except MeshingError as exc:
        # the stage checks its own result and refuses it; the loop's mesh is valid
        warn_user(
            f"the quality stage (slivers=True) failed and was skipped: {exc}; returning the "
            "DistMesh mesh without it",
            ConvergenceWarning,
        )
    for constraint in job.constraints:
        constraint.after_quality_stage(job, pinned, locked)
    job.seconds["slivers"] = time.perf_counter() - started
    if job.progress:
        from ..quality import tet_quality

        measured = tet_quality(job.points, job.tets)
        job.stage_log.started = started
        job.stage_log("quality stage", f"worst dihedral {measured['min_dihedral_angle'].min():.1f} deg, largest "
                      f"{measured['max_dihedral_angle'].max():.1f} deg, smallest radius ratio "
                      f"{measured['radius_ratio'].min():.3f}")


def local_size(job: MeshingJob):
    """The graded mesh's edge length at points, in units of length (None when uniform)."""
    if job.size is None:
        return None
    if job.absolute:
        return job.size
    return lambda x: job.h * np.asarray(job.size(x), dtype=float)


def relative_size(job: MeshingJob):
    """The graded mesh's size at points over ``h`` (None when uniform)."""
    if job.size is None:
        return None
    if job.absolute:
        return lambda x: job.size(x) / job.h
    return job.size


def fill_surface_gaps(job: MeshingJob, locked: np.ndarray | None = None) -> None:
    """Long boundary edges split at their midpoints on the zero set (new free nodes appended):
    the gaps a faceted surface leaves in the boundary nodes, which no vertex move repairs. No
    edge between two ``locked`` nodes is split (a region mesh's interface nodes)."""
    from .surface_refine import split_long_boundary_edges

    job.points, job.tets, split = split_long_boundary_edges(job.points, job.tets, job.model, job.h, relative_size(job),
                                                            locked=locked)
    if split:
        job.fixed_mask = np.concatenate([job.fixed_mask, np.zeros(split, dtype=bool)])
    job.split_edges = split


def recover_crease_segments(job: MeshingJob, flips: bool = True) -> None:
    """Boundary edges that cut across a concave crease flipped onto the crease segment they hide,
    or their lone cells removed (:mod:`fepre.distmesh.crease_recovery`)."""
    from .crease_recovery import recover_creases

    job.tets, changed = recover_creases(job.points, job.tets, job.model, job.features, job.h, flips=flips)
    job.crease_flips += changed


def removable_nodes(job: MeshingJob) -> np.ndarray:
    """The nodes an edge collapse may remove: every node but the user's fixed points and the
    feature corners (a feature curve's node only into another node on a crease)."""
    from .output import feature_flags

    removable = ~job.fixed_mask | (feature_flags(job.points, job.features) == 1)
    if job.user_fixed is not None and len(job.user_fixed):
        from scipy.spatial import cKDTree

        distance, index = cKDTree(job.points).query(np.asarray(job.user_fixed, dtype=np.float64))
        removable[index[distance <= 1e-9 * job.h]] = False
    return removable


def _drop_unused_nodes(job: MeshingJob) -> None:
    """Nodes in no cell (the quality stage's edge collapses leave them) removed, the rest renumbered."""
    used = np.zeros(len(job.points), dtype=bool)
    used[job.tets.ravel()] = True
    if used.all():
        return
    number = np.cumsum(used) - 1
    job.points, job.tets, job.fixed_mask = job.points[used], number[job.tets], job.fixed_mask[used]


def _default_quality_stage(job: MeshingJob) -> bool:
    """True when no constraint changes the quality stage (its result can be set aside alone)."""
    from .constraints import MeshConstraint

    return all(type(c).quality_stage is MeshConstraint.quality_stage
               and type(c).after_quality_stage is MeshConstraint.after_quality_stage for c in job.constraints)


def validate_mesh(job: MeshingJob) -> None:
    """Never an invalid mesh: the mesh is checked (:func:`~fepre.distmesh.validate.mesh_defects`:
    positive cells, faces used once or twice from opposite sides, a closed oriented boundary near
    the zero set that does not cross itself, the model's volume); a mesh the quality stage made
    invalid is replaced by the final mesh it started from (with a ConvergenceWarning), and a mesh
    that stays invalid raises MeshingError naming each check failed, how far and where."""
    from .validate import defects_message, mesh_defects

    started = time.perf_counter()

    reuse: dict = {}

    def defects():
        found = mesh_defects(job.points, job.tets, job.model, job.h, job.size, job.absolute, (job.lower, job.upper),
                             found=reuse)
        for constraint in job.constraints:
            found += constraint.defects(job)
        return found

    found = defects()
    if found and job.unimproved is not None and _default_quality_stage(job):
        after = defects_message(found, job.frame_offset)
        job.points, job.tets, job.fixed_mask = job.unimproved
        found = defects()
        if not found:
            warn_user(f"the quality stage (slivers=True) made the mesh invalid ({after}); returning the DistMesh "
                      "mesh without it", ConvergenceWarning)
    job.unimproved = None
    if found:
        raise MeshingError(f"distmesh: the mesh is not a valid solid and was not returned: "
                           f"{defects_message(found, job.frame_offset)}; {_smaller_h(job, found)}")
    job.boundary = (job.tets, reuse["boundary_faces"])  # for the output, if the cells stay the same
    job.seconds["validate"] = time.perf_counter() - started


def drop_fragments(job: MeshingJob) -> None:
    """Pieces of a plain mesh under ``SMALL_PIECE`` of its cells that the model joins to the rest
    dropped (:func:`~fepre.distmesh.pieces.cut_off_fragments`), unless ``thin_parts="keep"``;
    ``check_mesh`` names them."""
    from .constraints import FeatureNodes, FixedPoints

    o = job.options
    if not o.check_resolution or o.thin_parts == "keep" or not all(isinstance(c, (FixedPoints, FeatureNodes))
                                                                    for c in job.constraints):
        return
    from .pieces import cut_off_fragments
    from .thin_cells import sizes_at

    keep = None
    if job.user_fixed is not None and len(job.user_fixed):
        from scipy.spatial import cKDTree

        distance, nearest = cKDTree(job.points).query(np.asarray(job.user_fixed, float) - job.frame_offset)
        keep = np.zeros(len(job.points), bool)
        keep[nearest[distance <= 1e-6 * job.h]] = True
    kept, job.fragments = cut_off_fragments(job.points, job.tets, job.model, sizes_at(job.points, job.h, local_size(job)),
                                            keep)
    if job.fragments.cells:
        job.tets = job.tets[kept]
        _drop_unused_nodes(job)


def _smaller_h(job: MeshingJob, found: list) -> str:
    """What to try when the mesh is refused: where the volume is off, the parts thinner than
    ``h`` that the mesh left out and the gaps narrower than ``h`` that it filled, the larger
    first, each with the ``h`` (or ``h=(hmin, hmax)``) that resolves it."""
    from .lost_material import added_material_message, lost_material_message

    if not job.options.check_resolution or not any(defect.check == "volume" for defect in found):
        return "try a smaller h"
    lost, added = _material_checks(job)
    h = None if job.absolute else job.h
    parts = [(sum(r.volume for r in lost), lost_material_message(lost, h))] if lost else []
    if added:  # an assembly of bodies a little apart came out 22% over with advice about lost parts
        parts.append((sum(r.volume for r in added), added_material_message(added, h)))
    if not parts:
        return "try a smaller h"
    return "; ".join(text for _, text in sorted(parts, key=lambda part: -part[0]))


def _material_checks(job: MeshingJob) -> tuple[list, list]:
    """The regions of material lost and added (:func:`~fepre.distmesh.lost_material.material_checks`),
    their places in the user's frame."""
    from .lost_material import significant

    lost, added, _, _ = _material_candidates(job, volume=False)
    return significant(lost, job.points, job.tets, job.h), significant(added, job.points, job.tets, job.h)


def _material_candidates(job: MeshingJob, volume: bool = True) -> tuple[list, list, object, object]:
    """Every region lost and added, whatever its volume, in the user's frame, the checks' grid
    and, with ``volume``, the model's volume estimated on them when it is not a triangle-mesh
    model's exact one (:func:`~fepre.distmesh.lost_material.material_candidates`)."""
    from .lost_material import material_candidates, mesh_model_of

    lost, added, grid, volume = material_candidates(job.model, job.points, job.tets, job.h,
                                                    job.size if job.absolute else None,
                                                    volume=volume and mesh_model_of(job.given_model)[0] is None)
    if job.frame_offset.any():
        lost, added = ([replace(r, center=tuple(np.add(r.center, job.frame_offset).tolist())) for r in found]
                       for found in (lost, added))
    return lost, added, grid, volume


def _warn_of_genus(job: MeshingJob, faces, grid, lost: list, added: list, small_lost: list, small_added: list) -> None:
    """A warning when the regions lost or added change the genus of the mesh's surface: those
    under the volume floor named with it (nothing else names them), the others named above by
    their volume (a new user's hollow shaft at D/25, its keyway's floor lost and the keyway open
    into the bore, was named by volume alone)."""
    from .genus import genus_change
    from .lost_material import added_material_message, lost_material_message

    change = genus_change(faces, job.model, grid, lost, added)
    if change is None:
        return
    h = None if job.absolute else job.h
    parts = [change] + ([lost_material_message(small_lost, h)] if small_lost else []) + (
        [added_material_message(small_added, h)] if small_added else [])
    if len(parts) == 1:
        parts[0] += ", at the places named above"
    warn_user(f"distmesh: {'; '.join(parts)}", ResolutionWarning)


def check_mesh(job: MeshingJob) -> None:
    """The resolution check (material lost or added), the history, the constraints' checks."""
    from .lost_material import added_material_message, lost_material_message, volume_message

    o, loop, h = job.options, job.loop, job.h
    lost, added, small_lost, small_added, grid, estimate = [], [], [], [], None, None
    if o.check_resolution:
        from .lost_material import significant

        small_lost, small_added, grid, estimate = _material_candidates(job)
        lost, added = (significant(found, job.points, job.tets, h) for found in (small_lost, small_added))
        small_lost, small_added = ([] if big else small for big, small in ((lost, small_lost), (added, small_added)))
    if lost:
        warn_user(f"distmesh: {lost_material_message(lost, None if job.absolute else h)}", ResolutionWarning)
    if added:
        warn_user(f"distmesh: {added_material_message(added, None if job.absolute else h)}", ResolutionWarning)
    if o.check_resolution:
        from .cavities import cavities_message, inner_voids, pockets_message, sealed_pockets, unmodelled_cavities
        from .pieces import cut_off_pieces, fragments_message, mesh_pieces, pieces_message
        from .topology import boundary_faces

        faces = job.boundary[1] if job.boundary is not None and job.boundary[0] is job.tets else boundary_faces(job.tets)
        if lost or added or small_lost or small_added:  # whether they change the topology
            _warn_of_genus(job, faces, grid, lost + small_lost, added + small_added, small_lost, small_added)
        voids = inner_voids(job.points, faces, h)
        message = cavities_message(unmodelled_cavities(job.points, faces, job.model, h, voids), job.frame_offset)
        if message:
            warn_user(f"distmesh: {message}", ResolutionWarning)
        message = pockets_message(sealed_pockets(job.points, faces, job.model, h, job.lower, job.upper, voids),
                                  job.frame_offset)
        if message:
            warn_user(f"distmesh: {message}", ResolutionWarning)

        message = fragments_message(job.fragments, job.frame_offset)
        if message:
            warn_user(f"distmesh: {message}", ResolutionWarning)
        labels, counts = mesh_pieces(job.tets, len(job.points))
        cut_off = None
        if len(counts) > 1:
            from .thin_cells import sizes_at

            cut_off = cut_off_pieces(job.points, job.tets, labels, counts, job.model,
                                     sizes_at(job.points, h, local_size(job)))
        message = pieces_message(job.points, job.tets, labels, counts, job.frame_offset, cut_off)
        if message:
            warn_user(f"distmesh: {message}", ResolutionWarning)
        if o.slivers:
            from .thin_cells import combined, thin_bad_cells, thin_cells_message
            from .thin_trim import trimmed_message

            if job.trimmed.cells:
                from ..quality import signed_volumes

                volume = float(signed_volumes(job.points, job.tets).sum()) + job.trimmed.volume
                warn_user(f"distmesh: {trimmed_message(job.trimmed, volume, None if job.absolute else h, job.frame_offset)}",
                          ResolutionWarning)

            groups = next((found for c in job.constraints if (found := c.cell_models(job)) is not None), None)
            groups = [(job.model, slice(None))] if groups is None else groups
            thin = combined(thin_bad_cells(model, job.points, job.tets[cells], h, local_size(job)) for model, cells in groups)
            message = thin_cells_message(thin, None if job.absolute else h, job.frame_offset)
            if message:
                warn_user(f"distmesh: {message}", ResolutionWarning)
    if o.check_resolution and not any(value is not None for value in job.keywords.values()):  # not a cut cell
        message = volume_message(job.given_model, job.model, job.points, job.tets, job.lower, job.upper, h,
                                 job.absolute or job.size is not None, estimate)
        if message:
            warn_user(f"distmesh: {message}", ResolutionWarning)
    job.history = dict(loop.history)
    job.history.update(
        iterations=np.array([loop.iterations]),
        converged=np.array([int(loop.converged)]),
        triangulations=np.array([loop.triangulations]),
        loop_seconds=np.array([job.seconds["loop"]]),
        slivers_seconds=np.array([job.seconds["slivers"]]),
        features_seconds=np.array([job.seconds["features"]]),
        feature_nodes=np.array([job.feature_nodes]),
        split_edges=np.array([job.split_edges]),
        inserted_nodes=np.array([job.inserted_nodes]),
        trimmed_cells=np.array([job.trimmed.cells]),
        trimmed_volume=np.array([job.trimmed.volume]),
        dropped_cells=np.array([job.fragments.cells]),
        dropped_volume=np.array([job.fragments.volume]),
        lost_volume=np.array([sum(region.volume for region in lost) if o.check_resolution else np.nan]),
        added_volume=np.array([sum(region.volume for region in added) if o.check_resolution else np.nan]),
        seconds=np.array([time.perf_counter() - job.started]),
    )
    for constraint in job.constraints:
        constraint.check(job)


def output_grid(job: MeshingJob):
    """The pyvista.UnstructuredGrid with every constraint's data; warns if the loop stopped at maxiter."""
    faces = job.boundary[1] if job.boundary is not None and job.boundary[0] is job.tets else None
    grid = to_grid(job.points, job.tets, job.model, job.history, job.features, boundary=faces)
    for constraint in job.constraints:
        constraint.annotate(job, grid)
    job.stage_log("checks and output", f"{grid.n_points:,} nodes, {grid.n_cells:,} cells, "
                  f"{time.perf_counter() - job.started:.1f} s in all")
    if not job.loop.converged:
        o = job.options
        warn_user(
            f"distmesh stopped at maxiter={o.maxiter} before meeting its tolerance "
            f"(last interior move {job.loop.history['max_dp'][-1]:.3g} h > ptol={o.ptol:g}); returning the mesh reached",
            ConvergenceWarning,
        )
    return grid


#: the stages in order; each takes the job and leaves its result in it (the last returns the grid)
STAGES = (constraint_nodes, starting_points, run_loop, make_final_mesh, quality_stage, validate_mesh, drop_fragments,
          check_mesh, output_grid)


def run_pipeline(job: MeshingJob):
    """Run :data:`STAGES` on ``job``; returns the output grid. A MeshingError of a stage gets
    each constraint's :meth:`~fepre.distmesh.constraints.MeshConstraint.failure_note`."""
    try:
        for stage in STAGES[:-1]:
            stage(job)
        return STAGES[-1](job)
    except MeshingError as exc:
        _name_unresolved(exc, job)
        for constraint in job.constraints:
            note = constraint.failure_note(job)
            if note and hasattr(exc, "add_note"):  # Python 3.11
                exc.add_note(note)
        raise


def _name_unresolved(exc: MeshingError, job: MeshingJob) -> None:
    """A refusal that ends in "try a smaller h" from a mesh graded by a size field that named
    places needing sizes below its hmin: the advice names the thinnest and the hmin it needs."""
    message = str(exc)
    places = getattr(job.size, "unresolved", None) if job.absolute else None
    if not places or not message.endswith("try a smaller h"):
        return
    from ..sizing.under_hmin import named_place

    sized = sorted((place for place in places if place[0] > 0), key=lambda place: place[0])
    hmin = job.size.hmin
    if sized:
        advice = (f"the size field named {len(places)} place(s) thinner than its hmin={hmin:.4g} resolves, the "
                  f"thinnest {named_place(*sized[0], hmin)}: pass hmin <= {sized[0][0]:.3g}")
    else:
        advice = (f"the size field named {len(places)} place(s) no element size resolves, "
                  f"{named_place(*places[0], hmin)}: thicken, trim or join them in the model")
    exc.args = (message[: -len("try a smaller h")] + advice,) + exc.args[1:]

