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


@dataclass
class _LoopArrays:
    """The loop's working state between its steps."""

    points: np.ndarray
    fixed: np.ndarray
    #: sdf where evaluated, an upper bound of it elsewhere (the distance cache)
    bound: np.ndarray
    history: dict[str, list]
    timings: dict[str, float]
    #: per point: the local size (or h) that the move tests are relative to
    scale: np.ndarray | float
    tets: np.ndarray
    delaunay_tets: np.ndarray
    bars: np.ndarray | None = None
    #: the size function at the bars' midpoints when they were made (None without one)
    bar_sizes: np.ndarray | None = None
    triangulated: np.ndarray | None = None
    recent_moves: list[float] = field(default_factory=list)
    triangulations: int = 0

    def moved_since_triangulation(self, h: float) -> float:
        """The largest move since the last triangulation, relative to the local size, times h."""
        moved = self.points - self.triangulated
        return float((np.sqrt(np.einsum("ij,ij->i", moved, moved)) / self.scale).max() * h)


def _needs_triangulation(state: _LoopArrays, o: DistMeshOptions, h: float) -> bool:
    """Whether the points moved far enough (or move averaging asks) to triangulate anew."""
    if state.triangulated is None:
        return True
    retriangulate = state.moved_since_triangulation(h) > o.ttol * h
    if o.retriangulation == "move_average" and len(state.recent_moves) > o.move_average_window:
        window = state.recent_moves[-o.move_average_window - 1 : -1]
        retriangulate |= state.recent_moves[-1] > np.mean(window)
    return retriangulate


def _triangulate(state: _LoopArrays, model, o: DistMeshOptions, h: float, local_size: Callable | None,
                 size: Callable | None) -> None:
    """A new Delaunay triangulation (points in Hilbert order every ``sort_interval`` of them),
    its cells outside the domain dropped, its bars and the size at their midpoints.

    The sizes are taken once per triangulation, not per step: until the next one no point moves
    more than ``ttol`` of its size (of ``h`` for a relative size function), so a size field of
    gradation ``g`` changes by at most ``(g - 1) * ttol`` of itself at a midpoint (3% at the
    defaults), and the evaluation had taken two thirds of a graded loop's force time."""
    t0 = time.perf_counter()
    if o.sort == "hilbert" and state.triangulations % o.sort_interval == 0:
        order = hilbert_order(state.points)
        state.points, state.bound, state.fixed = state.points[order], state.bound[order], state.fixed[order]
    p = state.points
    state.scale = np.maximum(local_size(p), h) if local_size is not None else h  # per point
    state.delaunay_tets = loop_tetrahedralize(p, o.delaunay, h, o.parallel)
    state.tets = state.delaunay_tets[centroid_inside(model, p, state.delaunay_tets, state.bound, -o.geps * h)]
    t1 = time.perf_counter()
    state.bars = bars_of(state.tets, len(p))
    if size is not None:
        state.bar_sizes = evaluate_size(size, 0.5 * (p[state.bars[:, 0]] + p[state.bars[:, 1]]))
    state.triangulated = p.copy()
    state.recent_moves.clear()
    state.triangulations += 1
    state.timings["delaunay"] += t1 - t0
    state.timings["bars"] += time.perf_counter() - t1


def _move(state: _LoopArrays, model, o: DistMeshOptions, h: float,
          protect: Callable | None) -> tuple[np.ndarray, float, float]:
    """One step: bar forces, the quality of the current cells, the move, points that left the
    domain projected back, the ``protect`` hook. Returns the cells' volume-edge ratios, the
    largest move and the largest interior move relative to the local size."""
    p, bars, fixed, bound, timings, history = state.points, state.bars, state.fixed, state.bound, state.timings, state.history
    geps = o.geps * h
    t0 = time.perf_counter()
    force, _ = bar_forces(p, bars, o.fscale, o.nonlinear, state.bar_sizes)
    force[fixed] = 0.0
    move = o.deltat * force
    t1 = time.perf_counter()
    timings["forces"] += t1 - t0

    # -- quality of the current triangulation (volume-edge ratio, from the bar lengths)
    q = volume_edge_ratio(p, state.tets)
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
        near = np.arange(len(p))
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
    max_dp = float((step / state.scale)[interior].max()) if interior.any() else 0.0
    return q, float(step.max()), max_dp


def _converged(history: dict[str, list], o: DistMeshOptions, iteration: int, max_dp: float) -> bool:
    """``ptol`` met, or (``termination="quality"``) neither quality rose by ``quality_tol`` over
    the last window."""
    if max_dp < o.ptol:
        return True
    if o.termination == "quality" and iteration >= 2 * o.quality_window:
        w = o.quality_window
        return all(max(history[k][-w:]) - max(history[k][:-w]) < o.quality_tol for k in ("min_quality", "mean_quality"))
    return False


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
    empty = np.zeros((0, 4), np.int64)
    state = _LoopArrays(
        points=points.copy(), fixed=fixed_mask.copy(), bound=model(points.copy()), scale=h, tets=empty, delaunay_tets=empty,
        history={name: [] for name in HISTORY}, timings=dict.fromkeys(("delaunay", "bars", "forces", "model", "quality"), 0.0),
    )
    history = state.history
    converged = False
    last_print = previous_end = 0.0
    iteration = 0
    iteration_seconds: list[float] = []

    for iteration in range(1, o.maxiter + 1):
        retriangulate = _needs_triangulation(state, o, h)
        if retriangulate:
            _triangulate(state, model, o, h, local_size, size)
        q, max_move, max_dp = _move(state, model, o, h, protect)
        state.recent_moves.append(max_move)
        history["max_move"].append(max_move)
        history["max_dp"].append(max_dp)
        history["retriangulated"].append(bool(retriangulate))

        seconds = time.perf_counter() - start
        iteration_seconds.append(seconds - previous_end)
        previous_end = seconds
        if callback is not None:
            callback(
                DistMeshState(iteration, state.points, state.tets, max_move, max_dp, history["min_quality"][-1],
                              history["mean_quality"][-1], bool(retriangulate), seconds)
            )
        converged = _converged(history, o, iteration, max_dp)
        if progress and (converged or seconds - last_print > 0.5):
            last_print = seconds
            left = "" if converged else _time_left(history, o, iteration_seconds, state.timings["forces"] / iteration)
            _print_progress(iteration, state.points, state.tets, q, seconds, converged, left)
        if converged:
            break

    seconds = time.perf_counter() - start
    if progress and not converged:
        _print_progress(iteration, state.points, state.tets, q, seconds, True)
    return LoopResult(
        points=state.points,
        fixed_mask=state.fixed,
        history={k: np.asarray(v, dtype=np.int8 if k == "retriangulated" else np.float64) for k, v in history.items()},
        converged=converged,
        iterations=iteration,
        seconds=seconds,
        triangulations=state.triangulations,
        timings=state.timings,
        delaunay_tets=state.delaunay_tets,
        moved_since_delaunay=state.moved_since_triangulation(h),
    )
