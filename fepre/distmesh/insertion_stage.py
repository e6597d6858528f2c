"""The quality stage with vertex insertion: run, split an edge of each cell left bad, run again.

See :mod:`~fepre.distmesh.bad_cell_splits` for why vertices are missing where a faceted surface
bends at the scale of h. :func:`stage_with_insertions` runs the stage
(:func:`~fepre.distmesh.slivers.improve_arrays`) and then, while cells stay below the targets,
splits an edge of each and runs the stage again on the bad cells only, up to
``INSERTION_ROUNDS`` times. It keeps the
round whose worst cell scores best, if that mesh passes the final checks
(:func:`~fepre.distmesh.validate.mesh_defects`); a round can make things worse before the next
one repairs them (libigl's arm at D/50: 17.5 deg after the stage, 15.0 after the first round,
26.3 after the sixth); the checks matter where the model itself forbids the targets (a 15 deg
wedge's tip: 8.4 deg before and after, and a round that pinched a boundary vertex). The rounds
are counted, not timed, so the same input gives the same mesh on a busy machine. When the
worst cell fills a knife edge of the model (:func:`~fepre.distmesh.bad_cell_splits.knife_edge`),
no round starts (no vertex helps there) and the warning says so. An edge a round split that
is back after the stage (the stage collapsed its vertex) is split after every other choice in
the later rounds of the series: the same split gives the same mesh again (cow.obj at D/50: an
ear cell's inner edge split and collapsed four rounds running, 21.0 deg; with the next choice
the series converged).
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass
from typing import Callable

import numpy as np

from ..errors import ConvergenceWarning, MeshingError
from .bad_cell_splits import knife_edge, split_bad_cells, stable_edge_keys
from .cell_labels import refined_labels
from .improve_mesh import stage_pins
from .tet_shape import ShapeTargets
from .tet_topology import EDGE_OF_TET

__all__ = ["stage_with_insertions", "LabelledCells", "INSERTION_ROUNDS"]

#: Rounds of vertex insertion at most.
INSERTION_ROUNDS = 6
#: Rounds of thin zones given up at most (:mod:`~fepre.distmesh.thin_trim`).
TRIM_ROUNDS = 3
#: The stage's rounds after each: the cells it leaves bad are mostly flat ones no move mends
TRIM_STAGE_ROUNDS = 12
#: No round starts when more cells than this (or this share of the cells) are below the targets.
MAX_BAD_CELLS = 64
MAX_BAD_SHARE = 1e-3
#: a round better by at most this much (score, degrees) on its worst cell is kept only with no
#: more cells below the targets than the best so far
TIE = 0.5


@dataclass
class LabelledCells:
    """Cells in labelled regions (a region mesh) for :func:`stage_with_insertions`.

    Attributes
    ----------
    labels : (M,) int array
        Each cell's region.
    frozen : (N,) bool array
        The vertices of the faces between regions: fixed, no edge between two of them is split
        and no cavity crosses a face of three (vertices appended later are not frozen).
    node_regions : callable
        ``node_regions(points) -> (owner, region_of)``, the stage's ``node_regions``
        (:func:`~fepre.distmesh.slivers.improve_arrays`): each boundary vertex slides within its region.
    valid : callable
        ``valid(points, tets, labels) -> bool`` (every point in some cell): a round's mesh is
        kept only if its regions meet as they should.
    """

    labels: np.ndarray
    frozen: np.ndarray
    node_regions: Callable
    valid: Callable

    def frozen_among(self, n_points: int) -> np.ndarray:
        """``frozen`` for ``n_points`` vertices (those added since are not)."""
        return np.concatenate([self.frozen, np.zeros(n_points - self.frozen.shape[0], dtype=bool)])


def _run(job, pinned, removable: Callable, local_size, bad_cells_only: bool, reshaping: bool = False,
         labelled: LabelledCells | None = None, labels: np.ndarray | None = None, maxiter: int | None = None):
    """One run of the stage on ``job``'s mesh: points, cells, info and the warnings it gave
    (with ``labelled``, the cells' ``labels`` go in and ``info["labels"]`` comes out)."""
    from .slivers import improve_arrays

    collapse, extra = removable(job), {}
    if labelled is not None:
        frozen = labelled.frozen_among(job.points.shape[0])
        pinned, collapse = pinned | frozen, collapse & ~frozen
        extra = {"labels": labels, "node_regions": labelled.node_regions(job.points)}
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        points, tets, info = improve_arrays(
            job.points, job.tets, job.model, job.h, fixed_mask=pinned, size=job.size, seed=job.options.seed,
            collapse=collapse, local_size=local_size, bad_cells_only=bad_cells_only,
            inner_collapses=reshaping, maxiter=maxiter, **extra)
    return points, tets, info, list(caught)


def _valid(job, points, tets, labelled: LabelledCells | None = None, labels: np.ndarray | None = None) -> bool:
    from .validate import mesh_defects

    used = np.unique(tets)
    number = np.full(len(points), -1)
    number[used] = np.arange(len(used))
    points, tets = points[used], number[tets]
    if mesh_defects(points, tets, job.model, job.h, job.size, job.absolute, (job.lower, job.upper)):
        return False
    return labelled is None or bool(labelled.valid(points, tets, labels))


def stage_with_insertions(job, pinned: np.ndarray, removable: Callable, local_size,
                          labelled: LabelledCells | None = None, first_run: Callable | None = None) -> np.ndarray | None:
    """The quality stage on ``job`` with vertex insertion (:func:`_stage_once`); on a plain mesh
    left short of the targets, the whole stage once more from the same mesh with caps that
    bridge a valley removed too (:func:`~fepre.distmesh.boundary_slivers.bridges_removed`), and
    the better of the two kept (its warnings given). Removed from the first round on, such caps
    lifted ur3_base.stl at D/50 from 13.9 to 28.0 deg and beetle.obj from 9.6 to 25.0, but sent
    ur3_upperarm from 16.7 to 8.2 and beast from 10.8 to 3.3: neither way is better on all."""
    from .boundary_slivers import bridges_removed

    targets = ShapeTargets()
    start = (job.points, job.tets, job.fixed_mask, job.trimmed)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        labels = _stage_once(job, pinned, removable, local_size, labelled, first_run)
    first = (float(targets.score(job.points[job.tets]).min()), job.points, job.tets, job.fixed_mask,
             job.inserted_nodes, job.trimmed, list(caught), labels)
    chosen = first
    if labelled is None and first[0] < targets.min_dihedral:
        job.points, job.tets, job.fixed_mask, job.trimmed = start
        try:
            with warnings.catch_warnings(record=True) as caught, bridges_removed():
                warnings.simplefilter("always")
                labels = _stage_once(job, pinned, removable, local_size, labelled, first_run)
            score = float(targets.score(job.points[job.tets]).min())
            if score > first[0] and _valid(job, job.points, job.tets):
                chosen = (score, job.points, job.tets, job.fixed_mask, job.inserted_nodes, job.trimmed,
                          list(caught), labels)
        except MeshingError:
            pass
    _, job.points, job.tets, job.fixed_mask, job.inserted_nodes, job.trimmed, caught, labels = chosen
    for item in caught:
        warnings.warn_explicit(item.message, item.category, item.filename, item.lineno)
    return labels


def _stage_once(job, pinned: np.ndarray, removable: Callable, local_size,
                labelled: LabelledCells | None = None, first_run: Callable | None = None) -> np.ndarray | None:
    """The quality stage on ``job`` with vertex insertion (see the module docstring); sets
    ``job.points``, ``job.tets``, ``job.fixed_mask`` and ``job.inserted_nodes``.

    ``removable(job)`` gives the nodes edge collapses may remove, ``local_size`` the graded
    mesh's edge length at points (None when uniform). With ``labelled`` (a region mesh's cells),
    every run and split keeps the faces between regions and the cells' labels are carried
    through; ``first_run()`` then makes the stage's first run, ``(points, tets, labels)`` (the
    region mesh's stage, which also moves interface nodes along their interfaces). Returns the
    cells' labels (None without ``labelled``).
    """
    targets = ShapeTargets()
    if first_run is None:
        points, tets, info, caught = _run(job, pinned, removable, local_size, False, False, labelled,
                                          None if labelled is None else labelled.labels)
    else:
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            points, tets, labels = first_run()
        caught = list(caught)
        info = {"labels": labels, "converged": bool(targets.score(points[tets]).min() >= targets.min_dihedral)}
    first = (float(targets.score(points[tets]).min()), points, tets, job.fixed_mask, caught, info)
    best = first
    for reshaping in (False, True):
        best = _insertion_rounds(job, first, best, removable, local_size, targets, reshaping, labelled)
        if best[0] >= targets.min_dihedral:
            break
    if labelled is None and best[0] < targets.min_dihedral and job.options.thin_parts == "trim":
        best = _trim_rounds(job, best, removable, local_size, targets)
    _, job.points, job.tets, job.fixed_mask, caught, info = best
    job.inserted_nodes = len(job.fixed_mask) - len(first[3])
    for item in caught:
        message = str(item.message)
        if issubclass(item.category, ConvergenceWarning):
            message += _knife_edge_note(job, targets)
        warnings.warn_explicit(message, item.category, item.filename, item.lineno)
    return None if labelled is None else info["labels"]


def _insertion_rounds(job, first: tuple, best: tuple, removable: Callable, local_size, targets: ShapeTargets,
                      reshaping: bool, labelled: LabelledCells | None = None) -> tuple:
    """Up to ``INSERTION_ROUNDS`` rounds of splits and the stage on the bad cells, from the
    stage's ``first`` result; returns the best of ``best`` and the valid rounds' meshes.

    ``reshaping`` makes the second series, run when the first leaves cells below the targets:
    each bad cell's chord farthest off the surface is split first, and the stage collapses
    inner vertices that crowd another (the knight at h = (D/50, D/12): 13.0 deg after the first
    series, 30.7 after the second; bunny_small at D/25: 7.4 and 26.3).
    """
    _, points, tets, job.fixed_mask, _, info = first
    tried = np.zeros(0, dtype=np.int64)
    for _ in range(INSERTION_ROUNDS):
        if info["converged"] or _too_many_bad(points, tets, targets) or _worst_at_knife(points, tets, job.model, targets):
            break
        frozen = None if labelled is None else labelled.frozen_among(points.shape[0])
        job.points, job.tets, split = split_bad_cells(points, tets, job.model, job.h, targets,
                                                      off_surface_first=reshaping, tried=tried, locked=frozen)
        if split == 0:
            break
        labels = None if labelled is None else refined_labels(job.points, tets, info["labels"], job.tets)
        tried = np.union1d(tried, _split_away(points, tets, job.tets, targets))
        job.fixed_mask = np.concatenate([job.fixed_mask, np.zeros(split, dtype=bool)])
        pinned = stage_pins(job.points, job.tets, job.fixed_mask, job.user_fixed, job.model, job.h)
        try:
            points, tets, info, caught = _run(job, pinned, removable, local_size, True, reshaping, labelled, labels)
        except MeshingError:
            break  # the run refused its own result: the best so far stands
        score = targets.score(points[tets])
        worst = float(score.min())
        if _improves(score, best, targets) and _valid(job, points, tets, labelled, info.get("labels")):
            best = (worst, points, tets, job.fixed_mask, caught, info)
    return best


def _improves(score: np.ndarray, best: tuple, targets: ShapeTargets) -> bool:
    """True when a round whose cells score ``score`` is better than ``best``: its worst cell
    better by more than ``TIE``, or better at all with no more cells below the targets. The
    rounds' best mesh is where the trim starts: on ur3_upperarm.stl at D/50 a round whose worst
    cell scored a hair above the stage's (both about 0) but with 128 bad cells against 76 was
    kept, and the trim from it ended at 4.5 deg instead of 16.7."""
    worst = float(score.min())
    if worst > best[0] + TIE:
        return True
    if worst <= best[0]:
        return False
    before = targets.score(best[1][best[2]])
    return np.count_nonzero(score < targets.min_dihedral) <= np.count_nonzero(before < targets.min_dihedral)


def _trim_rounds(job, best: tuple, removable: Callable, local_size, targets: ShapeTargets) -> tuple:
    """Up to ``TRIM_ROUNDS`` rounds of giving up thin zones
    (:func:`~fepre.distmesh.thin_trim.trim_thin_zones`) and the stage on the cells left bad; a
    round is kept when its worst cell scores better and its mesh passes the final checks (a
    knife edge of the model keeps its angle however much of it goes). Sets ``job.trimmed``."""
    from ..quality import signed_volumes
    from .thin_trim import TOTAL_SHARE, trim_thin_zones

    budget = TOTAL_SHARE * float(signed_volumes(best[1], best[2]).sum())
    for _ in range(TRIM_ROUNDS):
        worst, points, tets, fixed, _, _ = best
        moved, kept, cut = trim_thin_zones(points, tets, job.model, job.h, local_size, targets,
                                           budget - job.trimmed.volume, fixed, _held(job, points))
        if cut.cells == 0:
            break
        job.points, job.tets, job.fixed_mask = moved, kept, fixed
        pinned = stage_pins(moved, kept, fixed, job.user_fixed, job.model, job.h)
        try:
            points, tets, info, caught = _run(job, pinned, removable, local_size, True, maxiter=TRIM_STAGE_ROUNDS)
        except MeshingError:
            break
        score = float(targets.score(points[tets]).min())
        if score <= worst or not _valid(job, points, tets):
            break  # only a better worst cell is worth the material (a 14 deg prism's tip: the same angle)
        best = (score, points, tets, fixed, caught, info)
        job.trimmed = job.trimmed + cut
        if score >= targets.min_dihedral:
            break
    return best


def _held(job, points: np.ndarray) -> np.ndarray | None:
    """(N,) mask of the nodes at the user's fixed points (their pieces stay whole), or None."""
    if job.user_fixed is None or not len(job.user_fixed):
        return None
    from scipy.spatial import cKDTree

    held = np.zeros(len(points), dtype=bool)
    held[cKDTree(points).query(np.asarray(job.user_fixed, dtype=float))[1]] = True
    return held


def _split_away(points, tets, new_tets, targets) -> np.ndarray:
    """The stable keys of the bad cells' edges of ``tets`` that ``new_tets`` no longer has (the
    edges a round split); when one comes back, the stage undid its split."""
    bad = tets[targets.score(points[tets]) < targets.min_dihedral]
    keys = np.unique(stable_edge_keys(bad[:, EDGE_OF_TET]))
    return keys[~np.isin(keys, stable_edge_keys(new_tets[:, EDGE_OF_TET]))]


def _too_many_bad(points, tets, targets) -> bool:
    """True when more cells are below the targets than insertion is for: a few isolated places
    (5-30 on organic models); a long knife edge leaves hundreds, and each round on them cost
    8 s on 6k cells of a 14 deg prism without a gain."""
    bad = int(np.count_nonzero(targets.score(points[tets]) < targets.min_dihedral))
    return bad > max(MAX_BAD_CELLS, MAX_BAD_SHARE * len(tets))


def _worst_at_knife(points, tets, model, targets) -> bool:
    """True when the worst cell fills a knife edge of the model sharper than the target: no
    inserted vertex helps there (a 14 deg prism at h = 0.1: six futile rounds took 380 s)."""
    found = knife_edge(points, tets, model, int(np.argmin(targets.score(points[tets]))))
    return found is not None and found[0] < targets.min_dihedral


def _knife_edge_note(job, targets) -> str:
    """Why the worst cell cannot meet the targets when it fills a knife edge of the model (its
    two boundary faces on surfaces meeting at less than ``min_dihedral``), else ''."""
    worst = int(np.argmin(targets.score(job.points[job.tets])))
    found = knife_edge(job.points, job.tets, job.model, worst)
    if found is None or found[0] >= targets.min_dihedral:
        return ""
    where = ", ".join(f"{x:.4g}" for x in found[1] + job.frame_offset)
    return (f"; the worst cell fills a knife edge of the model at ({where}), where its surfaces meet at "
            f"{found[0]:.1f} deg: a cell on an edge that sharp has no larger angle (round the edge off "
            f"in the model to meet the target)")
