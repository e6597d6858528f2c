"""The DistMesh iteration: bar forces, moves, boundary projection, retriangulation, stopping."""

from __future__ import annotations

import sys
import time
from dataclasses import dataclass, field
from typing import Callable

import numpy as np

from .delaunay import loop_tetrahedralize
from .forces import bar_forces, bars_of
from .hilbert import hilbert_order
from .initial_points import evaluate_size
from .options import DistMeshOptions

__all__ = ["DistMeshState", "LoopResult", "iterate", "project_outside", "centroid_inside"]

HISTORY = ("max_move", "max_dp", "min_quality", "mean_quality", "retriangulated")


@dataclass
class DistMeshState:
    """What a ``callback`` receives after each iteration (arrays are live views: copy to keep).

    Attributes
    ----------
    iteration : int
        1-based iteration number.
    points : (N, 3) float64 array
        Current point positions.
    tets : (M, 4) int64 array
        Current triangulation (positively oriented, boundary cells dropped).
    max_move : float
        Largest point move of this iteration.
    max_dp : float
        Largest move of an interior point, relative to ``h`` (the ``ptol`` criterion).
    min_quality, mean_quality : float
        Worst and mean volume-edge ratio of ``tets`` at the start of the iteration.
    retriangulated : bool
        Whether this iteration began with a new Delaunay triangulation.
    seconds : float
        Time since the start of the loop.
    """

    iteration: int
    points: np.ndarray
    tets: np.ndarray
    max_move: float
    max_dp: float
    min_quality: float
    mean_quality: float
    retriangulated: bool
    seconds: float


@dataclass
class LoopResult:
    points: np.ndarray
    fixed_mask: np.ndarray
    history: dict[str, np.ndarray]
    converged: bool
    iterations: int
    seconds: float
    triangulations: int = 0
    timings: dict[str, float] = field(default_factory=dict)
    #: the last Delaunay triangulation (before dropping outside cells, canonical cells in the
    #: backend's order) and how far the points moved since, for reuse by the final mesh
    delaunay_tets: np.ndarray | None = None
    moved_since_delaunay: float = np.inf


def volume_edge_ratio(points: np.ndarray, tets: np.ndarray) -> np.ndarray:
    """``6 sqrt(2) V / l_rms^3`` of each tetrahedron (the loop's cheap quality measure)."""
    from .._cell_kernels import volume_edge_ratios

    return volume_edge_ratios(points, tets)


def evaluate(model, points: np.ndarray, gradient: bool, deps: float | None, h: float):
    """Model values (and gradients): analytic when available, else forward differences with
    step ``deps * h`` when ``deps`` is set, else the model's central differences."""
    if not gradient:
        return model(points), None
    if model.analytic_gradient or deps is None:
        return model.value_and_gradient(points)
    step = deps * h
    values = model(points)
    shifted = np.concatenate([points + step * np.eye(3)[k] for k in range(3)])
    grad = (model(shifted).reshape(3, -1) - values[None, :]).T / step
    return values, grad


def project_outside(model, points, values, index, deps, h) -> None:
    """Move ``points[index]`` (which have sdf ``values`` > 0) back: ``p -= d g / |g|^2``."""
    if len(index) == 0:
        return
    _, grad = evaluate(model, points[index], True, deps, h)
    norm2 = np.einsum("ij,ij->i", grad, grad)
    norm2 = np.where(norm2 > 1e-24, norm2, 1.0)
    points[index] -= (values / norm2)[:, None] * grad


def centroid_inside(model, points, tets, bound, limit) -> np.ndarray:
    """Mask of tetrahedra whose centroid has sdf < ``limit``.

    ``bound`` is an upper bound of each point's sdf; as the sdf is 1-Lipschitz,
    ``sdf(c) <= bound_i + |c - p_i|`` for every corner ``i``: cells where that bound is already
    below ``limit`` are kept without evaluating the model.
    """
    from .._cell_kernels import centroid_bounds

    centroids, reach = centroid_bounds(points, tets, bound)
    sure = reach < limit
    keep = sure.copy()
    unsure = np.flatnonzero(~sure)
    if len(unsure):
        keep[unsure] = model(centroids[unsure]) < limit
    return keep


