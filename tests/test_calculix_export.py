"""CalculiX (ccx) runs on meshes exported by fepre.export: uniform-strain patch tests (C3D4,
C3D10 with curved boundaries) and a loaded part whose reactions balance the applied load."""

from __future__ import annotations

import os
import re
import shutil
import subprocess
from pathlib import Path

import numpy as np
import pytest

import fepre
from fepre import sdf

from test_export_meshes import distmesh_ball, kuhn_box

CCX = shutil.which("ccx")
pytestmark = pytest.mark.skipif(CCX is None, reason="CalculiX `ccx` is not installed (apt-get install calculix-ccx)")

E, NU = 210000.0, 0.3
EPS0 = np.array([[1.0e-3, 2.0e-4, -1.5e-4], [2.0e-4, -5.0e-4, 3.0e-4], [-1.5e-4, 3.0e-4, 8.0e-4]])


def run_ccx(directory: Path, job: str, text: str) -> str:
    (directory / f"{job}.inp").write_text(text)
    env = dict(os.environ, OMP_NUM_THREADS="1", CCX_NPROC_EQUATION_SOLVER="1")
    done = subprocess.run([CCX, "-i", job], cwd=directory, capture_output=True, text=True, timeout=120, env=env)
    assert done.returncode == 0 and "*ERROR" not in done.stdout, done.stdout[-3000:]
    return (directory / f"{job}.dat").read_text()


def dat_block(dat: str, title: str) -> np.ndarray:
    """Numeric rows of the first .dat block whose header starts with ``title``."""
    lines = dat.splitlines()
    start = next(i for i, line in enumerate(lines) if line.strip().startswith(title))
    rows = []
    for line in lines[start + 1 :]:
        if not line.strip():
            if rows:
                break
            continue
        if re.match(r"^\s*[a-z]", line):
            break
        rows.append([float(v) for v in line.split()])
    return np.array(rows)


def node_set(inp: str, name: str) -> np.ndarray:
    match = re.search(rf"^\*NSET, NSET={name}\n((?:[\d, ]+\n)+)", inp, flags=re.M)
    return np.array([int(v) for v in match.group(1).replace(",", " ").split()])


def material(elset: str = "EALL") -> str:
    return (
        f"*MATERIAL, NAME=STEEL\n*ELASTIC\n{E}, {NU}\n"
        f"*SOLID SECTION, ELSET={elset}, MATERIAL=STEEL\n"
    )


@pytest.fixture(scope="module")
def ball_mesh():
    return distmesh_ball(0.35)


def patch_test(tmp_path: Path, mesh, order: int, curved: bool = False, tolerance: float = 1e-6) -> None:
    model = sdf.sphere(1.0) if curved else None
    exported = fepre.export(mesh, tmp_path / "part.inp", order=order, model=model)
    inp = (tmp_path / "part.inp").read_text()
    points = np.asarray(exported.points)
    boundary = node_set(inp, "boundary")  # every node of the boundary faces (1-based)
    prescribed = points[boundary - 1] @ EPS0.T
    table = np.column_stack([np.repeat(boundary, 3), np.tile([1, 2, 3], boundary.size)])
    values = prescribed.ravel()
    bc = "".join(f"{n}, {d}, {d}, {v:.12e}\n" for (n, d), v in zip(table.tolist(), values.tolist()))
    job = (
        "*INCLUDE, INPUT=part.inp\n" + material() + "*STEP\n*STATIC\n*BOUNDARY\n" + bc
        + "*NODE PRINT, NSET=NALL\nU\n*EL PRINT, ELSET=EALL\nS\n*END STEP\n"
    )
    dat = run_ccx(tmp_path, "patch", job)
    displacement = dat_block(dat, "displacements")
    stresses = dat_block(dat, "stresses")
    n_elements = exported.n_cells
    assert displacement.shape == (points.shape[0], 4)
    interior = np.setdiff1d(np.arange(1, points.shape[0] + 1), boundary)
    assert interior.size > 10
    expected = points @ EPS0.T
    got = displacement[np.argsort(displacement[:, 0]), 1:]
    scale = np.abs(expected).max()
    assert np.abs(got[interior - 1] - expected[interior - 1]).max() <= tolerance * scale
    lam, mu = E * NU / ((1 + NU) * (1 - 2 * NU)), E / (2 * (1 + NU))
    sigma = lam * np.trace(EPS0) * np.eye(3) + 2 * mu * EPS0
    exact = np.array([sigma[0, 0], sigma[1, 1], sigma[2, 2], sigma[0, 1], sigma[0, 2], sigma[1, 2]])
    points_per_element = 4 if order == 2 else 1
    assert stresses.shape == (n_elements * points_per_element, 8)
    assert np.abs(stresses[:, 2:] - exact).max() <= tolerance * np.abs(exact).max()


