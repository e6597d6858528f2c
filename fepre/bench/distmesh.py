"""DistMesh on the unit sphere: speed vs pytetwild and gmsh, and how each loop option changes time and quality.

Part 1 times ``fepre.distmesh`` with the default options at h = 0.2, 0.1, 0.05 (the loop and the
quality stage separately; time per iteration per point shows the cost is linear in the points)
and, in the same run, pytetwild (``edge_length_abs=h`` on a VTK sphere surface) and gmsh (OCC
sphere, Delaunay 3D with gmsh's and Netgen's optimisers) when installed, with ratios of time per cell. Part 2 repeats the
experiments of Kelly's DistMesh.jl study: Table 3 (deltat x ttol, reference start and termination), Hilbert sorting on and off
at h = 0.15, linear vs nonlinear forces (dihedral histograms, Fig. 13) and movement vs
move-averaged retriangulation (quality per iteration, Fig. 14); the figures go to ``--out``.
"""

from __future__ import annotations

import argparse
import os
import time
import warnings

import numpy as np

from . import median_time, save_figure


def _sphere():
    from .. import sdf

    return sdf.sphere(1.0)


def _run(h: float, **options):
    import fepre

    with warnings.catch_warnings():
        warnings.simplefilter("ignore", fepre.ConvergenceWarning)
        return fepre.distmesh(_sphere(), h, **options)


def _figures(mesh) -> str:
    return f"{mesh.n_points:>8} {mesh.n_cells:>8} {mesh['min_dihedral_angle'].min():7.2f} {mesh['radius_ratio'].mean():7.3f}"


from ..references import GMSH_OPTIONS


def _pytetwild(h: float):
    import pytetwild
    import pyvista as pv

    resolution = max(16, int(round(2 * np.pi / (0.5 * h))))
    surface = pv.Sphere(radius=1.0, theta_resolution=resolution, phi_resolution=resolution).triangulate().clean()
    return pytetwild.tetrahedralize_pv(surface, edge_length_abs=h, quiet=True)


def gmsh_sphere(h: float, options: dict) -> tuple[np.ndarray, np.ndarray]:
    """gmsh's tetrahedral mesh of the unit sphere (OpenCASCADE) at size ``h`` with gmsh
    ``options``: points (N, 3) and cells (M, 4)."""
    import gmsh

    gmsh.initialize(readConfigFiles=False)
    try:
        gmsh.option.setNumber("General.Terminal", 0)
        gmsh.model.add("sphere")
        gmsh.model.occ.addSphere(0, 0, 0, 1.0)
        gmsh.model.occ.synchronize()
        gmsh.option.setNumber("Mesh.MeshSizeMin", h)
        gmsh.option.setNumber("Mesh.MeshSizeMax", h)
        for name, value in options.items():
            gmsh.option.setNumber(name, value)
        gmsh.model.mesh.generate(3)
        tags, coords, _ = gmsh.model.mesh.getNodes()
        _, _, nodes = gmsh.model.mesh.getElements(3)
        points = np.asarray(coords).reshape(-1, 3)
        index = np.empty(int(tags.max()) + 1, np.int64)
        index[tags.astype(np.int64)] = np.arange(len(tags))
        return points, index[np.asarray(nodes[0], np.int64).reshape(-1, 4)]
    finally:
        gmsh.finalize()


def _gmsh(h: float):
    import pyvista as pv

    from ..quality import add_quality

    points, tets = gmsh_sphere(h, GMSH_OPTIONS)
    return add_quality(pv.UnstructuredGrid({pv.CellType.TETRA: tets}, points))


