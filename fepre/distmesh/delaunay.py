"""Delaunay tetrahedralisation backends: scipy (Qhull) and gmsh (optional)."""

from __future__ import annotations

import functools

import numpy as np

from ..errors import MeshingError
from .._cell_kernels import canonical_cells

__all__ = ["tetrahedralize", "loop_tetrahedralize", "gmsh_available"]


@functools.lru_cache(maxsize=1)
def gmsh_available() -> bool:
    """True when the optional ``gmsh`` package can be imported."""
    try:
        import gmsh  # noqa: F401
    except ImportError:
        return False
    return True


def _scipy(points: np.ndarray) -> np.ndarray:
    from scipy.spatial import Delaunay, QhullError

    try:
        return Delaunay(points).simplices.astype(np.int64)
    except QhullError:
        pass
    # Many points exactly on a few planes (the faces of a box at a fine h) can make Qhull's
    # facet merging fail ("wide merge error"); joggling the input by ~1e-11 of its size is
    # Qhull's own remedy and gives a triangulation without merged facets
    try:
        return Delaunay(points, qhull_options="QJ Qbb").simplices.astype(np.int64)
    except QhullError as exc:
        first_line = str(exc).strip().splitlines()[0] if str(exc).strip() else type(exc).__name__
        raise MeshingError(f"Delaunay triangulation (Qhull) failed on {len(points)} points: {first_line}") from exc


@functools.lru_cache(maxsize=1)
def _c_library():
    """The C library (for its ``signal``), or None where it cannot be loaded."""
    import ctypes
    import ctypes.util

    for name in (None, ctypes.util.find_library("c"), "msvcrt"):
        try:
            library = ctypes.CDLL(name)
            library.signal  # noqa: B018 - the attribute lookup is the check
            return library
        except (OSError, AttributeError, TypeError):
            continue
    return None


def initialize_gmsh(**options) -> None:
    """``gmsh.initialize(**options)``, keeping Python's SIGPIPE disposition.

    gmsh sets SIGPIPE to the default action (end the process), so after any DistMesh a write to
    a closed pipe or socket killed the user's Python (exit 141) instead of raising
    ``BrokenPipeError``; Python ignores SIGPIPE unless told otherwise, and so does fepre's process
    after this.
    """
    import signal

    import gmsh

    before = signal.getsignal(signal.SIGPIPE) if hasattr(signal, "SIGPIPE") else None
    gmsh.initialize(**options)
    library = _c_library()
    if before == signal.SIG_IGN and library is not None:
        import ctypes

        library.signal.restype = ctypes.c_void_p
        library.signal.argtypes = [ctypes.c_int, ctypes.c_void_p]
        library.signal(int(signal.SIGPIPE), 1)  # SIG_IGN


#: gmsh options ``_gmsh`` sets for its call (and puts back)
_GMSH_OPTIONS = ("Mesh.Algorithm3D", "General.NumThreads", "General.Verbosity")


def _gmsh(points: np.ndarray, threads: int | None = None) -> np.ndarray:
    """Delaunay cells of ``points`` by gmsh's HXT kernel on ``threads`` threads (default:
    ``fepre.config.workers``), without the cells next to the convex hull that gmsh's default
    kernel leaves out.

    HXT (``Mesh.Algorithm3D = 10``) is 3.5-4 times faster than gmsh's default kernel on
    DistMesh's point sets and breaks ties between co-spherical points symbolically (the same
    cells for any number of threads, in any run). It returns the whole triangulation of the
    convex hull, whose long cells across a concave region at the hull (and near-flat ones on a
    planar hull face) the final mesh's choice of cells is not made for: the default kernel
    starts from a box 1.3 times the points' bounding box and drops the cells at its corners,
    so the same eight corners go in here and their cells come out.
    """
    try:
        import gmsh
    except ImportError as exc:
        raise ImportError(
            "delaunay='gmsh' needs the optional gmsh package (pip install gmsh); "
            "use delaunay='scipy' instead"
        ) from exc
    started = gmsh.isInitialized()
    if not started:
        initialize_gmsh(readConfigFiles=False)
        gmsh.option.setNumber("General.Terminal", 0)
    saved = [gmsh.option.getNumber(name) for name in _GMSH_OPTIONS]
    points, kept = _distinct(np.asarray(points, dtype=np.float64))
    n = len(points)
    boxed = np.concatenate([points, _box_corners(points)])
    omp_threads = _OpenMPThreads(gmsh, threads or _cores())
    try:
        gmsh.option.setNumber("Mesh.Algorithm3D", 10)
        gmsh.option.setNumber("General.NumThreads", threads or _cores())
        gmsh.option.setNumber("General.Verbosity", 0)  # HXT reports skipped duplicates one line each
        with omp_threads:
            result = gmsh.algorithm.tetrahedralize(boxed.ravel())
        tets = np.asarray(result[0] if isinstance(result, tuple) else result, dtype=np.int64)
    except Exception as exc:  # gmsh raises plain Exception
        raise MeshingError(f"gmsh tetrahedralize failed on {len(points)} points: {exc}") from exc
    finally:
        if started:
            for name, value in zip(_GMSH_OPTIONS, saved):
                gmsh.option.setNumber(name, value)
        else:
            gmsh.finalize()
    tets = tets.reshape(-1, 4) - 1
    tets = tets[(tets < n).all(axis=1)]
    if kept is not None:
        tets = kept[tets]
    if len(tets) == 0 and n >= 4:
        # nothing but box cells: (nearly) coplanar input; Qhull says why
        return _scipy(points)
    return tets


