"""Independent reference meshers for :func:`fepre.compare`: pytetwild and gmsh.

Both start from the same fine surface of the model (vtkFlyingEdges3D on a sampled grid), so
they see the part exactly as a user exporting an STL would. Their tetrahedra are returned as a
``pyvista.UnstructuredGrid`` of ``VTK_TETRA`` cells with positive volume (VTK's convention).

Examples
--------
>>> from fepre import sdf
>>> surface = reference_surface(sdf.sphere(1.0), spacing=0.1)
>>> surface.n_cells > 1000 and round(surface.volume, 1) == 4.2
True
"""

from __future__ import annotations

import importlib.util
import os
import tempfile
import time
from typing import Any, Callable

import numpy as np

from .arguments import as_bounds, positive_float
from .child_runs import gmsh_cells, run_child
from .errors import MeshingError

__all__ = ["reference_surface", "pytetwild_mesh", "gmsh_mesh", "REFERENCES", "available_references",
           "GMSH_OPTIONS", "REFERENCE_SETTINGS"]

# gmsh as its users run it for a volume mesh: Delaunay 3D, then its own optimiser and Netgen's.
GMSH_OPTIONS = {"Mesh.Algorithm3D": 1, "Mesh.Optimize": 1, "Mesh.OptimizeNetgen": 1}

#: How each reference mesher is run, as the report states it.
REFERENCE_SETTINGS = {
    "pytetwild": "fTetWild (pytetwild) with its defaults and ideal edge length edge_length_abs = h",
    "gmsh": (
        "gmsh on the same surface: patches classified at 40 deg and remeshed at size h "
        "(MeshSizeMin = MeshSizeMax = h), Delaunay 3D (Algorithm3D = 1) with Optimize = 1 and "
        "OptimizeNetgen = 1"
    ),
}


def reference_surface(model: Any, spacing: float, bounds: Any = None, sharp: bool = True):
    """The model's zero level set on a grid of ``spacing``: sharp where the model has edges.

    :func:`fepre.isosurface`: ``method="dual_contouring"`` for a model with sharp features
    (more than one surface patch), which keeps its edges and corners, else (and whenever that
    surface is not a closed manifold) ``"flying_edges"``. The grid covers ``bounds`` (default:
    the model's bounds) plus padding, so the surface is closed. The method is in the field data
    ``"surface_method"``.

    Parameters
    ----------
    model : SDF
    spacing : float
        Grid spacing; the surface's chords deviate from a curved boundary by O(spacing^2).
    bounds : ((min...), (max...)), optional
    sharp : bool
        Try dual contouring for a model with sharp features (default); False takes flying edges,
        whose triangles never cross each other (a mesher that refuses a dual-contoured surface
        whose facets cross at a corner takes that one).

    Returns
    -------
    pyvista.PolyData
        Closed triangle surface, outward normals.

    Examples
    --------
    >>> from fepre import sdf
    >>> reference_surface(sdf.sphere(1.0), 0.2).is_all_triangles
    True
    """
    import warnings

    from .surface import isosurface

    spacing = positive_float(spacing, "surface_spacing")
    if bounds is None and model.bounds is None:
        raise ValueError("bounds must be given for an unbounded model (its bounds are None)")
    lower, upper = (np.asarray(b, dtype=float) for b in as_bounds(bounds if bounds is not None else model.bounds))
    # two cells of padding, as fepre.sample gives a model's own bounds: the surface is closed
    bounds = (tuple(lower - 2 * spacing), tuple(upper + 2 * spacing))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # an empty surface is reported below as a MeshingError
        surface = None
        if sharp and (model.patch_count > 1 or len(model.singular_points())):
            sharp = isosurface(model, method="dual_contouring", spacing=spacing, bounds=bounds)
            if _closed_manifold(sharp):
                surface = sharp
        if surface is None:
            surface = isosurface(model, method="flying_edges", spacing=spacing, bounds=bounds)
    if surface.n_cells == 0:
        raise MeshingError("the model has no surface inside its bounds (the sampled values never change sign)")
    return surface