def speed(sizes: list[float], repeat: int) -> list[str]:
    """Default-option timings and peers on the same sphere."""
    from ..distmesh.delaunay import gmsh_available
    from ..quality import add_quality

    _run(0.3)  # imports and caches
    lines = [
        "Part 1: unit sphere, default options (median of %d for h >= 0.1, 1 run below)" % repeat,
        f"{'mesher':<22} {'h':>5} {'seconds':>8} {'loop s':>7} {'qual. s':>7} {'iters':>5} {'tri':>4} "
        f"{'us/it/pt':>8} {'points':>8} {'tets':>8} {'mindih':>7} {'mean rr':>7}  ratio",
    ]
    for h in sizes:
        runs = repeat if h >= 0.1 else 1
        meshes = []
        seconds = median_time(lambda: meshes.append(_run(h)), runs, warmup=0)
        mesh = meshes[-1]
        f = mesh.field_data
        loop_s, sliver_s = float(f["distmesh_loop_seconds"][0]), float(f["distmesh_slivers_seconds"][0])
        iterations = int(f["distmesh_iterations"][0])
        per = loop_s / iterations / mesh.n_points * 1e6
        lines.append(
            f"{'fepre.distmesh':<22} {h:5.2f} {seconds:8.2f} {loop_s:7.2f} {sliver_s:7.2f} {iterations:5d} "
            f"{int(f['distmesh_triangulations'][0]):4d} {per:8.2f} {_figures(mesh)}  1.00"
        )
        peers = [("pytetwild", _pytetwild)]
        if gmsh_available():
            peers.append(("gmsh (OCC, +Netgen opt)", _gmsh))
        for name, function in peers:
            peer_meshes = []
            peer_seconds = median_time(lambda: peer_meshes.append(function(h)), 1, warmup=0)
            peer = add_quality(peer_meshes[-1])
            lines.append(
                f"{name:<22} {h:5.2f} {peer_seconds:8.2f} {'':>7} {'':>7} {'':>5} {'':>4} {'':>8} "
                f"{_figures(peer)}  {(peer_seconds / peer.n_cells) / (seconds / mesh.n_cells):.2f}"
            )
    lines.append(
        "ratio = peer time per cell / fepre time per cell in this run (> 1: fepre faster); gmsh runs "
        "Delaunay 3D with Optimize = 1 and OptimizeNetgen = 1, pytetwild its defaults"
    )
    return lines


def table3(maxiter: int) -> list[str]:
    """Table 3 of Kelly's study: deltat x ttol on the sphere, h=0.2, reference start and termination."""
    lines = [
        f"Table 3: sphere h=0.2, cubic lattice, reference termination (ptol), maxiter {maxiter}, loop only",
        f"{'deltat':>6} {'ttol':>5} {'seconds':>8} {'iters':>6} {'tri':>4} {'conv':>4} {'tets':>6}   DistMesh.jl",
    ]
    seed = {(0.1, 0.02): "0.298 s", (0.1, 0.05): "4.003 s", (0.05, 0.02): "0.723 s", (0.05, 0.05): "138.156 s"}
    for deltat in (0.1, 0.05):
        for ttol in (0.02, 0.05):
            start = time.perf_counter()
            mesh = _run(
                0.2, deltat=deltat, ttol=ttol, distribution="cubic", boundary_layer=False,
                termination="displacement", maxiter=maxiter, slivers=False,
            )
            seconds = time.perf_counter() - start
            f = mesh.field_data
            lines.append(
                f"{deltat:6.2f} {ttol:5.2f} {seconds:8.2f} {int(f['distmesh_iterations'][0]):6d} "
                f"{int(f['distmesh_triangulations'][0]):4d} {int(f['distmesh_converged'][0]):4d} {mesh.n_cells:6d}   {seed[(deltat, ttol)]}"
            )
    return lines


def hilbert(repeat: int) -> list[str]:
    """Hilbert sorting on and off at h=0.15 (loop time)."""
    lines = ["Hilbert sorting, sphere h=0.15, loop only (median of %d)" % repeat]
    for sort in (None, "hilbert"):
        meshes = []
        seconds = median_time(lambda: meshes.append(_run(0.15, sort=sort, sort_interval=1, slivers=False)), repeat, warmup=0)
        lines.append(f"sort={str(sort):<8} {seconds:7.3f} s  {int(meshes[-1].field_data['distmesh_iterations'][0])} iterations")
    return lines