def _time_left(history: dict, options: DistMeshOptions, iteration_seconds: list[float], force_seconds: float) -> str:
    """``", about N s left"`` for the progress line (the loop's end from its quality trend, then
    the stages after it), or ``""`` while the trend cannot tell."""
    from .estimate import iterations_left, seconds_after

    if options.termination != "quality":
        return ""
    left = [iterations_left(history[k], options.quality_window, options.quality_tol, options.maxiter)
            for k in ("mean_quality", "min_quality")]
    if left[0] is None:
        return ""
    iterations = left[0] if left[1] is None else max(left)
    recent = iteration_seconds[-options.quality_window :]
    seconds = iterations * sum(recent) / len(recent) + seconds_after(None, force_seconds)
    return f", about {seconds:.0f} s left"


#: the progress line measures the dihedral angles of this many of the worst cells by the loop's
#: volume-edge ratio (all cells took a quarter of the loop's time)
PROGRESS_CELLS = 512


def _print_progress(iteration: int, points: np.ndarray, tets: np.ndarray, quality: np.ndarray, seconds: float,
                    done: bool, left: str = "") -> None:
    """One line: iteration, points, the worst dihedral angle of the current cells (among the
    worst by ``quality``, the volume-edge ratios), time (and the time left)."""
    from ..quality import dihedral_angles, signed_volumes

    worst_cells = tets[np.argpartition(quality, PROGRESS_CELLS)[:PROGRESS_CELLS]] if len(tets) > PROGRESS_CELLS else tets
    positive = signed_volumes(points, worst_cells) > 0
    worst = float(dihedral_angles(points, worst_cells[positive]).min()) if positive.any() else 0.0
    inverted = int(np.count_nonzero(~positive))
    flipped = f"  ({inverted} cells inverted)" if inverted else ""
    # one line rewritten in place on a terminal; whole lines in a log file
    end = "\n" if done or not sys.stderr.isatty() else "\r"
    sys.stderr.write(
        f"distmesh: iteration {iteration:5d}  {len(points):8d} points  worst dihedral {worst:5.1f} deg"
        f"{flipped}  {seconds:7.2f} s{left}{end}"
    )
    sys.stderr.flush()


