"""One periodic cell of a gyroid sheet: matching faces, node pairs, *EQUATION constraints and,
with CalculiX (``ccx``) installed, the effective stiffness.

Run: ``python examples/periodic_cell.py [outdir]``.
"""

from __future__ import annotations

import shutil
import sys
from pathlib import Path

import numpy as np

import fepre
from fepre import sdf


def main(outdir: str = ".") -> fepre.PeriodicNodes:
    out = Path(outdir)
    out.mkdir(parents=True, exist_ok=True)
    gyroid = sdf.gyroid(period=1.0, thickness=0.2)  # unbounded: fepre cuts it with the cell
    cell = fepre.distmesh(gyroid, h=0.09, periodic=1.0)
    print(cell.fepre.summary())

    nodes = fepre.periodic_nodes(cell)
    gap = cell.points[nodes.slaves] - nodes.shifts * nodes.cell.period - cell.points[nodes.masters]
    print(f"{len(nodes)} nodes on the upper faces, each exactly one period from its master "
          f"(largest gap {np.abs(gap).max():.1e}); x-face pairs: {len(nodes.pairs('x'))}")

    fepre.export(cell, out / "gyroid_cell.inp", order=2, model=gyroid)  # mesh + *EQUATION + PBC_REF nodes
    fepre.export(cell, out / "gyroid_cell.vtu")
    if shutil.which("ccx"):
        result = fepre.homogenize(cell, (1000.0, 0.3), order=1)  # order=2 is more accurate, about 10x slower
        print(result)
    return nodes


if __name__ == "__main__":
    main(sys.argv[1] if len(sys.argv) > 1 else ".")
