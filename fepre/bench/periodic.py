"""Periodic cells: matching faces and quality of periodic meshes, and homogenised stiffness in CalculiX.

Meshes: a gyroid sheet (period 1, thickness 0.2), a Schwarz P sheet, three crossing struts in a
non-cubic cell (1 x 1.4 x 0.8) and a cube with a centred spherical void, each at two edge lengths
with ``fepre.distmesh(..., periodic=...)``; printed: cells, seconds, the worst and largest
dihedral angle and the smallest radius ratio (targets 25, 150, 0.25), the node pairs, the
largest gap between partners (target 1e-12), the unpaired rim nodes and the share of face
triangles whose counterpart on the opposite face is the same triangle.

Homogenisation (``--homogenize``, needs ``ccx``): C3D10 in CalculiX; the void cell against the
Hashin-Shtrikman upper bounds of its void fraction, and gyroid sheets of several thicknesses:
relative density, C11, C12, C44, the spread of the three C11 and three C44 (cubic symmetry,
target 1%), the Zener ratio, E/Es and E over the Hashin-Shtrikman upper bound's, and the mean
Poisson's ratio (DeValk and Lakes, phys. stat. sol. (b) 2021, measured 0.34 +- 0.06 on gyroid
lattices of several densities, independent of direction; ``--nu`` sets the solid's), with a
power-law fit ``E/Es = C rho^n``.
"""

from __future__ import annotations

import argparse
import time
import warnings

import numpy as np


def _struts():
    from .. import sdf

    centre = (0.5, 0.7, 0.4)
    return (sdf.cylinder(0.15, 10.0, center=centre, axis="x") | sdf.cylinder(0.15, 10.0, center=centre, axis="y")
            | sdf.cylinder(0.15, 10.0, center=centre, axis="z"))


def _cells():
    from .. import sdf

    return [
        ("gyroid sheet t=0.2", sdf.gyroid(period=1.0, thickness=0.2), 1.0, (0.09, 0.06)),
        ("Schwarz P sheet t=0.15", sdf.schwarz_p(period=1.0, thickness=0.15, center=(0.5, 0.5, 0.5)), 1.0, (0.07, 0.05)),
        ("struts in 1 x 1.4 x 0.8", _struts(), (1.0, 1.4, 0.8), (0.08, 0.05)),
        ("spherical void r=0.3", sdf.box((9, 9, 9)) - sdf.sphere(0.3, center=(0.5, 0.5, 0.5)), 1.0, (0.1, 0.06)),
    ]


def face_triangle_match(mesh) -> float:
    """Share of the triangles on the cell's faces whose translate is a triangle of the opposite face."""
    from ..periodic.nodes import periodic_nodes

    nodes = periodic_nodes(mesh)
    cell = nodes.cell
    surface = mesh.extract_surface(algorithm="dataset_surface")
    triangles = np.asarray(surface["vtkOriginalPointIds"])[surface.faces.reshape(-1, 4)[:, 1:]]
    points = np.asarray(mesh.points)
    matched = total = 0
    for axis in range(3):
        coordinate = points[triangles][:, :, axis]
        low = triangles[(np.abs(coordinate - cell.lower[axis]) <= 1e-12).all(axis=1)]
        high = triangles[(np.abs(coordinate - cell.upper[axis]) <= 1e-12).all(axis=1)]
        pairs = nodes.pairs(axis)
        down = np.arange(len(points))
        down[pairs[:, 1]] = pairs[:, 0]
        a = {tuple(sorted(t)) for t in low.tolist()}
        b = {tuple(sorted(t)) for t in down[high].tolist()}
        matched += 2 * len(a & b)
        total += len(a) + len(b)
    return matched / total if total else 1.0


def _mesh_table() -> None:
    import fepre

    print("periodic meshes (fepre.distmesh(model, h, periodic=L)):")
    print(f"{'cell':26s} {'h':>5s} {'cells':>7s} {'s':>6s} {'worst':>6s} {'largest':>7s} {'min rr':>6s} "
          f"{'pairs':>6s} {'max gap':>8s} {'unpaired':>8s} {'faces same':>10s}")
    for name, model, period, hs in _cells():
        for h in hs:
            start = time.perf_counter()
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                mesh = fepre.distmesh(model, h=h, periodic=period)
            seconds = time.perf_counter() - start
            nodes = fepre.periodic_nodes(mesh)
            gap = np.abs(np.asarray(mesh.points)[nodes.slaves] - nodes.shifts * nodes.cell.period
                         - np.asarray(mesh.points)[nodes.masters]).max()
            print(f"{name:26s} {h:5.3g} {mesh.n_cells:7d} {seconds:6.1f} {mesh['min_dihedral_angle'].min():6.1f} "
                  f"{mesh['max_dihedral_angle'].max():7.1f} {mesh['radius_ratio'].min():6.3f} {len(nodes):6d} "
                  f"{gap:8.1e} {nodes.unpaired.size:8d} {face_triangle_match(mesh):10.3f}", flush=True)


def _moduli(c: np.ndarray) -> tuple[float, float]:
    bulk = c[:3, :3].sum() / 9.0
    shear = (np.trace(c[:3, :3]) - (c[0, 1] + c[0, 2] + c[1, 2]) + 3 * np.trace(c[3:, 3:])) / 15.0
    return bulk, shear


