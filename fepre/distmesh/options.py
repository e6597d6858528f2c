"""DistMesh parameters: one dataclass, every field checked and documented."""

from __future__ import annotations

import dataclasses
import numbers
from dataclasses import dataclass
from typing import Any, Optional

from ..arguments import choice, nonnegative_float, positive_float, positive_int, shown

__all__ = ["DistMeshOptions", "resolve_options"]

DISTRIBUTIONS = ("bcc", "fcc", "cubic")
TERMINATIONS = ("displacement", "quality")
RETRIANGULATIONS = ("movement", "move_average")
DELAUNAY_BACKENDS = ("auto", "scipy", "gmsh")
SORTS = (None, "hilbert")
THIN_PARTS = ("trim", "keep")


@dataclass(frozen=True)
class DistMeshOptions:
    """Parameters of :func:`fepre.distmesh`; lengths are relative to the edge length ``h``.

    Attributes
    ----------
    deltat : float, default 0.1
        Pseudo time step: each iteration moves a point by ``deltat`` times its total bar force.
    ptol : float, default 0.001
        Displacement termination: stop when no interior point (sdf < -geps) moved more than
        ``ptol * h`` in one iteration.
    ttol : float, default 0.1
        Retriangulate once some point has moved more than ``ttol * h`` since the last
        triangulation (the reference's rule; also the safety net of ``"move_average"``).
    fscale : float, default 1.1
        Bars' rest lengths are ``fscale`` times their scaled target, so that bars push.
    geps : float, default 0.1
        Boundary tolerance, times ``h``: tetrahedra whose centroid has sdf >= -geps*h are
        dropped, points with sdf < geps*h are kept from the initial lattice.
    deps : float or None, default None
        Finite-difference step, times ``h``, for models without an analytic gradient
        (None: ``sqrt(machine eps)``). Models with an analytic gradient ignore it.
    maxiter : int, default 1000
        Largest number of iterations; reaching it warns with ``ConvergenceWarning``.
    distribution : {"bcc", "fcc", "cubic"}, default "bcc"
        Initial lattice. ``"bcc"`` (body-centred cubic) has a unique Delaunay triangulation of
        congruent well-shaped tetrahedra and is already near equilibrium; ``"fcc"`` is the
        close packing (DistMesh.jl's default); ``"cubic"`` is the reference's simple cubic
        lattice (maximally co-spherical). Every lattice has the point density that gives edges
        of about ``h``.
    jitter : float, default 0.01
        Random perturbation of the initial lattice, times ``h`` (drawn from ``seed``); breaks
        the co-sphericity of the cubic and fcc lattices.
    boundary_layer : bool, default True
        Start with points on the zero set about ``h`` apart and the lattice cleared to a depth
        of ``h/2`` beneath them (on flat faces along an axis: the lattice's own layer moved onto
        the face, over the next one), instead of the reference's lattice points with sdf < geps
        (which leave the surface under-populated: its points must first flow out of the
        interior, costing many iterations and retriangulations).
    nonlinear : bool, default False
        Use the nonlinear bar force ``k (L0 - L)`` with ``k = (L + L0) / (2 L0)`` of Kelly's DistMesh.jl.
    distance_cache : bool, default True
        Keep an upper bound of each point's sdf (its last value plus the distance it moved
        since, valid because an sdf is 1-Lipschitz) and evaluate the model only at points whose
        bound reaches ``-geps * h``.
    sort : {None, "hilbert"}, default None
        Reorder points along a Hilbert curve before triangulating, for memory locality.
    sort_interval : int, default 20
        Sort every ``sort_interval`` retriangulations (with ``sort="hilbert"``).
    termination : {"quality", "displacement"}, default "quality"
        ``"displacement"``: the reference's ``ptol`` rule only (in 3D it often takes hundreds
        to thousands of iterations, most of which no longer improve the mesh). ``"quality"``:
        stop when neither the worst nor the mean tetrahedron quality (volume-edge ratio)
        improved by more than ``quality_tol`` over the last ``quality_window`` iterations, or on
        the ``ptol`` rule, whichever comes first.
    quality_window : int, default 10
        Window of the quality termination, in iterations.
    quality_tol : float, default 0.002
        Smallest improvement of worst or mean quality over the window that keeps iterating.
    retriangulation : {"movement", "move_average"}, default "movement"
        ``"movement"``: the ``ttol`` rule. ``"move_average"``: also retriangulate when the
        latest per-iteration maximum move exceeds the average of the previous
        ``move_average_window`` ones (as in Kelly's DistMesh.jl study).
    move_average_window : int, default 7
        Number of previous maximum moves averaged by ``"move_average"``.
    delaunay : {"auto", "scipy", "gmsh"}, default "auto"
        Triangulation backend: ``scipy.spatial.Delaunay`` (Qhull) or
        ``gmsh.algorithm.tetrahedralize`` (needs the optional ``gmsh`` package; about 2.5 times
        faster). ``"auto"``: gmsh when it can be imported, scipy otherwise.
    parallel : bool, default True
        Triangulate on every core fepre may use (``fepre.config.workers``; gmsh's HXT kernel
        is multithreaded, Qhull is not) when the work pays for a parallel launch
        (:mod:`fepre.kernel_threads`). The result is the same either way. ``False`` keeps
        the triangulations on one thread (the compiled kernels still choose their threads
        by their work).
    seed : int, default 0
        Seed of every random choice (lattice jitter, size rejection); same seed, same mesh.
    slivers : bool, default True
        Run fepre's quality stage (:func:`fepre.distmesh.improve`: sliver removal and
        smoothing) on the result of the loop.
    thin_parts : {"trim", "keep"}, default "trim"
        What the quality stage does where cells stay below the targets in a part thinner than an
        element (a knife edge, a fin's tip, the sliver a box leaves of a lattice's wall), where
        no cell of size ``h`` fits: ``"trim"`` leaves such places out, a little at a time and at
        most 1% of the volume, so that every cell meets the targets (a ResolutionWarning names
        them, their volume and the ``hmin`` that keeps them), and drops a piece of under 1% of
        the cells that such a place cut off from the rest (nothing would hold it in a solver;
        a ResolutionWarning names it); ``"keep"`` keeps them with flat cells, and the pieces.
    features : bool, default True
        Keep the model's sharp edges and corners (:func:`fepre.features`): corners and nodes
        about ``h`` apart along every feature curve become fixed points, other points are kept
        out of the curves' neighbourhood (so each piece of a curve is a mesh edge), and the
        quality stage leaves them where they are. Features closer together than ``h/2`` are
        skipped with a :class:`fepre.FeatureWarning`.
    feature_angle : float, default 30
        Crease threshold of ``features``, degrees: patches whose normals differ by more are a
        sharp edge.
    check_resolution : bool, default True
        Look for material of the model that the mesh left out (walls, fins and pins thinner
        than ``h`` resolves; :func:`fepre.distmesh.lost_material`) and warn with a
        :class:`fepre.ResolutionWarning` naming where, how thick and the ``h`` that keeps it.
        Costs a narrow-band sample of the model at ``h/4``, a few percent of the meshing time.
    max_cells : int, default 20_000_000
        Largest mesh, in estimated cells, that :func:`fepre.distmesh` starts on: a larger one is
        refused with a ValueError before any work. Meshing takes about 1.4 KB of memory per
        cell (20M cells: about 28 GB); raise it on a machine with the memory.
    """

    deltat: float = 0.1
    ptol: float = 0.001
    ttol: float = 0.1
    fscale: float = 1.1
    geps: float = 0.1
    deps: Optional[float] = None
    maxiter: int = 1000
    distribution: str = "bcc"
    jitter: float = 0.01
    boundary_layer: bool = True
    nonlinear: bool = False
    distance_cache: bool = True
    sort: Optional[str] = None
    sort_interval: int = 20
    termination: str = "quality"
    quality_window: int = 10
    quality_tol: float = 0.002
    retriangulation: str = "movement"
    move_average_window: int = 7
    delaunay: str = "auto"
    parallel: bool = True
    seed: int = 0
    slivers: bool = True
    thin_parts: str = "trim"
    features: bool = True
    feature_angle: float = 30.0
    check_resolution: bool = True
    max_cells: int = 20_000_000

    def __post_init__(self) -> None:
        def put(name: str, value: Any) -> None:
            object.__setattr__(self, name, value)

        for name in ("deltat", "ptol", "ttol", "fscale", "geps"):
            put(name, positive_float(getattr(self, name), name))
        if self.deps is not None:
            put("deps", positive_float(self.deps, "deps"))
        if self.deltat > 1.0:
            raise ValueError(f"deltat must be in (0, 1]; got {shown(self.deltat)}")
        if self.geps >= 1.0:
            raise ValueError(f"geps must be in (0, 1) (a fraction of h); got {shown(self.geps)}")
        put("jitter", nonnegative_float(self.jitter, "jitter"))
        if self.jitter >= 0.25:
            raise ValueError(f"jitter must be in [0, 0.25) (a fraction of h); got {shown(self.jitter)}")
        put("quality_tol", nonnegative_float(self.quality_tol, "quality_tol"))
        for name in ("maxiter", "sort_interval", "quality_window", "move_average_window", "max_cells"):
            put(name, positive_int(getattr(self, name), name))
        put("feature_angle", positive_float(self.feature_angle, "feature_angle"))
        if self.feature_angle >= 180.0:
            raise ValueError(f"feature_angle must be in (0, 180) degrees; got {shown(self.feature_angle)}")
        for name in ("nonlinear", "distance_cache", "slivers", "boundary_layer", "features", "check_resolution",
                     "parallel"):
            value = getattr(self, name)
            if not isinstance(value, (bool, numbers.Integral)) or value not in (0, 1):
                raise TypeError(f"{name} must be True or False; got {shown(value)}")
            put(name, bool(value))
        choice(self.distribution, "distribution", DISTRIBUTIONS)
        choice(self.termination, "termination", TERMINATIONS)
        choice(self.retriangulation, "retriangulation", RETRIANGULATIONS)
        choice(self.delaunay, "delaunay", DELAUNAY_BACKENDS)
        choice(self.sort, "sort", SORTS)
        choice(self.thin_parts, "thin_parts", THIN_PARTS)
        if isinstance(self.seed, bool) or not isinstance(self.seed, numbers.Integral) or self.seed < 0:
            raise ValueError(f"seed must be a non-negative integer; got {shown(self.seed)}")
        put("seed", int(self.seed))


def resolve_options(options: DistMeshOptions | None, overrides: dict[str, Any]) -> DistMeshOptions:
    """``options`` (default options when None) with keyword ``overrides`` applied on top.

    Examples
    --------
    >>> resolve_options(None, {"deltat": 0.05}).deltat
    0.05
    """
    if options is None:
        options = DistMeshOptions()
    elif not isinstance(options, DistMeshOptions):
        raise TypeError(f"options must be a fepre.DistMeshOptions or None; got {type(options).__name__}")
    valid = [field.name for field in dataclasses.fields(DistMeshOptions)]
    unknown = sorted(set(overrides) - set(valid))
    if unknown:
        raise TypeError(
            f"unknown DistMesh option(s) {', '.join(map(repr, unknown))}; valid options: {', '.join(valid)}"
        )
    return dataclasses.replace(options, **overrides) if overrides else options