def iterate(
    model,
    h: float,
    points: np.ndarray,
    fixed_mask: np.ndarray,
    size: Callable | None,
    options: DistMeshOptions,
    progress: bool = False,
    callback: Callable[[DistMeshState], object] | None = None,
    protect: Callable[[np.ndarray, np.ndarray], tuple[np.ndarray, np.ndarray]] | None = None,
    local_size: Callable[[np.ndarray], np.ndarray] | None = None,
) -> LoopResult:
    """Run the DistMesh loop from ``points``; returns the final positions and the history.

    ``protect(points, movable)`` moves points in place after each step (the feature
    neighbourhoods, :class:`~fepre.distmesh.feature_protection.FeatureProtection`) and returns
    the moved indices and distances. ``local_size(points)`` (a size field's edge lengths) makes
    the retriangulation and convergence tests relative to the local size instead of ``h``:
    large elements of a graded mesh move further per step than small ones.
    """
    start = time.perf_counter()
    o = options
    p = points.copy()
    fixed = fixed_mask.copy()
    geps, ttol = o.geps * h, o.ttol * h
    n = len(p)

    bound = model(p)  # sdf where evaluated, an upper bound of it elsewhere (the distance cache)
    history = {name: [] for name in HISTORY}
    timings = dict.fromkeys(("delaunay", "bars", "forces", "model", "quality"), 0.0)
    p_triangulated = None
    recent_moves: list[float] = []
    triangulations = 0
    converged = False
    last_print = 0.0
    tets = delaunay_tets = np.zeros((0, 4), np.int64)
    iteration = 0
    scale: np.ndarray | float = h
    iteration_seconds: list[float] = []
    previous_end = 0.0

    for iteration in range(1, o.maxiter + 1):
        # -- retriangulate when points moved far enough (or move averaging asks for it)
        retriangulate = p_triangulated is None
        if not retriangulate:
            moved = (np.sqrt(np.einsum("ij,ij->i", p - p_triangulated, p - p_triangulated)) / scale).max() * h
            retriangulate = moved > ttol
            if o.retriangulation == "move_average" and len(recent_moves) > o.move_average_window:
                window = recent_moves[-o.move_average_window - 1 : -1]
                retriangulate |= recent_moves[-1] > np.mean(window)
        if retriangulate:
            t0 = time.perf_counter()
            if o.sort == "hilbert" and triangulations % o.sort_interval == 0:
                order = hilbert_order(p)
                p, bound, fixed = p[order], bound[order], fixed[order]
            scale = np.maximum(local_size(p), h) if local_size is not None else h  # per point
            delaunay_tets = loop_tetrahedralize(p, o.delaunay, h, o.parallel)
            tets = delaunay_tets[centroid_inside(model, p, delaunay_tets, bound, -geps)]
            t1 = time.perf_counter()
            bars = bars_of(tets, n)
            p_triangulated = p.copy()
            recent_moves.clear()
            triangulations += 1
            timings["delaunay"] += t1 - t0
            timings["bars"] += time.perf_counter() - t1

        # -- forces and move
        t0 = time.perf_counter()
        hbars = None
        if size is not None:
            hbars = evaluate_size(size, 0.5 * (p[bars[:, 0]] + p[bars[:, 1]]))
        force, _ = bar_forces(p, bars, o.fscale, o.nonlinear, hbars)
        force[fixed] = 0.0
        move = o.deltat * force
        t1 = time.perf_counter()
        timings["forces"] += t1 - t0

        # -- quality of the current triangulation (volume-edge ratio, from the bar lengths)
        q = volume_edge_ratio(p, tets)
        history["min_quality"].append(float(q.min()) if len(q) else 0.0)
        history["mean_quality"].append(float(q.mean()) if len(q) else 0.0)
        t2 = time.perf_counter()
        timings["quality"] += t2 - t1

        p += move
        step = np.sqrt(np.einsum("ij,ij->i", move, move))

        # -- sdf where it may have reached -geps; project points that left the domain
        if o.distance_cache:
            bound += step
            near = np.flatnonzero(bound >= -geps)
        else:
            near = np.arange(n)
        values = model(p[near]) if len(near) else np.zeros(0)
        bound[near] = values
        outside = near[(values > 0) & ~fixed[near]]
        project_outside(model, p, bound[outside], outside, o.deps, h)
        bound[outside] = 0.0
        if protect is not None:
            pushed, distance = protect(p, ~fixed)
            bound[pushed] += distance  # the sdf is 1-Lipschitz
            step[pushed] += distance
        timings["model"] += time.perf_counter() - t2

        interior = bound < -geps
        max_dp = float((step / scale)[interior].max()) if interior.any() else 0.0
        max_move = float(step.max())
        recent_moves.append(max_move)
        history["max_move"].append(max_move)
        history["max_dp"].append(max_dp)
        history["retriangulated"].append(bool(retriangulate))

        seconds = time.perf_counter() - start
        iteration_seconds.append(seconds - previous_end)
        previous_end = seconds
        if callback is not None:
            callback(
                DistMeshState(iteration, p, tets, max_move, max_dp, history["min_quality"][-1],
                              history["mean_quality"][-1], bool(retriangulate), seconds)
            )
        if max_dp < o.ptol:
            converged = True
        elif o.termination == "quality" and iteration >= 2 * o.quality_window:
            w = o.quality_window
            converged = all(
                max(history[k][-w:]) - max(history[k][:-w]) < o.quality_tol for k in ("min_quality", "mean_quality")
            )
        if progress and (converged or seconds - last_print > 0.5):
            last_print = seconds
            left = "" if converged else _time_left(history, o, iteration_seconds, timings["forces"] / iteration)
            _print_progress(iteration, p, tets, q, seconds, converged, left)
        if converged:
            break

    seconds = time.perf_counter() - start
    moved_since = float((np.sqrt(np.einsum("ij,ij->i", p - p_triangulated, p - p_triangulated)) / scale).max() * h)
    if progress and not converged:
        _print_progress(iteration, p, tets, q, seconds, True)
    return LoopResult(
        points=p,
        fixed_mask=fixed,
        history={k: np.asarray(v, dtype=np.int8 if k == "retriangulated" else np.float64) for k, v in history.items()},
        converged=converged,
        iterations=iteration,
        seconds=seconds,
        triangulations=triangulations,
        timings=timings,
        delaunay_tets=delaunay_tets,
        moved_since_delaunay=moved_since,
    )
