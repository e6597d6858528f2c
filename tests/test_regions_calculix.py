"""Two-material bars in CalculiX: a conformal region mesh gives the Reuss (series) and Voigt
(parallel) stiffness exactly, and the interface nodes move as the exact solution says."""

from __future__ import annotations

import shutil
import subprocess

import numpy as np
import pytest

import fepre
from fepre import sdf

from test_calculix_export import dat_block, node_set

CCX = shutil.which("ccx")
pytestmark = pytest.mark.skipif(CCX is None, reason="CalculiX `ccx` is not installed (apt-get install calculix-ccx)")

E1, E2 = 1000.0, 3000.0
STRETCH = 0.002  # displacement of the end x = 2
BAR = sdf.box((2, 1, 1), center=(1, 0.5, 0.5))
ENDS = {
    "x0": sdf.plane((-1, 0, 0), (0, 0, 0)),
    "x1": sdf.plane((1, 0, 0), (2, 0, 0)),
    "y0": sdf.plane((0, -1, 0), (0, 0, 0)),
    "z0": sdf.plane((0, 0, -1), (0, 0, 0)),
}


def stretch(tmp_path, mesh, materials, order):
    """Rollers on x = 0, y = 0, z = 0, the end x = 2 moved by STRETCH; (end force, .inp text, .dat text)."""
    fepre.export(mesh, tmp_path / "part.inp", order=order, boundaries=ENDS, materials=materials)
    job = (
        "*INCLUDE, INPUT=part.inp\n*STEP\n*STATIC\n*BOUNDARY\nx0, 1, 1, 0\ny0, 2, 2, 0\nz0, 3, 3, 0\n"
        f"x1, 1, 1, {STRETCH}\n*NODE PRINT, NSET=x1, TOTALS=ONLY\nRF\n*NODE PRINT, NSET=NALL\nU\n*END STEP\n"
    )
    (tmp_path / "job.inp").write_text(job)
    done = subprocess.run([CCX, "-i", "job"], cwd=tmp_path, capture_output=True, text=True, timeout=300,
                          env={"OMP_NUM_THREADS": "1", "PATH": "/usr/bin:/bin"})
    assert done.returncode == 0 and "*ERROR" not in done.stdout, done.stdout[-2000:]
    dat = (tmp_path / "job.dat").read_text()
    force = dat_block(dat, "total force")[0, 0]
    return force, (tmp_path / "part.inp").read_text(), dat


@pytest.mark.slow
@pytest.mark.parametrize("order", [1, 2])
def test_bar_in_series_gives_the_reuss_stiffness(tmp_path, order):
    # nu = 0: each half is in uniaxial stress with no lateral strain, so the exact solution is
    # piecewise linear in x with a kink at x = 1, which the elements reproduce exactly only if
    # the interface is made of faces of the mesh.
    regions = {"soft": sdf.box((1, 1, 1), center=(0.5, 0.5, 0.5)), "stiff": sdf.box((1, 1, 1), center=(1.5, 0.5, 0.5))}
    mesh = fepre.distmesh(BAR, 0.25, regions=regions)
    force, inp, dat = stretch(tmp_path, mesh, {"soft": (E1, 0.0), "stiff": (E2, 0.0)}, order)
    reuss = 2.0 / (1.0 / E1 + 1.0 / E2)  # area 1, length 2
    assert force == pytest.approx(reuss * STRETCH / 2.0, rel=1e-6)
    displacement = dat_block(dat, "displacements")
    u = dict(zip(displacement[:, 0].astype(int).tolist(), displacement[:, 1].tolist()))
    interface = node_set(inp, "interface_soft_stiff")
    assert interface.size > 20
    at_interface = STRETCH * (1.0 / E1) / (1.0 / E1 + 1.0 / E2)
    assert np.allclose([u[n] for n in interface.tolist()], at_interface, rtol=1e-5, atol=0)


@pytest.mark.slow
@pytest.mark.parametrize("order", [1, 2])
def test_bar_in_parallel_gives_the_voigt_stiffness(tmp_path, order):
    # Equal nu: both halves take the same axial and lateral strains, so the interface y = 0.5
    # carries no traction mismatch and the stiffness is the volume average.
    regions = {"soft": sdf.box((2, 0.5, 1), center=(1, 0.25, 0.5)), "stiff": sdf.box((2, 0.5, 1), center=(1, 0.75, 0.5))}
    mesh = fepre.distmesh(BAR, 0.25, regions=regions)
    force, _, _ = stretch(tmp_path, mesh, {"soft": (E1, 0.3), "stiff": (E2, 0.3)}, order)
    voigt = 0.5 * (E1 + E2)
    assert force == pytest.approx(voigt * STRETCH / 2.0, rel=1e-6)


@pytest.mark.slow
def test_a_step_assembly_in_series_gives_the_reuss_stiffness(tmp_path):
    # the same bar as two solids of one STEP file, touching face to face at x = 1: each solid
    # its own element set and material, the shared face made of faces of the mesh
    import gmsh

    gmsh.initialize(interruptible=False)
    try:
        gmsh.option.setNumber("General.Terminal", 0)
        gmsh.model.occ.addBox(0, 0, 0, 1, 1, 1)
        gmsh.model.occ.addBox(1, 0, 0, 1, 1, 1)
        gmsh.model.occ.synchronize()
        gmsh.write(str(tmp_path / "bar.step"))
    finally:
        gmsh.finalize()
    solids = sdf.cad_solids(tmp_path / "bar.step", names={1: "soft", 2: "stiff"})
    mesh = fepre.distmesh(solids.part, 0.25, regions=solids, progress=False)
    force, inp, dat = stretch(tmp_path, mesh, {"soft": (E1, 0.0), "stiff": (E2, 0.0)}, 1)
    assert force == pytest.approx(1.0 / (1.0 / E1 + 1.0 / E2) * STRETCH, rel=1e-6)
    displacement = dat_block(dat, "displacements")
    u = dict(zip(displacement[:, 0].astype(int).tolist(), displacement[:, 1].tolist()))
    interface = node_set(inp, "interface_soft_stiff")
    assert interface.size > 20
    assert np.allclose([u[n] for n in interface.tolist()], STRETCH * E2 / (E1 + E2), rtol=1e-5, atol=0)
