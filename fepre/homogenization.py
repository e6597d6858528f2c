"""Effective (homogenised) elastic stiffness of a periodic cell, from six CalculiX solves.

The mesh is written with its periodic constraints (:mod:`fepre.periodic.equations`); in each
load case the three reference nodes impose one macroscopic strain (Voigt order 11, 22, 33, 23,
13, 12, engineering shears) and one node is held against rigid translation. The cell-averaged
stress comes from the elements' internal nodal forces ``f_a`` (CalculiX's ``RF`` output, which
it prints for every node; only nodes on the faces carry any once the solve is in equilibrium):

    sigma = (1 / V) sum_a f_a (x) x_a,

which equals the integral of the stress over the elements for isoparametric elements (the
coordinates are interpolated exactly), ``V`` being the cell's whole volume, voids included.
CalculiX does not report the constraint forces on the reference nodes themselves (they belong
to no element), so they cannot be used. The stiffness's column is that stress over the strain
(Hill's lemma: average stress over average strain, exact for periodic fields).
"""

from __future__ import annotations

import os
import re
import shutil
import subprocess
import tempfile
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from .arguments import choice, positive_float, shown
from .materials import elastic_material

__all__ = ["Homogenized", "homogenize", "VOIGT"]

#: Voigt order of the stiffness's rows and columns
VOIGT = ("11", "22", "33", "23", "13", "12")
#: the macroscopic strain of each load case (the result is divided by it)
STRAIN = 1e-3
_TENSOR = [(0, 0), (1, 1), (2, 2), (1, 2), (0, 2), (0, 1)]


@dataclass(frozen=True)
class Homogenized:
    """The effective stiffness of a periodic cell.

    Attributes
    ----------
    stiffness : (6, 6) float64
        ``C`` in Voigt notation (order 11, 22, 33, 23, 13, 12; engineering shear strains), in
        the material's units, symmetrised (``asymmetry`` says by how much it was not).
    relative_density : float
        The mesh's volume over the cell's.
    youngs_modulus, poissons_ratio : float
        The material.
    asymmetry : float
        ``max|C - C^T| / max|C|`` before symmetrising (a check of the solve).
    cells, nodes, order : int
        Size of the solved mesh (nodes include midside nodes for ``order=2``).
    seconds : float
        Time of the export and the six solves.
    """

    stiffness: np.ndarray
    relative_density: float
    youngs_modulus: float
    poissons_ratio: float
    asymmetry: float
    cells: int
    nodes: int
    order: int
    seconds: float

    @property
    def compliance(self) -> np.ndarray:
        """``S = C^-1`` (6, 6)."""
        return np.linalg.inv(self.stiffness)

    @property
    def young_moduli(self) -> np.ndarray:
        """Effective Young's moduli along x, y, z: ``1 / S_ii``."""
        return 1.0 / np.diag(self.compliance)[:3]

    @property
    def shear_moduli(self) -> np.ndarray:
        """Effective shear moduli G23, G13, G12: ``1 / S_ii``."""
        return 1.0 / np.diag(self.compliance)[3:]

    @property
    def poisson_ratios(self) -> np.ndarray:
        """(3, 3) ``nu_ij = -S_ji / S_ii`` (strain in j over strain in i under stress in i)."""
        s = self.compliance[:3, :3]
        ratios = -s.T / np.diag(s)[:, None]
        np.fill_diagonal(ratios, 0.0)
        return ratios

    def __repr__(self) -> str:
        rows = "\n".join("  " + " ".join(f"{v:11.4g}" for v in row) for row in self.stiffness)
        return (
            f"Homogenized(relative_density={self.relative_density:.4f}, {self.cells} cells, order {self.order}, "
            f"{self.seconds:.1f} s)\n  stiffness (Voigt 11 22 33 23 13 12):\n{rows}\n"
            f"  E = {np.array2string(self.young_moduli, precision=4)}, "
            f"G = {np.array2string(self.shear_moduli, precision=4)}"
        )


def _ccx(ccx: Any) -> str:
    if ccx is not None:
        path = shutil.which(os.fspath(ccx))
        if path is None:
            raise FileNotFoundError(f"ccx={ccx!r} is not an executable CalculiX")
        return path
    path = shutil.which("ccx")
    if path is None:
        raise FileNotFoundError(
            "CalculiX (ccx) is not installed: install it (apt-get install calculix-ccx) or pass ccx='/path/to/ccx'"
        )
    return path


def _job(young: float, poisson: float, cell, references: tuple[int, int, int], anchor: int) -> str:
    parts = [
        "*INCLUDE, INPUT=cell.inp\n",
        f"*MATERIAL, NAME=CELL_MATERIAL\n*ELASTIC\n{young:.12g}, {poisson:.12g}\n",
        "*SOLID SECTION, ELSET=EALL, MATERIAL=CELL_MATERIAL\n",
    ]
    for case in range(6):
        strain = np.zeros((3, 3))
        i, j = _TENSOR[case]
        strain[i, j] = strain[j, i] = STRAIN if i == j else 0.5 * STRAIN
        lines = [f"{anchor}, 1, 3, 0.0\n"]
        for k in range(3):
            displacement = cell.period[k] * strain[:, k]
            lines += [f"{references[k]}, {d + 1}, {d + 1}, {displacement[d]:.12e}\n" for d in range(3)]
        parts.append(
            f"** load case {VOIGT[case]}\n*STEP\n*STATIC\n*BOUNDARY, OP=NEW\n" + "".join(lines)
            + "*NODE PRINT, NSET=PBC_FACES, TOTALS=NO\nRF\n*END STEP\n"
        )
    return "".join(parts)


