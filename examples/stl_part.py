"""A part that arrives as an STL file: read it as a model, repair it, mesh it, hollow it.

Writes ``block.stl`` (an OpenCASCADE block with two bolt holes and a slot, as a CAD system
exports it) and a copy with a hole and flipped triangles, reads both back with
:func:`fepre.sdf.mesh`, meshes the damaged copy for a solver with the block's sharp edges kept,
and writes a lighter version for printing: a gyroid core under a solid skin.

Run: ``python examples/stl_part.py [OUTDIR]``
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pyvista as pv

import fepre
from fepre import sdf
from fepre.parts import write_mounting_block_stl


def damaged_copy(path: Path, out: Path) -> Path:
    """The STL with a hole near one corner and every tenth triangle turned over."""
    surface = pv.read(path)
    faces = surface.faces.reshape(-1, 4)[:, 1:].copy()
    centroids = np.asarray(surface.points)[faces].mean(axis=1)
    faces = faces[np.linalg.norm(centroids - (35.0, 25.0, 0.0), axis=1) > 2.5]
    faces[::10] = faces[::10, ::-1]
    pv.PolyData(np.asarray(surface.points), np.column_stack([np.full(len(faces), 3), faces]).ravel()).save(out)
    return out


def main(outdir: Path) -> dict:
    outdir.mkdir(parents=True, exist_ok=True)
    clean = sdf.mesh(write_mounting_block_stl(outdir / "block.stl"))
    damaged = sdf.mesh(damaged_copy(outdir / "block.stl", outdir / "block_damaged.stl"))
    print("damaged file:", damaged.repaired.summary())
    print(f"volume {damaged.volume:.1f} (clean file {clean.volume:.1f})")

    mesh = fepre.distmesh(damaged, h=2.5)  # the block's edges and corners are feature curves
    print(mesh.fepre.summary())
    fepre.export(mesh, outdir / "block.inp")

    light = sdf.infill(clean, sdf.gyroid(period=16.0, thickness=3.0), wall=3.0)
    fepre.isosurface(light, spacing=0.5).save(outdir / "block_light.stl")
    return {"clean": clean, "damaged": damaged, "mesh": mesh}


if __name__ == "__main__":
    main(Path(sys.argv[1]) if len(sys.argv) > 1 else Path("."))
