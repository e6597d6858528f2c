"""Automatic size fields: graded fepre meshes against uniform ones at hmin and gmsh's curvature sizing.

Every part is meshed by ``fepre.distmesh(model, h=(hmin, hmax))`` (the automatic field of
:func:`fepre.size_field`, default options) and, interleaved in the same run, by gmsh on the
part's reference surface (dual contouring at hmin/4) with ``Mesh.MeshSizeFromCurvature`` (20
elements per 2 pi) between hmin and hmax, Delaunay with its optimiser and Netgen's, as gmsh
users grade a mesh. The table gives cells (and the share of a uniform fepre mesh at hmin, whose
count is estimated from the volume: 8.3 cells per hmin^3), the worst dihedral, the largest
dihedral, the smallest radius ratio, the volume error (against the exact volume), components and
genus of the boundary (the part's are given), elements through the part's thinnest wall (its
thickness over the median edge length of the cells in it) and the times: fepre's field, fepre's
whole mesh and gmsh.

``--set cad`` runs issue 33's ordinary CAD parts (:mod:`fepre.cad_parts`) against its targets
instead: field minimum, cells and time per cell against the uniform mesh at hmin, quality, volume,
the same part far from the origin and gmsh (:mod:`fepre.bench._sizing_cad`).

Thin-feature parts have walls 0.3-3 hmin thick, a tube and a shell, a rib, small holes (radius
0.5-2 hmin) and slots 0.2-2 hmin wide; the economy parts are a gyroid-infilled block under a
solid skin and an L-bracket with small holes.
"""

from __future__ import annotations

import argparse
import math
import time
import warnings
from dataclasses import dataclass
from typing import Callable

import numpy as np

from .. import sdf


@dataclass
class SizingPart:
    name: str
    model: sdf.SDF
    hmin: float
    hmax: float
    volume: float
    components: int
    genus: int
    wall: float | None = None  # the thinnest wall's thickness
    in_wall: Callable[[np.ndarray], np.ndarray] | None = None  # cell centroids in that wall


def parts(hmin: float = 0.5) -> list[SizingPart]:
    """The benchmark's parts at smallest size ``hmin``."""
    h = hmin
    out = []
    for factor in (0.3, 1.0, 3.0):
        t = factor * h
        out.append(SizingPart(f"plate {factor:g} hmin", sdf.box((6.0, 6.0, t)), h, 8 * h, 36.0 * t, 1, 0,
                              t, lambda c: np.abs(c[:, 0]) < 2.0))
    t = 1.5 * h
    tube = sdf.cylinder(6.0, 12.0) - sdf.cylinder(6.0 - t, 14.0)
    out.append(SizingPart("tube 1.5 hmin", tube, h, 8 * h, math.pi * (36.0 - (6.0 - t) ** 2) * 12.0, 1, 1, t,
                          lambda c: np.abs(c[:, 2]) < 4.0))
    shell = sdf.sphere(6.0) - sdf.sphere(6.0 - t)
    out.append(SizingPart("shell 1.5 hmin", shell, h, 8 * h, 4 / 3 * math.pi * (216.0 - (6.0 - t) ** 3), 1, 0, t,
                          lambda c: np.ones(len(c), bool)))
    t = 2.0 * h
    rib = sdf.box((20.0, 20.0, 4.0)) | sdf.box((t, 16.0, 8.0), center=(0.0, 0.0, 4.0))
    out.append(SizingPart("rib 2 hmin", rib, h, 8 * h, 1600.0 + t * 16.0 * 6.0, 1, 0, t,
                          lambda c: (np.abs(c[:, 0]) < t / 2) & (c[:, 2] > 3.0)))
    plate = sdf.box((24.0, 12.0, 4.0))
    radii = (0.5 * h, 1.0 * h, 2.0 * h)
    for k, r in enumerate(radii):
        plate = plate - sdf.cylinder(r, 6.0).translate((-8.0 + 8.0 * k, 0.0, 0.0))
    out.append(SizingPart("holes 0.5-2 hmin", plate, h, 8 * h, 24 * 12 * 4 - 4 * math.pi * sum(r * r for r in radii), 1, 3))
    slots = sdf.box((24.0, 8.0, 8.0), center=(0.0, 0.0, 2.0))
    for x, w in ((-6.0, 0.2 * h), (0.0, 1.0 * h), (6.0, 2.0 * h)):
        slots = slots - sdf.box((w, 10.0, 6.0), center=(x, 0.0, 3.5))
    out.append(SizingPart("slots 0.2-2 hmin", slots, h, 8 * h, 24 * 8 * 8 - 8.0 * 5.5 * (3.2 * h), 1, 0))
    skin = 4 * h
    block = sdf.box((40.0, 40.0, 20.0))
    core = sdf.box((40.0 - 2 * skin, 40.0 - 2 * skin, 20.0 - 2 * skin))
    infill = sdf.gyroid(period=10.0, thickness=3 * h) & core
    gyroid_block = (block - core) | infill
    out.append(SizingPart("gyroid block", gyroid_block, h, 8 * h, float("nan"), 1, -1))
    bracket = sdf.box((60.0, 40.0, 5.0), center=(0.0, 0.0, 2.5)) | sdf.box((60.0, 5.0, 35.0), center=(0.0, 17.5, 17.5))
    for x in (-20.0, 0.0, 20.0):
        bracket = bracket - sdf.cylinder(1.5 * h, 12.0).translate((x, 0.0, 2.5))
        bracket = bracket - sdf.cylinder(2.0 * h, 12.0, axis="y").translate((x, 17.5, 25.0))
    volume = 60 * 40 * 5 + 60 * 5 * 30 - 3 * math.pi * ((1.5 * h) ** 2 * 5 + (2.0 * h) ** 2 * 5)
    out.append(SizingPart("bracket, small holes", bracket, h, 12 * h, volume, 1, 6))
    return out