def _hs_upper_young(young: float, poisson: float, density: float) -> float:
    """Young's modulus of the Hashin-Shtrikman upper bound of a porous isotropic solid."""
    bulk, shear = young / (3 * (1 - 2 * poisson)), young / (2 * (1 + poisson))
    bulk_hs = 4 * shear * bulk * density / (4 * shear + 3 * bulk * (1 - density))
    shear_hs = shear + (1 - density) / (-1 / shear + 6 * (bulk + 2 * shear) * density / (5 * shear * (3 * bulk + 4 * shear)))
    return 9 * bulk_hs * shear_hs / (3 * bulk_hs + shear_hs)


def _homogenize_table(thicknesses: list[float], order: int, poisson: float = 0.3) -> None:
    import fepre
    from .. import sdf

    young = 1000.0
    bulk1, shear1 = young / (3 * (1 - 2 * poisson)), young / (2 * (1 + poisson))
    print(f"\nhomogenisation in CalculiX (C3D{10 if order == 2 else 4}, E = {young:g}, nu = {poisson}):")
    radius = 0.3
    void = sdf.box((9, 9, 9)) - sdf.sphere(radius, center=(0.5, 0.5, 0.5))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        mesh = fepre.distmesh(void, h=0.08, periodic=1.0)
    result = fepre.homogenize(mesh, (young, poisson), order=order, model=void)
    f = 4 / 3 * np.pi * radius**3
    bulk_hs = bulk1 + f / (-1 / bulk1 + 3 * (1 - f) / (3 * bulk1 + 4 * shear1))
    shear_hs = shear1 + f / (-1 / shear1 + 6 * (1 - f) * (bulk1 + 2 * shear1) / (5 * shear1 * (3 * bulk1 + 4 * shear1)))
    bulk, shear = _moduli(result.stiffness)
    print(f"spherical void r=0.3 (f = {f:.4f}), h=0.08: {mesh.n_cells} cells, {result.seconds:.1f} s; K/K_HS+ = "
          f"{bulk / bulk_hs:.4f}, G_Voigt/G_HS+ = {shear / shear_hs:.4f}, C44/G_HS+ = {result.stiffness[3, 3] / shear_hs:.4f}")
    print(f"\n{'gyroid t':>8s} {'h':>5s} {'cells':>7s} {'s':>6s} {'rho':>6s} {'C11':>8s} {'C12':>8s} {'C44':>8s} "
          f"{'C11 spread':>10s} {'C44 spread':>10s} {'Zener':>6s} {'E/Es':>7s} {'E/E_HS+':>7s} {'nu':>6s}")
    densities, ratios = [], []
    for thickness in thicknesses:
        h = min(0.09, thickness / 2.2)
        model = sdf.gyroid(period=1.0, thickness=thickness)
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            mesh = fepre.distmesh(model, h=h, periodic=1.0)
        result = fepre.homogenize(mesh, (young, poisson), order=order, model=model)
        c = result.stiffness
        d = np.diag(c)
        zener = 2 * d[3:].mean() / (d[:3].mean() - np.mean([c[0, 1], c[0, 2], c[1, 2]]))
        e = result.young_moduli.mean() / young
        densities.append(result.relative_density)
        ratios.append(e)
        print(f"{thickness:8.3g} {h:5.3g} {mesh.n_cells:7d} {result.seconds:6.1f} {result.relative_density:6.3f} "
              f"{d[:3].mean():8.2f} {np.mean([c[0, 1], c[0, 2], c[1, 2]]):8.2f} {d[3:].mean():8.2f} "
              f"{np.ptp(d[:3]) / d[:3].mean():10.4f} {np.ptp(d[3:]) / d[3:].mean():10.4f} {zener:6.3f} {e:7.4f} "
              f"{e * young / _hs_upper_young(young, poisson, result.relative_density):7.3f} "
              f"{result.poisson_ratios[~np.eye(3, dtype=bool)].mean():6.3f}", flush=True)
    if len(densities) >= 2:
        n, log_c = np.polyfit(np.log(densities), np.log(ratios), 1)
        print(f"power law fit: E/Es = {np.exp(log_c):.3f} rho^{n:.3f} over rho {min(densities):.3f}-{max(densities):.3f}")


def main(argv: list[str]) -> int:
    parser = argparse.ArgumentParser(prog="fepre bench periodic", description=__doc__.splitlines()[0])
    parser.add_argument("--homogenize", action="store_true", help="also homogenise in CalculiX (minutes)")
    parser.add_argument("--skip-meshes", action="store_true", help="only the homogenisation table")
    parser.add_argument("--thickness", type=float, nargs="+", default=[0.2, 0.15, 0.1],
                        help="gyroid sheet thicknesses (period 1) for the stiffness-density table")
    parser.add_argument("--order", type=int, choices=(1, 2), default=2)
    parser.add_argument("--nu", type=float, default=0.3, help="Poisson's ratio of the solid (default 0.3)")
    args = parser.parse_args(argv)
    if not args.skip_meshes:
        _mesh_table()
    if args.homogenize:
        _homogenize_table(args.thickness, args.order, args.nu)
    return 0
