"""Modelling with signed distance functions: primitives, booleans, smooth blends, transforms, infill.

Builds an L-bracket (two boxes blended by a smooth union, a bolt hole), prints its model tree,
evaluates it at a few points, and saves a picture of it and of a gyroid-infilled block into OUTDIR.

Run: ``python examples/modelling.py [OUTDIR]``
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np

import fepre
from fepre import sdf


def main(outdir: str = ".") -> None:
    base = sdf.box((4.0, 2.0, 0.6), center=(2.0, 1.0, 0.3))
    upright = sdf.box((0.6, 2.0, 3.0), center=(0.3, 1.0, 1.5))
    hole = sdf.cylinder(radius=0.4, height=2.0, center=(2.8, 1.0, 0.3))
    bracket = sdf.union(base, upright, k=0.3) - hole        # smooth fillet of radius 0.3, then a hole
    print(repr(bracket))
    points = np.array([[2.8, 1.0, 0.3], [2.0, 1.0, 0.3], [0.6, 1.0, 0.6], [5.0, 1.0, 0.3]])
    for point, value in zip(points, bracket(points)):
        where = "inside" if value < 0 else "outside" if value > 0 else "on the surface"
        print(f"  sdf({point[0]:g}, {point[1]:g}, {point[2]:g}) = {value:+.4f}  ({where})")
    print("bounds:", bracket.bounds, "exact distance:", bracket.exact)

    block = sdf.box((2.0, 2.0, 1.0))
    infilled = sdf.infill(block, sdf.gyroid(period=1.0, thickness=0.15), wall=0.2)
    twisted = sdf.box((0.6, 0.6, 2.0)).twist(90.0)
    out = Path(outdir)
    for name, model, clip in (("bracket", bracket, False), ("gyroid_block", infilled, True), ("twisted_bar", twisted, False)):
        path = fepre.plot_model(model, clip=clip, off_screen=True, screenshot=out / f"{name}.png")
        print("wrote", path)


if __name__ == "__main__":
    main(*sys.argv[1:2])