def forces_figure(out: str | None) -> list[str]:
    """Fig. 13 of Kelly's study: dihedral angle histograms, linear vs nonlinear forces (h=0.2, loop only)."""
    from ..quality import dihedral_angles

    meshes = {name: _run(0.2, nonlinear=name == "nonlinear", slivers=False) for name in ("linear", "nonlinear")}
    lines = ["Fig. 13: linear vs nonlinear forces, sphere h=0.2, loop only"]
    for name, mesh in meshes.items():
        lines.append(
            f"{name:<10} min dihedral {mesh['min_dihedral_angle'].min():6.2f}  median min dihedral "
            f"{np.median(mesh['min_dihedral_angle']):6.2f}  cells under 15 deg {(mesh['min_dihedral_angle'] < 15).sum()}"
        )
    if out:
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt

        fig, axes = plt.subplots(2, 2, figsize=(10, 7), sharex="col")
        for row, (name, mesh) in enumerate(meshes.items()):
            tets = mesh.cells_dict[10]
            axes[row, 0].hist(mesh["min_dihedral_angle"], bins=60, range=(0, 90))
            axes[row, 0].set_title(f"{name}: minimum dihedral angle per cell")
            axes[row, 1].hist(dihedral_angles(mesh.points, tets).ravel(), bins=90, range=(0, 180))
            axes[row, 1].set_title(f"{name}: all dihedral angles")
        for ax in axes[1]:
            ax.set_xlabel("degrees")
        fig.tight_layout()
        lines.append(f"wrote {save_figure(fig, os.path.join(out, 'distmesh_fig13_dihedral.png'))}")
    return lines


def retriangulation_figure(out: str | None) -> list[str]:
    """Fig. 14 of Kelly's study: quality per iteration, movement vs move-averaged retriangulation."""
    runs = {
        name: _run(0.2, retriangulation=name, termination="displacement", maxiter=300, slivers=False)
        for name in ("movement", "move_average")
    }
    lines = ["Fig. 14: retriangulation rule, sphere h=0.2, reference termination (maxiter 300), loop only"]
    for name, mesh in runs.items():
        f = mesh.field_data
        lines.append(
            f"{name:<13} {int(f['distmesh_iterations'][0]):4d} iterations  {int(f['distmesh_triangulations'][0]):3d} "
            f"triangulations  final mean quality {f['distmesh_mean_quality'][-1]:.4f}  converged {int(f['distmesh_converged'][0])}"
        )
    if out:
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt

        fig, axes = plt.subplots(2, 1, figsize=(9, 7), sharex=True)
        for ax, (name, mesh) in zip(axes, runs.items()):
            f = mesh.field_data
            ax.plot(f["distmesh_mean_quality"], label="mean quality")
            ax.plot(f["distmesh_min_quality"], label="worst quality")
            for x in np.flatnonzero(f["distmesh_retriangulated"]):
                ax.axvline(x, color="red", lw=0.5)
            ax.set_title(f"{name} (red: retriangulation)")
            ax.set_ylabel("volume-edge ratio")
            ax.legend(loc="lower right")
        axes[-1].set_xlabel("iteration")
        fig.tight_layout()
        lines.append(f"wrote {save_figure(fig, os.path.join(out, 'distmesh_fig14_retriangulation.png'))}")
    return lines


def main(argv: list[str]) -> int:
    parser = argparse.ArgumentParser(prog="fepre bench distmesh", description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="h = 0.2, 0.1 only, fewer repeats, shorter Table 3")
    parser.add_argument("--out", default=None, help="directory for the PNG figures (default: none written)")
    parser.add_argument("--skip-experiments", action="store_true", help="part 1 only")
    args = parser.parse_args(argv)
    if args.out:
        os.makedirs(args.out, exist_ok=True)
    sizes = [0.2, 0.1] if args.quick else [0.2, 0.1, 0.05]
    repeat = 1 if args.quick else 3
    sections = [lambda: speed(sizes, repeat)]
    if not args.skip_experiments:
        sections += [
            lambda: table3(300 if args.quick else 2000),
            lambda: hilbert(repeat),
            lambda: forces_figure(args.out),
            lambda: retriangulation_figure(args.out),
        ]
    for section in sections:
        print("\n".join(section()), flush=True)
        print()
    return 0
