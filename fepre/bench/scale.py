"""DistMesh at scale: time, peak memory and cores used per cell, against gmsh at equal cell counts.

Every run is a fresh process (so peak memory is the run's own): ``fepre.distmesh`` at default
options on the unit sphere at about ``--cells`` cells and on three parts with sharp features and
a lattice (a box with 20 through holes, a flange with a hub, a bore and six bolt holes, a
gyroid-infilled block) at about ``--part-cells``; gmsh meshes the same sphere (OpenCASCADE,
Delaunay 3D, its default optimiser ``Mesh.Optimize = 1``; ``--netgen`` adds
``Mesh.OptimizeNetgen = 1``), its size calibrated on a small run to give the same number of
cells. Runs are interleaved (fepre, gmsh, fepre, gmsh, ...) and the table gives medians and the
ratios fepre / gmsh of time per cell. Peak memory is the process's maximum resident set,
including the interpreter and its libraries (the baseline line says how much that is).
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys

import numpy as np

PARTS = ("sphere", "box-holes", "flange", "gyroid-block")


def _model(name: str):
    from .. import sdf

    if name == "sphere":
        return sdf.sphere(1.0)
    if name == "box-holes":
        block = sdf.box((100.0, 80.0, 20.0))
        holes = [sdf.cylinder(4.0, 30.0, center=(x, y, 0.0)) for x in (-40, -20, 0, 20, 40) for y in (-30, -10, 10, 30)]
        return block - sdf.union(*holes)
    if name == "flange":
        body = sdf.cylinder(50.0, 10.0, center=(0, 0, 5.0)) | sdf.cylinder(20.0, 30.0, center=(0, 0, 15.0))
        cuts = [sdf.cylinder(10.0, 40.0, center=(0, 0, 15.0))]
        cuts += [sdf.cylinder(4.0, 14.0, center=(35 * np.cos(a), 35 * np.sin(a), 5.0)) for a in np.arange(6) * np.pi / 3]
        return body - sdf.union(*cuts)
    if name == "gyroid-block":
        from .. import parts

        return parts.gyroid_block()
    raise ValueError(f"unknown part {name!r}; known: {', '.join(PARTS)}")


def _h_for(model, cells: float) -> float:
    """Edge length at which fepre's cell estimate is ``cells``."""
    from ..distmesh.mesher import domain_bounds
    from ..sizing.estimate import estimated_cells

    lower, upper = (np.asarray(v, float) for v in domain_bounds(model, None))
    trial = float((upper - lower).max()) / 20.0
    estimate = estimated_cells(model, None, trial, lower, upper, False)
    return trial * (estimate / cells) ** (1.0 / 3.0)


def _child(kind: str, part: str, h: float) -> dict:
    """One run in this (fresh) process; what it measured."""
    import resource
    import time
    import warnings

    import fepre  # noqa: F401 - imports before the baseline
    import gmsh  # noqa: F401

    baseline = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss * 1024
    wall, cpu = time.perf_counter(), time.process_time()
    if kind == "fepre":
        import fepre

        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            mesh = fepre.distmesh(_model(part), h)
        cells, points = mesh.n_cells, mesh.n_points
        worst = float(mesh["min_dihedral_angle"].min())
        ratio = float(mesh["radius_ratio"].min())
    else:
        cells, points, worst, ratio = _gmsh_sphere(h, netgen=kind == "gmsh-netgen")
    wall, cpu = time.perf_counter() - wall, time.process_time() - cpu
    peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss * 1024
    return dict(kind=kind, part=part, h=h, cells=cells, points=points, wall=wall, cpu=cpu, peak=peak,
                baseline=baseline, worst=worst, ratio=ratio)


def _gmsh_sphere(h: float, netgen: bool) -> tuple[int, int, float, float]:
    from ..quality import tet_quality
    from .distmesh import gmsh_sphere

    options = {"Mesh.Algorithm3D": 1, "Mesh.Optimize": 1, "Mesh.OptimizeNetgen": int(netgen)}
    points, tets = gmsh_sphere(h, options)
    quality = tet_quality(points, tets)
    return len(tets), len(points), float(np.abs(quality["min_dihedral_angle"]).min()), float(np.abs(quality["radius_ratio"]).min())


def _spawn(kind: str, part: str, h: float) -> dict:
    command = [sys.executable, "-m", "fepre.bench.scale", "--child", kind, part, repr(h)]
    done = subprocess.run(command, capture_output=True, text=True, env=dict(os.environ, PYTHONWARNINGS="ignore"))
    if done.returncode != 0:
        raise RuntimeError(f"{kind} on {part} at h={h:g} failed:\n{done.stderr[-2000:]}")
    return json.loads(done.stdout.strip().splitlines()[-1])