class _OpenMPThreads:
    """The OpenMP thread count of the calling thread set to ``threads`` for a ``with`` block, and
    put back. ``gmsh.algorithm.tetrahedralize`` ignores ``General.NumThreads`` (gmsh applies it
    when it meshes a model): HXT's parallel regions take OpenMP's default, every core. Measured on
    500 points on a loaded 2-core machine: 22 ms a call with ``General.NumThreads = 1``, 4.6 ms
    with OpenMP's count set to 1. Does nothing where gmsh's library does not export the
    OpenMP calls."""

    def __init__(self, gmsh, threads: int) -> None:
        library = getattr(gmsh, "lib", None)
        usable = all(hasattr(library, name) for name in ("omp_set_num_threads", "omp_get_max_threads"))
        self.library = library if usable else None
        self.threads = int(threads)
        self.previous = None

    def __enter__(self) -> None:
        if self.library is not None:
            self.previous = int(self.library.omp_get_max_threads())
            self.library.omp_set_num_threads(self.threads)

    def __exit__(self, *exc) -> None:
        if self.library is not None and self.previous is not None:
            self.library.omp_set_num_threads(self.previous)


def _distinct(points: np.ndarray) -> tuple[np.ndarray, np.ndarray | None]:
    """``points`` without exact repeats (each kept once, at its first index) and the indices kept
    (None when there is no repeat).

    HXT skips a repeated point itself but prints a line for it on the terminal (a DistMesh
    boundary point projected onto a triangle-mesh model's vertex lands on the feature corner
    there, bit for bit); the repeat is in no cell either way. Repeats share their x, so only
    the runs of equal x in one sort are compared (30-45 ms for 1M random points, HXT 11 s).
    """
    order = np.argsort(points[:, 0])
    x = points[order, 0]
    same_x = np.flatnonzero(x[1:] == x[:-1])
    if same_x.size == 0:
        return points, None
    repeated = np.zeros(len(points), dtype=bool)
    candidates = np.unique(np.concatenate([order[same_x], order[same_x + 1]]))
    _, first = np.unique(points[candidates], axis=0, return_index=True)
    repeated[candidates] = True
    repeated[candidates[first]] = False
    if not repeated.any():
        return points, None
    kept = np.flatnonzero(~repeated)
    return points[kept], kept


def _box_corners(points: np.ndarray) -> np.ndarray:
    """The corners of the points' bounding box scaled by 1.3 about its centre: the box gmsh's
    default kernel starts from (``initialCube`` in gmsh's delaunay3d.cpp)."""
    lower, upper = points.min(axis=0), points.max(axis=0)
    centre, half = 0.5 * (lower + upper), 0.65 * (upper - lower)
    low, high = centre - half, centre + half
    return np.array([[x, y, z] for z in (low[2], high[2]) for y in (low[1], high[1]) for x in (low[0], high[0])])


def _cores() -> int:
    from ..config import config

    return config.resolve_workers(None)