def test_patch_test_c3d4(tmp_path, ball_mesh):
    patch_test(tmp_path, ball_mesh, order=1)


def test_patch_test_c3d10(tmp_path, ball_mesh):
    patch_test(tmp_path, ball_mesh, order=2)


def test_patch_test_c3d10_curved(tmp_path, ball_mesh):
    # On curved C3D10 elements det(J) varies, so the 4-point rule of C3D10 no longer integrates
    # the stiffness exactly and the patch test holds to the quadrature error (measured 2.7e-4
    # relative in the stresses on this coarse ball), not to round-off.
    patch_test(tmp_path, ball_mesh, order=2, curved=True, tolerance=1e-3)


@pytest.fixture(scope="module")
def bracket():
    """A DistMesh mesh of a 2 x 1 x 1 block with a vertical through-hole of radius 0.25."""
    import warnings

    part = sdf.box((2, 1, 1)) - sdf.cylinder(radius=0.25, height=2)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", fepre.ConvergenceWarning)
        return fepre.distmesh(part, h=0.2)


@pytest.mark.parametrize("order", [1, 2])
def test_loaded_bracket_reactions_balance_the_load(tmp_path, bracket, order):
    # Clamped on x = -1; pressure p1 on x = +1, a bolt pressure p2 on the hole, and a force F
    # in z spread over the top nodes not clamped. The reactions on the clamped set must sum to
    # minus the applied load, computed here from the named face sets' vector areas.
    boundaries = {
        "fixed": sdf.plane((-1, 0, 0), (-1, 0, 0)),
        "loaded": sdf.plane((1, 0, 0), (1, 0, 0)),
        "top": sdf.plane((0, 0, 1), (0, 0, 0.5)),
        "hole": sdf.cylinder(radius=0.25, height=2),
    }
    exported = fepre.export(bracket, tmp_path / "part.inp", order=order, boundaries=boundaries)
    faces = fepre.export.tag_boundaries(bracket, boundaries)
    p = np.asarray(faces.points)[faces.regular_faces]
    vector_areas = 0.5 * np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0])  # outward
    names = faces.field_data["boundary_names"].tolist()
    area = {n: vector_areas[faces["boundary_id"] == i].sum(axis=0) for i, n in enumerate(names)}
    assert area["loaded"][0] == pytest.approx(1.0, abs=0.03)  # DistMesh rounds the box edges a little
    hole_area = np.linalg.norm(vector_areas[faces["boundary_id"] == names.index("hole")], axis=1).sum()
    assert hole_area == pytest.approx(2 * np.pi * 0.25, rel=0.1)  # the hole's wall, rims aside
    inp = (tmp_path / "part.inp").read_text()
    top = np.setdiff1d(node_set(inp, "top"), node_set(inp, "fixed"))
    p1, p2, force = 3.0, 2.0, 5.0
    cload = "".join(f"{n}, 3, {force / top.size:.12e}\n" for n in top.tolist())
    job = (
        "*INCLUDE, INPUT=part.inp\n" + material() + "*STEP\n*STATIC\n*BOUNDARY\nfixed, 1, 3\n"
        f"*DSLOAD\nloaded, P, {p1}\nhole, P, {p2}\n*CLOAD\n{cload}"
        "*NODE PRINT, NSET=fixed, TOTALS=ONLY\nRF\n*END STEP\n"
    )
    dat = run_ccx(tmp_path, "bracket", job)
    total = dat_block(dat, "total force")
    applied = -p1 * area["loaded"] - p2 * area["hole"] + np.array([0.0, 0.0, force])
    assert total.shape == (1, 3)
    assert np.allclose(total[0], -applied, rtol=0, atol=1e-5 * np.abs(applied).max())
    assert exported.n_cells == bracket.n_cells