def _row(label: str, runs: list[dict], reference: dict | None) -> str:
    wall = statistics.median(r["wall"] for r in runs)
    cpu = statistics.median(r["cpu"] / r["wall"] for r in runs)
    peak = statistics.median(r["peak"] for r in runs)
    cells = runs[-1]["cells"]
    per_cell = wall / cells * 1e6
    ratio = f"{per_cell / reference['per_cell']:6.2f}" if reference else f"{'':>6}"
    memory = f"{peak / cells / 1024:6.2f}"
    memory_ratio = f"{(peak / cells) / reference['memory']:6.2f}" if reference and reference["memory"] else f"{'':>6}"
    return (
        f"{label:<30} {runs[-1]['h']:8.4g} {cells:>10,} {wall:8.1f} {per_cell:7.1f} {ratio} {cpu:5.2f} "
        f"{peak / 2**30:6.2f} {memory} {memory_ratio} {runs[-1]['worst']:6.1f} {runs[-1]['ratio']:6.3f}"
    )


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="fepre bench scale", description=(__doc__ or "").strip().splitlines()[0])
    parser.add_argument("--cells", type=float, default=2.4e6, help="cells of the sphere (default 2.4e6)")
    parser.add_argument("--part-cells", type=float, default=5e5, help="cells of the other parts (default 5e5)")
    parser.add_argument("--parts", nargs="+", choices=PARTS, default=list(PARTS), help="parts to mesh (default all)")
    parser.add_argument("--repeat", type=int, default=1, help="interleaved runs of each (default 1)")
    parser.add_argument("--no-gmsh", action="store_true", help="fepre only")
    parser.add_argument("--netgen", action="store_true", help="also gmsh with Mesh.OptimizeNetgen = 1")
    parser.add_argument("--child", nargs=3, help=argparse.SUPPRESS)
    args = parser.parse_args(argv)
    if args.child:
        kind, part, h = args.child
        print(json.dumps(_child(kind, part, float(h))))
        return 0
    for flag, value in (("--cells", args.cells), ("--part-cells", args.part_cells)):
        if not (np.isfinite(value) and value >= 1000):
            parser.error(f"{flag} must be a number of cells of at least 1000; got {value:g}")
    if args.repeat < 1:
        parser.error(f"--repeat must be at least 1; got {args.repeat}")

    print(__doc__.strip().splitlines()[0])
    print(f"{os.cpu_count()} cores; each run a fresh process; medians of {args.repeat} interleaved run(s)")
    print(f"{'run':<30} {'h':>8} {'cells':>10} {'wall s':>8} {'us/cell':>7} {'ratio':>6} {'cpu/w':>5} "
          f"{'peak GB':>6} {'KB/cell':>6} {'ratio':>6} {'worst':>6} {'min rr':>6}")
    sphere_cost, baseline = None, 0
    for part in args.parts:
        model = _model(part)
        target = args.cells if part == "sphere" else args.part_cells
        h = _h_for(model, target)
        kinds = ["fepre"]
        peers: dict[str, float] = {}
        if part == "sphere" and not args.no_gmsh:
            # gmsh's cells per h^-3, from a run at about 50k cells
            for kind in ["gmsh"] + (["gmsh-netgen"] if args.netgen else []):
                small = _h_for(model, 5e4)
                probe = _spawn(kind, part, small)
                peers[kind] = small * (probe["cells"] / target) ** (1.0 / 3.0)
                kinds.append(kind)
        runs: dict[str, list[dict]] = {kind: [] for kind in kinds}
        for _ in range(args.repeat):
            for kind in kinds:
                runs[kind].append(_spawn(kind, part, h if kind == "fepre" else peers[kind]))
        mine = runs["fepre"]
        for kind in kinds[1:]:
            peer = runs[kind]
            reference = dict(per_cell=statistics.median(r["wall"] for r in peer) / peer[-1]["cells"] * 1e6,
                             memory=statistics.median(r["peak"] for r in peer) / peer[-1]["cells"])
            print(_row(f"{part}: {kind}", peer, None))
            print(_row(f"{part}: fepre vs {kind}", mine, reference))
        if len(kinds) == 1:
            reference = None
            if sphere_cost is not None:
                reference = dict(per_cell=sphere_cost, memory=None)
            print(_row(f"{part}: fepre" + (" vs sphere" if reference else ""), mine, reference))
        if part == "sphere":
            sphere_cost = statistics.median(r["wall"] for r in mine) / mine[-1]["cells"] * 1e6
        baseline = mine[-1]["baseline"]
        sys.stdout.flush()
    print(f"peak memory includes the interpreter and its libraries: {baseline / 2**20:.0f} MB before meshing")
    print("ratio = fepre / peer (time per cell, then memory per cell; below 1: fepre cheaper); parts other "
          "than the sphere compare their time per cell with fepre's on the sphere in this run")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