def _closed_manifold(surface) -> bool:
    """True when every edge of the triangle surface is shared by exactly two triangles."""
    triangles = np.asarray(surface.regular_faces, dtype=np.int64) if surface.n_cells else np.zeros((0, 3), np.int64)
    if len(triangles) == 0:
        return False
    edges = np.sort(triangles[:, [0, 1, 1, 2, 2, 0]].reshape(-1, 2), axis=1)
    _, counts = np.unique(edges, axis=0, return_counts=True)
    return bool(np.all(counts == 2))


def _positive_tets(points: np.ndarray, tets: np.ndarray):
    """A VTK_TETRA grid with every cell turned to positive volume and unused points dropped."""
    import pyvista as pv

    tets = np.asarray(tets, dtype=np.int64).copy()
    p0 = points[tets[:, 0]]
    volume = np.einsum(
        "ij,ij->i", np.cross(points[tets[:, 1]] - p0, points[tets[:, 2]] - p0), points[tets[:, 3]] - p0
    )
    negative = volume < 0
    tets[negative, 1], tets[negative, 2] = tets[negative, 2].copy(), tets[negative, 1].copy()
    used, inverse = np.unique(tets, return_inverse=True)
    tets = inverse.reshape(-1, 4)
    return pv.UnstructuredGrid({pv.CellType.TETRA: tets}, np.asarray(points[used], dtype=np.float64))


def pytetwild_mesh(surface: Any, h: float, *, seed: int = 0, timeout: float | None = None):
    """Tetrahedralise ``surface`` with fTetWild (pytetwild) at ideal edge length ``h``.

    With ``timeout`` (seconds), pytetwild runs in a separate Python process (``python -m
    fepre.references --pytetwild``), which is stopped after that long with a
    :class:`MeshingError` (fTetWild cannot be interrupted in-process; it takes over 15 minutes on
    some 100k-triangle models); the time pytetwild itself took is then in field data
    ``"reference_seconds"``.

    Examples
    --------
    >>> from fepre import sdf
    >>> mesh = pytetwild_mesh(reference_surface(sdf.sphere(1.0), 0.15), h=0.5)  # doctest: +SKIP
    """
    h = positive_float(h, "h")
    if timeout is not None:
        return _pytetwild_in_child(surface, h, positive_float(timeout, "timeout"))
    return _positive_tets(*_pytetwild_tetrahedra(surface, h))


def _pytetwild_tetrahedra(surface: Any, h: float) -> tuple[np.ndarray, np.ndarray]:
    import warnings

    import pytetwild

    # fTetWild writes "__tracked_surface.stl" into the working folder: run it in a scratch one
    with warnings.catch_warnings(), tempfile.TemporaryDirectory(prefix="fepre-pytetwild-") as scratch:
        warnings.simplefilter("ignore")  # pytetwild's use of a deprecated pyvista attribute
        previous = os.getcwd()
        os.chdir(scratch)
        try:
            grid = pytetwild.tetrahedralize_pv(surface, edge_length_abs=h, quiet=True)
        finally:
            os.chdir(previous)
    if grid.n_cells == 0:
        raise MeshingError("pytetwild returned no tetrahedra")
    tets = grid.cells_dict.get(10)
    if tets is None:
        raise MeshingError(f"pytetwild returned cells other than tetrahedra: {sorted(grid.cells_dict)}")
    return np.asarray(grid.points, dtype=np.float64), tets


def _pytetwild_in_child(surface: Any, h: float, timeout: float):
    import sys

    import pyvista as pv

    triangles = pv.PolyData(surface).triangulate()
    with tempfile.TemporaryDirectory(prefix="fepre-pytetwild-") as scratch:
        path, out = os.path.join(scratch, "surface.npz"), os.path.join(scratch, "mesh.npz")
        np.savez(path, points=np.asarray(triangles.points, dtype=np.float64),
                 faces=triangles.faces.reshape(-1, 4)[:, 1:].astype(np.int64))
        command = [sys.executable, "-m", "fepre.references", "--pytetwild", path, out, repr(float(h))]
        run_child(command, out, timeout=timeout, cwd=scratch, tool="pytetwild", doing="meshing the surface",
                  error=MeshingError)
        with np.load(out) as result:
            points, tets, seconds = result["points"], result["tets"], float(result["seconds"])
    grid = _positive_tets(points, tets)
    grid.field_data["reference_seconds"] = [seconds]
    return grid


