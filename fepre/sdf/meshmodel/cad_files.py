"""CAD files as surface models: STEP and BREP tessellated by gmsh's OpenCASCADE kernel.

Engineers hold their parts as STEP files more often than as STL. :func:`read_cad_surface` imports
one with OpenCASCADE (through gmsh, already a dependency), unites its solids when it holds
several (an assembly's bodies that touch or overlap become one solid, as a mesh model of their
STL would), and tessellates the boundary finely enough that the model is the part:
:data:`SEGMENTS` triangles per turn of a curved face (a chord sags 0.12% of its radius; a
cylinder's area falls 0.16% short), planar faces as coarse as their outline allows.

gmsh runs in a separate interpreter (``python -m fepre.sdf.meshmodel.cad_files``): OpenCASCADE
can abort the process on a broken file, which must not take the caller's session with it.
"""

from __future__ import annotations

import os
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np

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
        try:
            done = subprocess.run(command, capture_output=True, text=True, timeout=timeout, cwd=scratch)
        except subprocess.TimeoutExpired:
            raise ValueError(f"OpenCASCADE did not import and tessellate it within {timeout:g} s") from None
        if os.path.exists(out + ".error"):
            raise ValueError(Path(out + ".error").read_text(encoding="utf-8"))
        if done.returncode != 0 or not os.path.exists(out):
            last = (done.stderr or done.stdout).strip().splitlines()[-1:] or ["no message"]
            raise ValueError(f"OpenCASCADE's process died importing it (exit code {done.returncode}: {last[0][:200]})")
        with np.load(out) as result:
            points, triangles = result["points"], result["triangles"]
    return pv.PolyData.from_regular_faces(points, triangles)


def _tessellate(path: str) -> tuple[np.ndarray, np.ndarray]:
    """In the child: import ``path``, unite its solids and mesh their boundary."""
    import gmsh

    gmsh.initialize(interruptible=False)
    try:
        gmsh.option.setNumber("General.Terminal", 0)
        try:
            gmsh.model.occ.importShapes(path)
        except Exception as exc:  # noqa: BLE001 - gmsh raises plain Exceptions
            raise ValueError(f"OpenCASCADE could not import it ({str(exc).strip()[:200]})") from None
        gmsh.model.occ.synchronize()
        volumes = gmsh.model.getEntities(3)
        if len(volumes) > 1:
            try:
                gmsh.model.occ.fuse(volumes[:1], volumes[1:])
                gmsh.model.occ.synchronize()
            except Exception:  # noqa: BLE001 - the bodies' own boundaries are then united by the repair
                pass
        if not gmsh.model.getEntities(2):
            raise ValueError("it holds no surface (no face to tessellate)")
        lower, upper = np.split(np.asarray(gmsh.model.getBoundingBox(-1, -1)), 2)
        gmsh.option.setNumber("Mesh.MeshSizeFromCurvature", SEGMENTS)
        gmsh.option.setNumber("Mesh.MeshSizeMax", float(np.linalg.norm(upper - lower)) / 20.0)
        gmsh.option.setNumber("Mesh.MeshSizeExtendFromBoundary", 1)
        try:
            gmsh.model.mesh.generate(2)
        except Exception as exc:  # noqa: BLE001
            raise ValueError(f"gmsh could not tessellate its faces ({str(exc).strip()[:200]})") from None
        tags, coordinates, _ = gmsh.model.mesh.getNodes()
        # gmsh gives a solid's faces' triangles facing out of it
        types, _, nodes = gmsh.model.mesh.getElements(2)
        if 2 not in list(types):
            raise ValueError("tessellating its faces gave no triangles")
        triangles = np.asarray(nodes[list(types).index(2)], dtype=np.int64).reshape(-1, 3)
        order = np.argsort(tags)
        triangles = np.searchsorted(tags[order], triangles)
        return np.asarray(coordinates, dtype=np.float64).reshape(-1, 3)[order], triangles
    finally:
        gmsh.finalize()


def main(arguments: list[str]) -> int:
    """``python -m fepre.sdf.meshmodel.cad_files CAD OUT.npz``: the tessellated boundary into OUT.npz."""
    path, out = arguments
    try:
        points, triangles = _tessellate(path)
    except ValueError as exc:
        Path(out + ".error").write_text(str(exc), encoding="utf-8")
        return 1
    np.savez(out, points=points, triangles=triangles)
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
