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
    """The C library gmsh draws its random numbers from (``rand``), or None where it cannot be loaded."""
    import ctypes
    import ctypes.util

    for name in (None, ctypes.util.find_library("c"), "msvcrt"):
        try:
            library = ctypes.CDLL(name)
            library.srand  # noqa: B018 - the attribute lookup is the check
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


def _reset_c_random() -> None:
    """Seed the C library's ``rand``: gmsh's Delaunay kernel breaks ties on co-spherical points
    (lattices, nodes on one plane or circle) with it, so without this the same points gave a
    different triangulation on every call in a process (the same in each fresh process)."""
    library = _c_library()
    if library is not None:
        library.srand(1)


def _gmsh(points: np.ndarray) -> np.ndarray:
    try:
        import gmsh
    except ImportError as exc:
        raise ImportError(
            "delaunay='gmsh' needs the optional gmsh package (pip install gmsh); "
            "use delaunay='scipy' instead"
        ) from exc
    # gmsh inserts the points in the order given: lattice or sorted order is its worst case
    # (3.7 times slower than random order on 52k points of the h=0.05 sphere); a fixed
    # pseudo-random order keeps the result reproducible
    order = np.random.default_rng(0).permutation(len(points))
    points = points[order]
    started = gmsh.isInitialized()
    if not started:
        initialize_gmsh(readConfigFiles=False)
        gmsh.option.setNumber("General.Terminal", 0)
    _reset_c_random()
    try:
        result = gmsh.algorithm.tetrahedralize(points.ravel())
        tets = np.asarray(result[0] if isinstance(result, tuple) else result, dtype=np.int64)
    except Exception as exc:  # gmsh raises plain Exception
        raise MeshingError(f"gmsh tetrahedralize failed on {len(points)} points: {exc}") from exc
    finally:
        if not started:
            gmsh.finalize()
    return order[tets.reshape(-1, 4) - 1]


def tetrahedralize(
    points: np.ndarray, backend: str = "scipy", scale: float = 1.0, keep_flat: bool = False
) -> np.ndarray:
    """Delaunay tetrahedra (M, 4) of ``points``, positively oriented, none of (near) zero volume.

    Co-spherical input (lattices) makes Qhull return flat tetrahedra; they are removed here
    (``|V| <= 1e-10 scale^3``), which is harmless inside the DistMesh loop where only the edges
    matter. The final mesh is checked separately. ``keep_flat=True`` keeps them (in the
    backend's vertex order, so their orientation is undetermined), for the final mesh to flip
    them away (:func:`fepre.distmesh.finalize.final_mesh`).

    Examples
    --------
    >>> from fepre.quality import signed_volumes
    >>> cube = np.array([[i, j, k] for i in (0, 1) for j in (0, 1) for k in (0, 1)], float)
    >>> tets = tetrahedralize(cube)
    >>> bool((signed_volumes(cube, tets) > 0).all()), round(float(signed_volumes(cube, tets).sum()), 9)
    (True, 1.0)
    """
    if len(points) < 4:
        raise MeshingError(f"Delaunay triangulation needs at least 4 points; got {len(points)}")
    if backend == "auto":
        backend = "gmsh" if gmsh_available() else "scipy"
    tets = _gmsh(points) if backend == "gmsh" else _scipy(points)
    return _canonical(points, tets, scale, keep_flat)


def loop_tetrahedralize(
    points: np.ndarray, backend: str, scale: float, spacing: float, parallel: bool = True
) -> tuple[np.ndarray, bool]:
    """The DistMesh loop's triangulation and whether it is the exact one: with ``parallel``, on
    large point sets with gmsh and two cores, two overlapping slabs at once
    (:func:`~fepre.distmesh.slab_delaunay.split_delaunay`, ``spacing`` the largest edge length
    at the cut), else :func:`tetrahedralize`.

    Examples
    --------
    >>> cube = np.array([[i, j, k] for i in (0, 1) for j in (0, 1) for k in (0, 1)], float)
    >>> tets, exact = loop_tetrahedralize(cube, "scipy", 1.0, 1.0)
    >>> len(tets), exact
    (6, True)
    """
    from .slab_delaunay import split_delaunay

    if parallel and len(points) >= 4:
        tets = split_delaunay(points, spacing, backend)
        if tets is not None:
            return _canonical(points, tets, scale, False), False
    return tetrahedralize(points, backend, scale), True


def _canonical(points: np.ndarray, tets: np.ndarray, scale: float, keep_flat: bool) -> np.ndarray:
    # canonical form (sorted corners, then the orientation fixed by swapping the last two, rows
    # sorted): the result does not depend on the backend's output order
    tets = np.ascontiguousarray(tets, dtype=np.int64)
    volumes = canonical_cells(points, tets)
    if not keep_flat:
        tets = tets[np.abs(volumes) > 1e-10 * scale**3]
    n = np.int64(len(points))
    # (a, b) are the two smallest corners, {c, d} the others: two int64 keys identify a cell
    return tets[np.lexsort((tets[:, 2] * n + tets[:, 3], tets[:, 0] * n + tets[:, 1]))]
