"""Sharp edges and corners: find the features of the cube with a hole of Kelly's DistMesh.jl study and keep them in a mesh.

``fepre.features`` finds the cube's 8 corners, its 12 edges and the two rims where the hole
meets the top and bottom faces. DistMesh makes them mesh nodes (``features=True``, the
default); with ``features=False`` projection onto the surface rounds them off. Prints both
meshes' corner gap and deviation from the true surface, writes the features (``features.vtp``)
and the sharp mesh (``cube_with_hole.vtu``).

Run: ``python examples/sharp_features.py [OUTDIR]``
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
from scipy.spatial import cKDTree

import fepre
from fepre.mesh_metrics import model_hausdorff
from fepre.parts import cube_with_hole, cube_with_hole_corners


def main(outdir: str = ".") -> None:
    part, hole = cube_with_hole()
    h = 0.5
    found = fepre.features(part, h)
    print(found)
    out = Path(outdir)
    found.to_polydata().save(out / "features.vtp")
    for features in (True, False):
        mesh = fepre.distmesh(part, h, features=features)
        gap = cKDTree(mesh.points).query(cube_with_hole_corners())[0].max()
        deviation = max(model_hausdorff(mesh, part, spacing=h / 8, exclude=hole, margin=h))
        print(f"features={features!s:5}: {mesh.n_cells} tetrahedra, corner gap {gap:.1e}, "
              f"largest deviation from the flat faces {deviation:.1e}, worst dihedral "
              f"{mesh['min_dihedral_angle'].min():.1f} deg, {int(np.count_nonzero(mesh['feature']))} feature nodes")
        if features:
            mesh.save(out / "cube_with_hole.vtu")
    print("wrote", out / "features.vtp", "and", out / "cube_with_hole.vtu")


if __name__ == "__main__":
    main(*sys.argv[1:2])