def pytetwild_worker(arguments: list[str]) -> int:
    """``python -m fepre.references --pytetwild SURFACE.npz OUT.npz H``: pytetwild into OUT.npz."""
    import pyvista as pv

    path, out, h = arguments[0], arguments[1], float(arguments[2])
    try:
        import pytetwild  # noqa: F401 - loaded before the clock starts

        with np.load(path) as surface:
            polydata = pv.PolyData.from_regular_faces(surface["points"], surface["faces"])
        start = time.perf_counter()
        points, tets = _pytetwild_tetrahedra(polydata, h)
        seconds = time.perf_counter() - start
    except Exception as exc:  # noqa: BLE001 - reported to the parent as text
        with open(out + ".error", "w", encoding="utf-8") as handle:
            handle.write(f"{type(exc).__name__}: {exc}")
        return 1
    np.savez(out, points=points, tets=tets, seconds=np.array(seconds))
    return 0


def _gmsh_tetrahedra(path: str, h: float, seed: int, remesh: bool, hmin: float = 0.0, curvature: int = 0):
    """One gmsh run on the STL ``path``; returns (points, tets) of the volume mesh. With
    ``curvature`` > 0, sizes come from the surface's curvature (that many elements per 2 pi),
    between ``hmin`` and ``h``."""
    import gmsh

    gmsh.model.add("fepre-reference")
    try:
        gmsh.option.setNumber("Mesh.RandomSeed", int(seed) + 1)
        gmsh.merge(path)
        if remesh:
            gmsh.model.mesh.classifySurfaces(np.radians(40.0), True, True, np.pi)
            gmsh.model.mesh.createGeometry()
        surfaces = [tag for _, tag in gmsh.model.getEntities(2)]
        loop = gmsh.model.geo.addSurfaceLoop(surfaces)
        gmsh.model.geo.addVolume([loop])
        gmsh.model.geo.synchronize()
        gmsh.option.setNumber("Mesh.MeshSizeMin", hmin if curvature else (h if remesh else 0.0))
        gmsh.option.setNumber("Mesh.MeshSizeMax", h)
        gmsh.option.setNumber("Mesh.MeshSizeFromCurvature", int(curvature))
        for name, value in GMSH_OPTIONS.items():
            gmsh.option.setNumber(name, value)
        gmsh.model.mesh.generate(3)
        mesh = gmsh_cells(3, 4, 4)
        if mesh is None:
            raise MeshingError("gmsh produced no tetrahedra from the surface")
        return mesh
    finally:
        gmsh.model.remove()


def _gmsh_in_child(path: str, h: float, seed: int, hmin: float = 0.0, curvature: int = 0) -> tuple[np.ndarray, np.ndarray, str | None, float]:
    """Run in a child process: gmsh on the STL ``path``, remeshed, else with the surface kept."""
    import gmsh

    start = time.perf_counter()
    gmsh.initialize(interruptible=False)
    gmsh.option.setNumber("General.Terminal", 0)
    note = None
    try:
        try:
            points, tets = _gmsh_tetrahedra(path, h, seed, remesh=True, hmin=hmin, curvature=curvature)
        except Exception as exc:  # noqa: BLE001 - gmsh raises plain Exceptions
            note = f"surface kept as sampled (gmsh could not remesh it: {str(exc).strip()[:120]})"
            gmsh.finalize()  # a failed generate() can leave state behind: start afresh
            gmsh.initialize(interruptible=False)
            gmsh.option.setNumber("General.Terminal", 0)
            points, tets = _gmsh_tetrahedra(path, h, seed, remesh=False, hmin=hmin, curvature=curvature)
    finally:
        gmsh.finalize()
    return points, tets, note, time.perf_counter() - start


def gmsh_worker(arguments: list[str]) -> int:
    """``python -m fepre.references STL OUT.npz H SEED [HMIN CURVATURE]``: mesh the STL with gmsh into OUT.npz.

    A fresh interpreter, not a multiprocessing child: a spawned child imports the parent's
    ``__main__``, which re-runs a user's script that has no ``if __name__ == "__main__"`` guard.
    """
    path, out, h, seed = arguments[0], arguments[1], float(arguments[2]), int(arguments[3])
    hmin, curvature = (float(arguments[4]), int(arguments[5])) if len(arguments) > 5 else (0.0, 0)
    try:
        points, tets, note, seconds = _gmsh_in_child(path, h, seed, hmin, curvature)
    except Exception as exc:  # noqa: BLE001 - reported to the parent as text
        with open(out + ".error", "w", encoding="utf-8") as handle:
            handle.write(f"{type(exc).__name__}: {exc}")
        return 1
    np.savez(out, points=points, tets=tets, note=np.array(note or ""), seconds=np.array(seconds))
    return 0