def _average_stresses(dat: str, points: np.ndarray, volume: float) -> np.ndarray:
    """(6, 3, 3) cell-averaged stress of each load case from the printed nodal forces."""
    blocks = re.split(r"^\s*forces \(fx,fy,fz\) for set PBC_FACES and time\s+\S+\s*$", dat, flags=re.M | re.I)[1:]
    if len(blocks) != 6:
        raise RuntimeError(f"CalculiX printed {len(blocks)} blocks of nodal forces, not 6")
    out = np.zeros((6, 3, 3))
    for case, block in enumerate(blocks):
        table = np.array([line.split() for line in block.strip().splitlines() if len(line.split()) == 4], dtype=np.float64)
        ids = table[:, 0].astype(np.int64) - 1
        out[case] = table[:, 1:].T @ points[ids] / volume
    return out


def homogenize(
    mesh,
    material: Any,
    *,
    solver: str = "calculix",
    order: int = 2,
    model: Any = None,
    ccx: Any = None,
    workdir: Any = None,
    timeout: float = 3600.0,
) -> Homogenized:
    """Effective elastic stiffness of a periodic cell (six unit-strain load cases in CalculiX).

    Parameters
    ----------
    mesh : pyvista.UnstructuredGrid
        A periodic mesh from ``fepre.distmesh(model, h, periodic=...)``.
    material : (E, nu) or dict with "E" and "nu"
        The isotropic linear-elastic material of the solid.
    solver : {"calculix"}
        The solver (CalculiX ``ccx``, found on the PATH or given by ``ccx``).
    order : {1, 2}
        C3D4 or C3D10 elements (default 2: linear tetrahedra are too stiff in bending, which
        thin lattice walls carry).
    model : fepre.sdf.SDF, optional
        The cell's model, for curved midside nodes on its surface (order 2).
    ccx : str or path, optional
        The CalculiX executable.
    workdir : str or path, optional
        An existing folder to keep the solver's files in (``cell.inp``, ``homogenize.inp``, the
        results); by default a temporary folder, removed afterwards.
    timeout : float
        Seconds the solver may run.

    Returns
    -------
    Homogenized

    Examples
    --------
    >>> import fepre
    >>> from fepre import sdf
    >>> cell = fepre.distmesh(sdf.box((9, 9, 9)) - sdf.sphere(0.3, center=(0.5, 0.5, 0.5)), h=0.15, periodic=1.0)
    >>> result = fepre.homogenize(cell, (1000.0, 0.3))  # doctest: +SKIP
    >>> round(result.relative_density, 2)  # doctest: +SKIP
    0.89
    """
    from .export import export
    from .periodic.nodes import periodic_nodes

    start = time.perf_counter()
    choice(solver, "solver", ("calculix",))
    if isinstance(order, bool) or order not in (1, 2):
        raise ValueError(f"order must be 1 or 2; got {shown(order)}")
    young, poisson = elastic_material(material)
    executable = _ccx(ccx)
    nodes = periodic_nodes(mesh)  # refuses a mesh that is not a periodic cell
    if len(nodes) == 0:
        raise ValueError("the mesh touches no face of its periodic cell: nothing connects one cell to the next")
    if workdir is not None:
        folder = Path(os.fspath(workdir))
        if not folder.is_dir():
            raise FileNotFoundError(f"workdir {str(folder)!r} is not an existing folder")
        keep = None
    else:
        keep = tempfile.TemporaryDirectory(prefix="fepre-homogenize-")
        folder = Path(keep.name)
    try:
        written = export(mesh, folder / "cell.inp", order=order, model=model)
        n = written.n_points
        references = (n + 1, n + 2, n + 3)
        anchor = int(written.field_data["periodic_anchor"][0]) + 1
        (folder / "homogenize.inp").write_text(_job(young, poisson, nodes.cell, references, anchor))
        threads = str(os.cpu_count() or 1)
        env = dict(os.environ)
        env.setdefault("OMP_NUM_THREADS", threads)
        env.setdefault("CCX_NPROC_EQUATION_SOLVER", threads)
        done = subprocess.run([executable, "-i", "homogenize"], cwd=folder, capture_output=True, text=True,
                              timeout=timeout, env=env)
        if done.returncode != 0 or "*ERROR" in done.stdout:
            tail = "\n".join(done.stdout.splitlines()[-15:])
            raise RuntimeError(f"CalculiX failed (exit {done.returncode}):\n{tail}")
        stress = _average_stresses((folder / "homogenize.dat").read_text(), np.asarray(written.points), nodes.cell.volume)
    finally:
        if keep is not None:
            keep.cleanup()
    stiffness = np.zeros((6, 6))
    for row, (i, j) in enumerate(_TENSOR):
        stiffness[row] = 0.5 * (stress[:, i, j] + stress[:, j, i]) / STRAIN
    scale = np.abs(stiffness).max()
    asymmetry = float(np.abs(stiffness - stiffness.T).max() / scale) if scale > 0 else 0.0
    return Homogenized(
        stiffness=0.5 * (stiffness + stiffness.T),
        relative_density=float(abs(mesh.volume) / nodes.cell.volume),
        youngs_modulus=young,
        poissons_ratio=poisson,
        asymmetry=asymmetry,
        cells=int(mesh.n_cells),
        nodes=int(n),
        order=order,
        seconds=time.perf_counter() - start,
    )