def _edges(points: np.ndarray, tets: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    pairs = np.concatenate([tets[:, [a, b]] for a in range(4) for b in range(a + 1, 4)])
    length = np.linalg.norm(points[pairs[:, 0]] - points[pairs[:, 1]], axis=1)
    owner = np.tile(np.arange(len(tets)), 6)
    return length, owner


def _measure(part: SizingPart, points: np.ndarray, tets: np.ndarray, check_mesh) -> dict:
    import pyvista as pv

    from .. import check_surface

    check = check_mesh(points, tets, part.model, part.hmin)
    grid = pv.UnstructuredGrid({pv.CellType.TETRA: tets}, points)
    surface = check_surface(grid.extract_surface(algorithm=None).triangulate())
    across = float("nan")
    if part.wall is not None:
        centroid = points[tets].mean(axis=1)
        inside = part.in_wall(centroid) & (np.abs(part.model(centroid)) < part.wall / 2)
        length, owner = _edges(points, tets)
        if inside.any():
            across = part.wall / float(np.median(length[inside[owner]]))
    return dict(cells=len(tets), check=check, genus=surface.genus, components=check.components, across=across)


def _gmsh(part: SizingPart):
    from ..references import gmsh_mesh, reference_surface

    surface = reference_surface(part.model, part.hmin / 4)
    start = time.perf_counter()
    try:
        mesh = gmsh_mesh(surface, part.hmax, hmin=part.hmin, curvature=20, timeout=900)
    except Exception as exc:  # noqa: BLE001 - reported in the table
        return None, time.perf_counter() - start, f"{type(exc).__name__}: {str(exc)[:80]}"
    return mesh, time.perf_counter() - start, None


def main(argv: list[str]) -> int:
    import fepre
    from fepre.corpus import check_mesh, monte_carlo_volume
    from fepre.sizing.estimate import estimated_cells

    parser = argparse.ArgumentParser(prog="fepre bench sizing", description=__doc__.splitlines()[0])
    parser.add_argument("--hmin", type=float, default=0.5, help="smallest size (default 0.5; the parts are tens of units)")
    parser.add_argument("--no-gmsh", action="store_true", help="fepre only")
    parser.add_argument("--parts", nargs="+", help="only the parts whose names start with these words")
    parser.add_argument("--set", choices=("thin", "cad"), default="thin",
                        help="thin: the thin-feature parts (default); cad: ordinary CAD parts (fepre.cad_parts) "
                             "against issue 33's targets, each at its own (hmin, hmax)")
    parser.add_argument("--uniform-limit", type=float, default=250_000,
                        help="--set cad: mesh the uniform mesh at hmin when its estimated cells are at most this "
                             "(default 250000: every part of the set; 4 s for the largest), else print the estimate")
    parser.add_argument("--no-far", action="store_true", help="--set cad: skip the copy translated far from the origin")
    args = parser.parse_args(argv)
    if not args.hmin > 0:
        parser.error(f"--hmin must be > 0; got {args.hmin}")
    if not args.uniform_limit >= 0:
        parser.error(f"--uniform-limit must be >= 0; got {args.uniform_limit}")
    if args.set == "cad":
        from ._sizing_cad import run

        return run(args.parts, uniform_limit=args.uniform_limit, far=not args.no_far, gmsh=not args.no_gmsh)
    chosen = [p for p in parts(args.hmin) if not args.parts or any(p.name.startswith(w) for w in args.parts)]
    print(f"fepre bench sizing: {len(chosen)} parts, fepre.distmesh(model, h=(hmin, hmax)) at default options; "
          + ("gmsh on the hmin/4 reference surface, MeshSizeFromCurvature=20 between hmin and hmax, Delaunay + optimiser + Netgen"
             if not args.no_gmsh else "no peer"))
    for part in chosen:
        lower, upper = (np.asarray(v, float) for v in part.model.bounds)
        volume = part.volume
        if not np.isfinite(volume):
            volume = monte_carlo_volume(part.model, lower, upper, 4_000_000)[0]
        uniform = estimated_cells(part.model, None, part.hmin, lower, upper, False)
        start = time.perf_counter()
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            field = fepre.size_field(part.model, part.hmin, part.hmax)
            mesh = fepre.distmesh(part.model, size=field)
        seconds = time.perf_counter() - start
        ours = _measure(part, np.asarray(mesh.points, float), mesh.cells_dict[10].astype(np.int64), check_mesh)
        ours.update(seconds=seconds, field=field.seconds, volume=ours["check"].volume / volume - 1,
                    warnings=sorted({type(w.message).__name__ for w in caught}))
        peer = None
        if not args.no_gmsh:
            grid, gmsh_seconds, error = _gmsh(part)
            if grid is not None:
                peer = _measure(part, np.asarray(grid.points, float), grid.cells_dict[10].astype(np.int64), check_mesh)
                peer.update(seconds=gmsh_seconds, volume=peer["check"].volume / volume - 1)
            else:
                peer = dict(error=error, seconds=gmsh_seconds)
        _print_row(part, uniform, ours, peer)
    return 0


def _print_row(part: SizingPart, uniform: float, ours: dict, peer: dict | None) -> None:
    c = ours["check"]
    genus = "-" if part.genus < 0 else str(part.genus)
    line = (f"{part.name:22s} hmin {part.hmin:g} hmax {part.hmax:g} | fepre {ours['cells']:8d} cells "
            f"({ours['cells'] / max(uniform, 1):6.1%} of uniform {uniform:,.0f}) {c.min_dihedral:5.1f}/{c.max_dihedral:5.1f} deg "
            f"rr {c.min_radius_ratio:.3f} vol {100 * ours['volume']:+6.2f}% comp {ours['components']}/{part.components} "
            f"genus {ours['genus']}/{genus} across {ours['across']:.1f} field {ours['field']:.1f} s total {ours['seconds']:.1f} s"
            f"{' valid' if c.valid else ' INVALID ' + '; '.join(c.problems)}"
            f"{' warns ' + ','.join(ours['warnings']) if ours['warnings'] else ''}")
    if peer is not None:
        if "error" in peer:
            line += f" | gmsh ERROR {peer['error']}"
        else:
            p = peer["check"]
            line += (f" | gmsh {peer['cells']:8d} cells {p.min_dihedral:5.1f}/{p.max_dihedral:5.1f} deg rr {p.min_radius_ratio:.3f} "
                     f"vol {100 * peer['volume']:+6.2f}% comp {peer['components']} genus {peer['genus']} across {peer['across']:.1f} "
                     f"{peer['seconds']:.1f} s")
    print(line, flush=True)
