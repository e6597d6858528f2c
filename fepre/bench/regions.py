"""Conformal regions: quality, interface accuracy and cost of multi-material meshes against one-region meshes.

Parts: a bar in two halves, three boxes meeting on a line, a sphere core in a ball, a cube core in
a ball, a plate with an insert through its thickness, a sphere insert cut by a cylinder's faces
(a knife-edge wedge of matrix), and skins around gyroid cores. Each is meshed at the same ``h``
twice in one interleaved run: as one region (``fepre.distmesh(model, h)``) and with its regions
(``regions=``). Printed per part: cells and seconds of both (and their ratio), the worst dihedral
angle of each region and of the one-region mesh (target 25), the largest dihedral (target 150),
the smallest radius ratio (target 0.25), the interface faces, the largest distance of an
interface node from the two zero sets (target 1e-3 h) and, for regions bounded by planes only,
the largest relative error of their volumes (curved ones are inscribed polyhedra). The first
part's one-region time includes the compilation of the kernels.
"""

from __future__ import annotations

import argparse
import time
import warnings

import numpy as np


def _parts(quick: bool):
    from .. import sdf

    bar = sdf.box((2, 1, 1), center=(1, 0.5, 0.5))
    left, right = sdf.box((1, 1, 1), center=(0.5, 0.5, 0.5)), sdf.box((1, 1, 1), center=(1.5, 0.5, 0.5))
    ball = sdf.sphere(1.0)
    plate = sdf.box((3.0, 2.0, 0.4))
    pin = sdf.cylinder(radius=0.4, height=1.0)
    disc = sdf.cylinder(radius=1.0, height=0.8)
    bead = sdf.sphere(0.45, center=(0.3, 0, 0))
    parts = [
        ("bar in two halves", bar, {"left": left, "right": right}, 0.2, [1.0, 1.0]),
        ("three boxes on a line", bar, {"a": left, "b": sdf.box((1, 0.5, 1), center=(1.5, 0.25, 0.5)),
                                        "c": sdf.box((1, 0.5, 1), center=(1.5, 0.75, 0.5))}, 0.2, [1.0, 0.5, 0.5]),
        ("sphere core r=0.6 in a ball", ball, {"skin": ball - sdf.sphere(0.6), "core": sdf.sphere(0.6)}, 0.12, None),
        ("cube core in a ball", ball, {"skin": ball - sdf.box(1.0), "core": sdf.box(1.0)}, 0.12, [None, 1.0]),
        ("plate with an insert", plate, {"plate": plate - pin, "insert": pin}, 0.1, None),
        ("bead cut by a disc's faces", disc, {"matrix": disc - bead, "bead": bead}, 0.12, None),
    ]
    for size, h in ((1.0, 0.08),) if quick else ((1.0, 0.08), (1.2, 0.07)):
        outer = sdf.box(size)
        skin = outer.shell(0.15)
        model = sdf.infill(outer, sdf.gyroid(period=1.0, thickness=0.25 if size == 1.0 else 0.2), wall=0.15)
        inner = size - 0.3
        parts.append((f"skin + gyroid core, box {size:g}", model, {"skin": skin, "core": outer - skin}, h,
                      [size**3 - inner**3, None]))
    return parts


def main(argv: list[str] | None = None) -> int:
    import fepre

    parser = argparse.ArgumentParser(prog="fepre bench regions", description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="fewer parts (the smaller gyroid core only)")
    args = parser.parse_args(argv)
    print("each part meshed twice at the same h, interleaved: one region, then its regions (fepre.distmesh defaults)")
    header = (f"{'part':31s} {'h':>5s} {'cells 1':>8s} {'s 1':>6s} {'cells R':>8s} {'s R':>6s} {'ratio':>5s} "
              f"{'min1':>5s} {'minR (per region)':>18s} {'maxR':>6s} {'rrR':>6s} {'faces':>6s} {'off/h':>8s} {'vol err':>8s}")
    print(header)
    for name, model, regions, h, exact in _parts(args.quick):
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            start = time.perf_counter()
            plain = fepre.distmesh(model, h)
            plain_seconds = time.perf_counter() - start
            start = time.perf_counter()
            mesh = fepre.distmesh(model, h, regions=regions)
            seconds = time.perf_counter() - start
        ids = np.asarray(mesh["region_id"])
        worst = [float(mesh["min_dihedral_angle"][ids == k].min()) for k in range(len(regions))]
        points = np.asarray(mesh.points)[np.asarray(mesh["interface"]).astype(bool)]
        values = np.sort(np.abs(np.column_stack([r(points) for r in regions.values()])), axis=1)[:, 1]
        error = ""
        if exact is not None:
            volumes = np.bincount(ids, mesh["volume"], minlength=len(regions))
            error = f"{max(abs(v - e) / e for v, e in zip(volumes, exact) if e is not None):8.1e}"
        print(f"{name:31s} {h:5.2f} {plain.n_cells:8d} {plain_seconds:6.1f} {mesh.n_cells:8d} {seconds:6.1f} "
              f"{seconds / plain_seconds:5.2f} {float(plain['min_dihedral_angle'].min()):5.1f} "
              f"{' '.join(f'{w:.1f}' for w in worst):>18s} {float(mesh['max_dihedral_angle'].max()):6.1f} "
              f"{float(mesh['radius_ratio'].min()):6.3f} {int(mesh.field_data['distmesh_interface_faces'][0]):6d} "
              f"{float(values.max()) / h:8.1e} {error:>8s}", flush=True)
    return 0
