"""CAD files as surface models: STEP and BREP tessellated by gmsh's OpenCASCADE kernel.

Engineers hold their parts as STEP files more often than as STL. :func:`read_cad_surface` imports
one with OpenCASCADE (through gmsh, already a dependency), unites its solids when it holds
several (an assembly's bodies that touch or overlap become one solid, as a mesh model of their
STL would; :func:`~fepre.sdf.meshmodel.cad_solids.cad_solids` keeps each its own region), and tessellates the boundary finely enough that the model is the part:
:data:`SEGMENTS` triangles per turn of a curved face (a chord sags 0.12% of its radius; a
cylinder's area falls 0.16% short), planar faces as coarse as their outline allows.

gmsh runs in a separate interpreter (``python -m fepre.sdf.meshmodel.cad_files``): OpenCASCADE
can abort the process on a broken file, which must not take the caller's session with it.
"""

from __future__ import annotations

import os
import sys
import tempfile
from pathlib import Path

import numpy as np

from ...child_runs import gmsh_cells, run_child

__all__ = ["read_cad_surface", "CAD_SUFFIXES", "FACE_SUFFIXES", "SEGMENTS"]

#: CAD files OpenCASCADE imports as solids. IGES files are refused: they hold faces, which
#: OpenCASCADE sews into a shell whose bore edges gmsh then meshes twice (a plate with a bore
#: written as IGES came back with 256 open edges and no solid).
CAD_SUFFIXES = (".step", ".stp", ".brep")
#: CAD files that hold faces, not solids.
FACE_SUFFIXES = (".iges", ".igs")
#: Triangles per turn (2 pi) of a curved face's curvature.
SEGMENTS = 64
#: Seconds a file may take to import and tessellate.
TIMEOUT = 600.0


def read_cad_surface(path: str | os.PathLike, *, timeout: float = TIMEOUT):
    """The boundary of the solids of a STEP or BREP file, tessellated, as a PolyData.

    Raises
    ------
    ValueError
        OpenCASCADE could not import the file, it holds no surface, or tessellating it failed
        or took longer than ``timeout`` seconds.

    Examples
    --------
    >>> surface = read_cad_surface("bracket.step")   # doctest: +SKIP
    """
    import pyvista as pv

    path = Path(path)
    with tempfile.TemporaryDirectory(prefix="fepre-cad-") as scratch:
        out = os.path.join(scratch, "surface.npz")
        command = [sys.executable, "-m", "fepre.sdf.meshmodel.cad_files", str(path.resolve()), out]
        run_child(command, out, timeout=timeout, cwd=scratch, tool="OpenCASCADE", doing="reading it", error=ValueError)
        with np.load(out) as result:
            points, triangles, solids = result["points"], result["triangles"], int(result["solids"])
    if solids == 0:
        from ...errors import RepairWarning, warn_user

        warn_user(f"{path} holds no solid: its faces were tessellated and taken as the surface of one (check "
                  "that they close it, or export the solid)", RepairWarning)
    return pv.PolyData.from_regular_faces(points, triangles)


def import_shapes(path: str) -> None:
    """In the child, gmsh initialised: import ``path`` into OpenCASCADE (a ValueError if it cannot)."""
    import gmsh

    gmsh.option.setNumber("General.Terminal", 0)
    try:
        gmsh.model.occ.importShapes(path)
    except Exception as exc:  # noqa: BLE001 - gmsh raises plain Exceptions
        raise ValueError(f"could not import the file ({str(exc).strip()[:200]})") from None
    gmsh.model.occ.synchronize()


def mesh_faces() -> None:
    """In the child: tessellate every face, :data:`SEGMENTS` per turn, planar faces up to D/20.

    The sizes inside a face come from its own curvature, not from its edges: a plate with 135
    small holes, the holes' fine edges carried into its flat faces, was 1.08M triangles and 27 s
    of tessellation; its flat faces now take few (444k triangles, 10 s).
    """
    import gmsh

    lower, upper = np.split(np.asarray(gmsh.model.getBoundingBox(-1, -1)), 2)
    gmsh.option.setNumber("Mesh.MeshSizeFromCurvature", SEGMENTS)
    gmsh.option.setNumber("Mesh.MeshSizeMax", float(np.linalg.norm(upper - lower)) / 20.0)
    gmsh.option.setNumber("Mesh.MeshSizeExtendFromBoundary", 0)
    try:
        gmsh.model.mesh.generate(2)
    except Exception as exc:  # noqa: BLE001
        raise ValueError(f"gmsh could not tessellate its faces ({str(exc).strip()[:200]})") from None


def _tessellate(path: str) -> tuple[np.ndarray, np.ndarray, int]:
    """In the child: import ``path``, unite its solids and mesh their boundary; the number of
    solids the file held."""
    import gmsh

    gmsh.initialize(interruptible=False)
    try:
        import_shapes(path)
        volumes = gmsh.model.getEntities(3)
        if len(volumes) > 1:
            try:
                gmsh.model.occ.fuse(volumes[:1], volumes[1:])
                gmsh.model.occ.synchronize()
            except Exception:  # noqa: BLE001 - the bodies' own boundaries are then united by the repair
                pass
        if not gmsh.model.getEntities(2):
            raise ValueError("the file holds no surface (no face to tessellate)")
        mesh_faces()
        surface = gmsh_cells(2, 2, 3)  # gmsh gives a solid's faces' triangles facing out of it
        if surface is None:
            raise ValueError("tessellating its faces gave no triangles")
        return (*surface, len(volumes))
    finally:
        gmsh.finalize()


def main(arguments: list[str]) -> int:
    """``python -m fepre.sdf.meshmodel.cad_files CAD OUT.npz``: the tessellated boundary into OUT.npz."""
    path, out = arguments
    try:
        points, triangles, solids = _tessellate(path)
    except ValueError as exc:
        Path(out + ".error").write_text(str(exc), encoding="utf-8")
        return 1
    np.savez(out, points=points, triangles=triangles, solids=solids)
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