@pytest.fixture(scope="module")
def washer():
    """A DistMesh mesh of a washer: outer radius 25, hole radius 10, 10 thick (h = 4)."""
    import warnings

    part = sdf.cylinder(radius=25.0, height=10.0) - sdf.cylinder(radius=10.0, height=30.0)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", fepre.ConvergenceWarning)
        return part, fepre.distmesh(part, h=4.0)


def test_c3d10_pressure_on_an_annulus_gives_p_times_its_area(tmp_path, washer):
    # The top face is a flat annulus bounded by two circles (feature curves). With midside nodes of
    # the rim edges on the chords, the face lost 0.51% of its area (reaction 1640.9 for p.A 1649.3);
    # on the circles the reaction equals p.A (measured 8e-6 relative).
    part, mesh = washer
    boundaries = {"top": sdf.plane((0, 0, 1), (0, 0, 5.0)), "bottom": sdf.plane((0, 0, -1), (0, 0, -5.0))}
    fepre.export(mesh, tmp_path / "part.inp", order=2, model=part, boundaries=boundaries)
    job = (
        "*INCLUDE, INPUT=part.inp\n" + material() + "*STEP\n*STATIC\n*BOUNDARY\nbottom, 1, 3\n"
        "*DSLOAD\ntop, P, 1.0\n*NODE PRINT, NSET=bottom, TOTALS=ONLY\nRF\n*END STEP\n"
    )
    total = dat_block(run_ccx(tmp_path, "washer", job), "total force")[0]
    area = np.pi * (25.0**2 - 10.0**2)
    assert abs(total[2] - area) <= 5e-4 * area
    assert np.abs(total[:2]).max() <= 1e-6 * area


def test_pressure_on_the_enclosure_floor_gives_p_times_the_flat_floor(tmp_path):
    # Issue 33: a pressure on the "floor" set of an enclosure whose bottom edges are chamfered
    # 30 degrees. The floor set held the chamfer's first row of faces (60.02 against 45): the
    # reaction was 33% over p A. With only the faces on the floor it is p A (C3D10).
    from test_export_sets import FLOOR, FLOOR_AREA, enclosure, meshed

    part = enclosure()
    mesh = meshed(part, 1.0)
    top = sdf.plane((0, 0, 1), (0, 0, 5.0))
    grid = fepre.export(mesh, tmp_path / "part.inp", order=2, model=part, boundaries={"floor": FLOOR, "rim": top})
    job = (
        "*INCLUDE, INPUT=part.inp\n" + material() + "*STEP\n*STATIC\n*BOUNDARY\nrim, 1, 3\n"
        "*DSLOAD\nfloor, P, 2.0\n*NODE PRINT, NSET=rim, TOTALS=ONLY\nRF\n*END STEP\n"
    )
    total = dat_block(run_ccx(tmp_path, "enclosure", job), "total force")[0]
    assert abs(total[2] + 2.0 * FLOOR_AREA) <= 1e-3 * 2.0 * FLOOR_AREA  # the pressure pushes up (+z)
    assert np.abs(total[:2]).max() <= 1e-6 * FLOOR_AREA
    names = grid.field_data["boundary_names"].tolist()
    assert grid.field_data["boundary_areas"][names.index("floor")] == pytest.approx(FLOOR_AREA, rel=1e-9)
