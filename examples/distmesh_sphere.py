"""DistMesh tetrahedra of the unit sphere (Table 3 of Kelly's DistMesh.jl study), their quality, a VTU file.

Prints the mesh size, time, volume error and the quality summary (worst dihedral angle, radius
ratio, ...), writes ``sphere.vtu`` and a picture of the interior coloured by worst dihedral angle.

Run: ``python examples/distmesh_sphere.py [OUTDIR]``
"""

from __future__ import annotations

import math
import sys
import time
from pathlib import Path

import fepre
from fepre import sdf


def main(outdir: str = ".") -> None:
    start = time.perf_counter()
    mesh = fepre.distmesh(sdf.sphere(1.0), h=0.2)
    seconds = time.perf_counter() - start
    exact = 4 * math.pi / 3
    print(f"{mesh.n_cells} tetrahedra, {mesh.n_points} nodes in {seconds:.2f} s; "
          f"volume error {mesh.volume / exact - 1:+.2%}")
    print(fepre.quality.summary(mesh))
    out = Path(outdir)
    mesh.save(out / "sphere.vtu")
    fepre.plot(mesh, off_screen=True, screenshot=out / "sphere_quality.png")
    print("wrote", out / "sphere.vtu", "and", out / "sphere_quality.png")


if __name__ == "__main__":
    main(*sys.argv[1:2])
