"""Adaptive re-meshing: solve, estimate the error per cell, re-mesh with that background size.

An L-shaped block (a 2 x 2 square with one quadrant cut away, 0.5 thick) has a re-entrant edge
where the solution of Laplace's equation is singular: ``u = r^(2/3) sin(2 phi / 3)`` (phi from
the notch's first face), given on the boundary. scikit-fem solves it with linear tetrahedra;
the error per cell is estimated by gradient recovery (Zienkiewicz-Zhu: the nodal average of the
cells' gradients against each cell's own), the cells are given the sizes that spread the error
evenly (``h_new = h * (target / error)^(2/5)``, as the error of a cell of size h goes as
``h^(5/2)``), and that mesh, carrying its ``size`` array, is the background mesh of the next
``fepre.distmesh`` call. Uniform refinement on the same part is measured alongside: the energy
error against the exact solution falls faster per cell with adaptation.

Run ``python examples/adaptive_remeshing.py [OUTPUT_FOLDER]``; it writes the last mesh (VTU) and
prints the error and cell count of every step.
"""

from __future__ import annotations

import sys
import warnings
from pathlib import Path

import numpy as np

import fepre
from fepre import sdf

L_BLOCK = sdf.box((2.0, 2.0, 0.5)) - sdf.box((1.2, 1.2, 1.0), center=(0.6, 0.6, 0.0))


def _angle(x: np.ndarray) -> np.ndarray:
    """phi in [-pi/4, 7pi/4): nodes a rounding error outside a notch face stay next to it."""
    return np.mod(np.arctan2(x[1], x[0]) - np.pi / 2 + np.pi / 4, 2 * np.pi) - np.pi / 4


def exact(x: np.ndarray) -> np.ndarray:
    """``r^(2/3) sin(2 phi / 3)``, phi measured from the notch face x = 0 (y > 0) around to y = 0."""
    r = np.hypot(x[0], x[1])
    phi = _angle(x)
    return r ** (2 / 3) * np.sin(2 * phi / 3)


def exact_gradient(x: np.ndarray) -> np.ndarray:
    r = np.maximum(np.hypot(x[0], x[1]), 1e-300)
    phi = _angle(x)
    theta = phi + np.pi / 2
    radial = (2 / 3) * r ** (-1 / 3) * np.sin(2 * phi / 3)
    angular = (2 / 3) * r ** (-1 / 3) * np.cos(2 * phi / 3)
    return np.stack([radial * np.cos(theta) - angular * np.sin(theta),
                     radial * np.sin(theta) + angular * np.cos(theta), np.zeros_like(r)])


def solve(mesh):
    """Laplace's equation with the exact values on the boundary; the energy error and the
    Zienkiewicz-Zhu indicator per cell."""
    from skfem import Basis, ElementTetP1, Functional, MeshTet, condense, solve as fem_solve, solver_iter_pcg
    from skfem.models.poisson import laplace

    points = np.asarray(mesh.points, dtype=np.float64)
    tets = np.asarray(mesh.cells_dict[10], dtype=np.int64)
    fem = MeshTet(points.T, tets.T)
    basis = Basis(fem, ElementTetP1(), intorder=4)
    stiffness = laplace.assemble(basis)
    boundary = basis.get_dofs().all()
    u = np.zeros(basis.N)
    u[boundary] = exact(points[boundary].T)
    u = fem_solve(*condense(stiffness, np.zeros(basis.N), x=u, D=boundary), solver=solver_iter_pcg(rtol=1e-10))

    @Functional
    def squared_energy_error(w):
        difference = w["uh"].grad - exact_gradient(w.x)
        return (difference**2).sum(axis=0)

    error = float(np.sqrt(squared_energy_error.assemble(basis, uh=basis.interpolate(u))))
    # cell gradients (P1: constant per cell) and their volume-weighted nodal averages
    corners = points[tets]
    edges = corners[:, 1:] - corners[:, :1]
    volume = np.abs(np.linalg.det(edges)) / 6.0
    gradient = np.linalg.solve(edges, (u[tets[:, 1:]] - u[tets[:, :1]])[..., None])[..., 0]
    weight = np.zeros(len(points))
    np.add.at(weight, tets, volume[:, None])
    recovered = np.zeros((len(points), 3))
    np.add.at(recovered, tets, (volume[:, None] * gradient)[:, None, :])
    recovered /= weight[:, None]
    indicator = np.sqrt(volume * ((recovered[tets] - gradient[:, None, :]) ** 2).sum(axis=2).mean(axis=1))
    return error, indicator


def mesh_with(**arguments):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", fepre.ConvergenceWarning)
        return fepre.distmesh(L_BLOCK, **arguments)


def adapt(steps: int = 6, start: float = 0.25, growth: float = 2.2):
    """Errors and cell counts of uniform meshes and of ``steps`` adapted meshes."""
    uniform = []
    for h in (start, start / growth ** (1 / 3), start / growth ** (2 / 3), start / growth):
        mesh = mesh_with(h=h)
        uniform.append((mesh.n_cells, solve(mesh)[0]))
    adaptive = []
    mesh = mesh_with(h=start)
    for _ in range(steps):
        error, indicator = solve(mesh)
        adaptive.append((mesh.n_cells, error))
        points = np.asarray(mesh.points)
        tets = mesh.cells_dict[10]
        corners = points[tets]
        size = (np.abs(np.linalg.det(corners[:, 1:] - corners[:, :1])) / 6.0 * 6 * np.sqrt(2)) ** (1 / 3)
        # spread the error over growth times as many cells
        target = np.sqrt((indicator**2).sum() / (growth * len(tets)))
        wanted = np.clip(size * (target / np.maximum(indicator, 1e-300)) ** 0.4, size / 3, 2 * size)
        background = mesh.copy()
        background.clear_data()
        background.cell_data["size"] = np.clip(wanted, 0.01, 0.5)
        mesh = mesh_with(size=background)
    return uniform, adaptive, mesh


def rate(runs) -> float:
    """Slope of log(error) against log(cells)."""
    cells, errors = np.array(runs, dtype=float).T
    return float(np.polyfit(np.log(cells), np.log(errors), 1)[0])


def main(folder: str = ".") -> tuple[list, list]:
    uniform, adaptive, last = adapt()
    for name, runs in (("uniform", uniform), ("adaptive", adaptive)):
        print(f"{name:9s} " + "  ".join(f"{cells:6d} cells {error:.4f}" for cells, error in runs)
              + f"   rate {rate(runs):.3f}")
    out = Path(folder) / "adapted_l_block.vtu"
    last.save(str(out))
    print(f"wrote {out}")
    return uniform, adaptive


if __name__ == "__main__":
    main(sys.argv[1] if len(sys.argv) > 1 else ".")
