"""Parts of several materials, each meshed as one conformal mesh: a plate with a stiff insert
through its thickness, and a skin around a gyroid core.

Run: ``python examples/regions.py [outdir]``.
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np

import fepre
from fepre import sdf


def report(name: str, mesh) -> None:
    for index, region in enumerate(mesh.field_data["region_names"]):
        cells = np.asarray(mesh["region_id"]) == index
        print(f"{name} {region}: {int(cells.sum())} cells, volume {float(mesh['volume'][cells].sum()):.5f}, "
              f"worst dihedral {float(mesh['min_dihedral_angle'][cells].min()):.1f} deg")
    print(f"{name}: {int(mesh.field_data['distmesh_interface_faces'][0])} interface faces, "
          f"{int(np.asarray(mesh['interface']).sum())} interface nodes")


def main(outdir: str = ".") -> dict:
    out = Path(outdir)
    out.mkdir(parents=True, exist_ok=True)

    plate = sdf.box((3.0, 2.0, 0.4))
    insert = sdf.cylinder(radius=0.4, height=1.0)  # through the thickness: cut by the plate's faces
    plated = fepre.distmesh(plate, h=0.15, regions={"plate": plate - insert, "insert": insert})
    report("plate", plated)
    fepre.export(plated, out / "plate.inp", materials={"plate": (3.0e3, 0.35), "insert": (70e3, 0.33)})
    fepre.export(plated, out / "plate.msh")  # physical volumes per region, the interface as a surface

    outer = sdf.box(1.0)
    skin = outer.shell(0.15)
    infilled = sdf.infill(outer, sdf.gyroid(period=1.0, thickness=0.25), wall=0.15)
    cored = fepre.distmesh(infilled, h=0.08, regions={"skin": skin, "core": outer - skin})
    report("infilled", cored)
    fepre.export(cored, out / "infilled.inp", order=2, model=infilled,
                 materials={"skin": (210e3, 0.3), "core": (110e3, 0.34)})
    fepre.export(cored, out / "infilled.vtu")
    return {"plate": plated, "infilled": cored}


if __name__ == "__main__":
    main(sys.argv[1] if len(sys.argv) > 1 else ".")