def tetrahedralize(
    points: np.ndarray, backend: str = "scipy", scale: float = 1.0, keep_flat: bool = False
) -> np.ndarray:
    """Delaunay tetrahedra (M, 4) of ``points``, positively oriented, none of (near) zero volume.

    Co-spherical input (lattices) makes Qhull return flat tetrahedra; they are removed here
    (``|V| <= 1e-10 scale^3``), which is harmless inside the DistMesh loop where only the edges
    matter. The final mesh is checked separately. ``keep_flat=True`` keeps them (in the
    backend's vertex order, so their orientation is undetermined), for the final mesh to flip
    them away (:func:`fepre.distmesh.finalize.final_mesh`). ``backend`` is ``"scipy"``,
    ``"gmsh"`` (gmsh's HXT kernel on every core fepre may use when the work pays for a parallel
    launch, see :func:`_gmsh` and :mod:`fepre.kernel_threads`) or ``"auto"``
    (gmsh when it can be imported).

    Examples
    --------
    >>> from fepre.quality import signed_volumes
    >>> cube = np.array([[i, j, k] for i in (0, 1) for j in (0, 1) for k in (0, 1)], float)
    >>> tets = tetrahedralize(cube)
    >>> bool((signed_volumes(cube, tets) > 0).all()), round(float(signed_volumes(cube, tets).sum()), 9)
    (True, 1.0)
    """
    points = _near_origin(points)
    return _canonical(points, _triangulate(points, backend, _threads_for(len(points))), scale, keep_flat)


def loop_tetrahedralize(points: np.ndarray, backend: str, scale: float, parallel: bool = True) -> np.ndarray:
    """The DistMesh loop's triangulation: :func:`tetrahedralize`'s cells (gmsh's on every core
    fepre may use with ``parallel`` when the work pays for it, else on one), but in the backend's order: the loop needs
    their bars, whose order :func:`~fepre.distmesh.forces.bars_of` fixes, and sorting the rows
    took a third of the triangulation's time; :func:`sorted_cells` sorts them.

    Examples
    --------
    >>> cube = np.array([[i, j, k] for i in (0, 1) for j in (0, 1) for k in (0, 1)], float)
    >>> len(loop_tetrahedralize(cube, "scipy", 1.0))
    6
    """
    points = _near_origin(points)
    tets = _triangulate(points, backend, _threads_for(len(points)) if parallel else 1)
    return _canonical(points, tets, scale, False, ordered=False)


#: HXT's serial time per point (measured: about 1 us on DistMesh's point sets)
_HXT_SECONDS_PER_POINT = 1.0e-6


def _threads_for(n_points: int) -> int:
    """gmsh's threads for a triangulation of ``n_points``: every core fepre may use
    when the work pays for a parallel launch now (:func:`fepre.kernel_threads.choose_threads`;
    HXT's threads are libgomp's, as numba's kernels'), else one. The cells are the same."""
    from ..kernel_threads import choose_threads

    return choose_threads(n_points, _HXT_SECONDS_PER_POINT, _cores())


def _near_origin(points: np.ndarray) -> np.ndarray:
    """``points`` moved near the origin when they are far from it (:func:`fepre.placement.local_offset`
    of their box; the same array otherwise): Qhull's precision and the flat cells' volumes follow
    the coordinates' size, HXT's initial box too."""
    from ..placement import local_offset

    points = np.asarray(points, dtype=np.float64)
    if len(points) == 0:
        return points
    offset = local_offset(points.min(axis=0), points.max(axis=0))
    return points - offset if offset.any() else points


def _triangulate(points: np.ndarray, backend: str, threads: int | None) -> np.ndarray:
    """The backend's cells of ``points``, as it returns them."""
    if len(points) < 4:
        raise MeshingError(f"Delaunay triangulation needs at least 4 points; got {len(points)}")
    return _gmsh(points, threads) if resolve_backend(backend) == "gmsh" else _scipy(points)


def resolve_backend(backend: str) -> str:
    """``"gmsh"`` or ``"scipy"``: ``"auto"`` is gmsh when it can be imported."""
    if backend == "auto":
        return "gmsh" if gmsh_available() else "scipy"
    return backend


def sorted_cells(tets: np.ndarray, n_points: int) -> np.ndarray:
    """Cells in canonical form (corners sorted but for orientation) in :func:`tetrahedralize`'s
    row order: by the two smallest corners, then the other two."""
    n = np.int64(n_points)
    # (a, b) are the two smallest corners, {c, d} the others: two int64 keys identify a cell
    return tets[np.lexsort((tets[:, 2] * n + tets[:, 3], tets[:, 0] * n + tets[:, 1]))]


def _canonical(points: np.ndarray, tets: np.ndarray, scale: float, keep_flat: bool, ordered: bool = True) -> np.ndarray:
    # canonical form (sorted corners, then the orientation fixed by swapping the last two, rows
    # sorted): the result does not depend on the backend's output order
    tets = np.ascontiguousarray(tets, dtype=np.int64)
    volumes = canonical_cells(points, tets)
    if not keep_flat:
        tets = tets[np.abs(volumes) > 1e-10 * scale**3]
    return sorted_cells(tets, len(points)) if ordered else tets