def gmsh_mesh(surface: Any, h: float, *, seed: int = 0, timeout: float = 300.0, hmin: float | None = None,
              curvature: int = 0):
    """Tetrahedralise ``surface`` with gmsh: the surface is remeshed at size ``h``, then meshed in 3D.

    The triangles are classified into patches (``classifySurfaces``, 40 degree feature angle),
    turned into a parametrised geometry, remeshed and filled with Delaunay tetrahedra, which
    gmsh's optimiser and Netgen's then improve (:data:`GMSH_OPTIONS`, as gmsh users mesh). When gmsh
    cannot remesh the patches (e.g. bumpy sharp edges of a sampled surface), the surface is kept
    as it is and only the volume is meshed (size ``h`` inside); the grid's field data
    ``"reference_note"`` then says so.

    gmsh runs in a separate Python process (``python -m fepre.references``, which never imports
    the caller's script): on some surfaces it aborts the whole process (seen: "Failed during
    initial partitioning") or never returns; either is reported as a :class:`MeshingError` (the
    process is stopped after ``timeout`` seconds). The time gmsh itself took is stored in field
    data ``"reference_seconds"``.

    ``curvature`` > 0 sizes the mesh from the surface's curvature as gmsh users grade a mesh
    (``Mesh.MeshSizeFromCurvature``: that many elements per 2 pi), between ``hmin`` and ``h``.
    """
    import sys

    h = positive_float(h, "h")
    timeout = positive_float(timeout, "timeout")
    with tempfile.TemporaryDirectory(prefix="fepre-gmsh-") as scratch:
        path = os.path.join(scratch, "surface.stl")
        out = os.path.join(scratch, "mesh.npz")
        surface.save(path, binary=True)
        command = [sys.executable, "-m", "fepre.references", path, out, repr(float(h)), str(int(seed))]
        if curvature:
            command += [repr(float(positive_float(hmin, "hmin") if hmin is not None else 0.0)), str(int(curvature))]
        run_child(command, out, timeout=timeout, cwd=scratch, tool="gmsh", doing="meshing the surface", error=MeshingError)
        with np.load(out) as result:
            points, tets = result["points"], result["tets"]
            note, seconds = str(result["note"]), float(result["seconds"])
    grid = _positive_tets(points, tets)
    if note:
        grid.field_data["reference_note"] = [note]
    grid.field_data["reference_seconds"] = [seconds]
    return grid


REFERENCES: dict[str, tuple[str, Callable[..., Any]]] = {
    "pytetwild": ("pytetwild", pytetwild_mesh),
    "gmsh": ("gmsh", gmsh_mesh),
}


def available_references() -> list[str]:
    """Names of the reference meshers whose package is installed."""
    return [name for name, (package, _) in REFERENCES.items() if importlib.util.find_spec(package) is not None]


def run_reference(name: str, surface: Any, h: float, seed: int = 0):
    """Mesh ``surface`` with reference ``name``; returns ``(mesh, seconds)``."""
    if name not in REFERENCES:
        raise ValueError(f"references must name {', '.join(map(repr, REFERENCES))}; got {name!r}")
    package, mesher = REFERENCES[name]
    if importlib.util.find_spec(package) is None:
        raise ValueError(f"reference {name!r} needs the package {package!r}, which is not installed")
    start = time.perf_counter()
    mesh = mesher(surface, h, seed=seed)
    seconds = time.perf_counter() - start
    if "reference_seconds" in mesh.field_data:  # measured inside the mesher's own process
        seconds = float(mesh.field_data["reference_seconds"][0])
    mesh.field_data["reference_settings"] = [REFERENCE_SETTINGS[name]]
    return mesh, seconds


if __name__ == "__main__":
    import sys

    sys.exit(pytetwild_worker(sys.argv[2:]) if sys.argv[1:2] == ["--pytetwild"] else gmsh_worker(sys.argv[1:]))
