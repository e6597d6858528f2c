"""fepre as a PyVista plugin: ``dataset.fepre`` accessors and ``grid.save("part.inp")``.

Samples a model onto an ImageData, extracts and checks its surface through the accessors,
meshes it, reads the quality through ``grid.fepre``, saves Abaqus input with PyVista's own
``save`` and a quality picture, all into OUTDIR.

Run: ``python examples/pyvista_plugin.py [OUTDIR]``
"""

from __future__ import annotations

import sys
from pathlib import Path

import pyvista as pv

import fepre
from fepre import sdf


def main(outdir: str = ".") -> None:
    out = Path(outdir)
    capsules = sdf.union(sdf.capsule((-0.8, 0, 0), (0.8, 0, 0), 0.4), sdf.capsule((0, -0.8, 0), (0, 0.8, 0.3), 0.35), k=0.2)
    image: pv.ImageData = fepre.sample(capsules, spacing=0.03)
    surface = image.fepre.isosurface(method="surface_nets")
    print(surface.fepre.check(capsules))
    grid = fepre.distmesh(capsules, h=0.15)
    print(grid.fepre.summary())
    grid.save(out / "capsules.inp")                      # written by fepre.export (C3D4)
    grid.fepre.plot_quality("radius_ratio", off_screen=True, screenshot=out / "capsules_radius_ratio.png")
    print("wrote", out / "capsules.inp", "and", out / "capsules_radius_ratio.png")


if __name__ == "__main__":
    main(*sys.argv[1:2])
