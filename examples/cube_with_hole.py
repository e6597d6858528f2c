"""The first example of Kelly's DistMesh.jl study: a cube [0, 5]^3 minus a radius-1 cylinder along z through its centre.

Writes ``cube_with_hole.stl`` (into the folder given as the first argument, default the current
folder) with dual contouring, so the cube's edges and corners and the rims of the hole stay
sharp, prints the surface check against the exact volume and area, and the worst distance from a
cube corner to the nearest surface vertex (flying edges chamfers the corners by about a cell).

Run: ``python examples/cube_with_hole.py [OUTDIR]``
"""

from __future__ import annotations

import itertools
import math
import sys
from pathlib import Path

import numpy as np

import fepre
from fepre import sdf

cube = sdf.box((5, 5, 5), center=(2.5, 2.5, 2.5))
hole = sdf.cylinder(radius=1, height=7, center=(2.5, 2.5, 2.5))
model = cube - hole
SPACING = 0.05


def worst_corner_error(surface) -> float:
    """Largest distance from one of the cube's 8 corners to its nearest surface vertex."""
    corners = 5.0 * np.array(list(itertools.product((0, 1), repeat=3)), dtype=float)
    points = np.asarray(surface.points)
    return max(float(np.min(np.linalg.norm(points - corner, axis=1))) for corner in corners)


def main(outdir: str = ".") -> fepre.SurfaceCheck:
    surface = fepre.isosurface(model, spacing=SPACING, method="dual_contouring")  # sharp edges
    path = Path(outdir) / "cube_with_hole.stl"
    surface.save(path)
    check = fepre.check_surface(surface, model)
    exact_volume, exact_area = 125 - 5 * math.pi, 150 + 8 * math.pi
    print(repr(model))
    print(check)
    print(f"volume {check.volume:.4f} (exact {exact_volume:.4f}), area {check.area:.4f} (exact {exact_area:.4f})")
    print(f"worst corner error {worst_corner_error(surface):.2e} (grid spacing {SPACING}); wrote {path}")
    return check


if __name__ == "__main__":
    main(*sys.argv[1:2])
