"""The seed's first example: a cube [0, 5]^3 minus a radius-1 cylinder along z through its centre.

Writes ``cube_with_hole.stl`` (into the folder given as the first argument, default the current
folder) and prints the surface check against the exact volume and area.

Run: ``python examples/cube_with_hole.py [OUTDIR]``
"""

from __future__ import annotations

import math
import sys
from pathlib import Path

import fepre
from fepre import sdf

cube = sdf.box((5, 5, 5), center=(2.5, 2.5, 2.5))
hole = sdf.cylinder(radius=1, height=7, center=(2.5, 2.5, 2.5))
model = cube - hole


def main(outdir: str = ".") -> fepre.SurfaceCheck:
    surface = fepre.isosurface(model, spacing=0.05, method="flying_edges")
    path = Path(outdir) / "cube_with_hole.stl"
    surface.save(path)
    check = fepre.check_surface(surface, model)
    exact_volume = 125 - 5 * math.pi
    print(repr(model))
    print(check)
    print(f"volume {check.volume:.4f} (exact {exact_volume:.4f}); wrote {path}")
    return check


if __name__ == "__main__":
    main(*sys.argv[1:2])
