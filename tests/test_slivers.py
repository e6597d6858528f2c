"""The quality stage (fepre.improve, fepre.distmesh.slivers) on the issue's models and bad input."""

from __future__ import annotations

import warnings

import numpy as np
import pytest
import pyvista as pv

import fepre
from fepre import quality, sdf
from fepre.distmesh.slivers import improve_arrays
from fepre.distmesh.topology import check_topology

WORST_TARGET = 15.0  # the floor; the stage aims at 20 and above
MEAN_RR_TARGET = 0.90


def raw_mesh(model, h, **kwargs) -> pv.UnstructuredGrid:
    """DistMesh without the quality stage: the stage's real input, slivers included."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", fepre.ConvergenceWarning)
        return fepre.distmesh(model, h, slivers=False, **kwargs)


def arrays(mesh: pv.UnstructuredGrid) -> tuple[np.ndarray, np.ndarray]:
    return np.asarray(mesh.points, dtype=np.float64), mesh.cells_dict[pv.CellType.TETRA].astype(np.int64)


def assert_improved(
    before: pv.UnstructuredGrid, after: pv.UnstructuredGrid, model, h, exact_volume=None, mean_rr=MEAN_RR_TARGET
):
    """Targets met, nothing inverted, closed boundary on the zero set, volume kept."""
    points, tets = arrays(after)
    q = quality.tet_quality(points, tets)  # fepre.quality: independent of the stage's own kernel
    assert q["volume"].min() > 0
    assert q["min_dihedral_angle"].min() >= WORST_TARGET
    assert q["radius_ratio"].mean() >= mean_rr
    assert q["radius_ratio"].mean() > before["radius_ratio"].mean() + 0.01
    report = check_topology(tets, len(points))
    assert report.ok, report
    boundary = np.unique(report.boundary_faces)
    assert np.abs(model(points[boundary])).max() <= 1e-3 * h
    # closed: the outward boundary faces enclose exactly the cells' volume (divergence theorem),
    # and the surface keeps almost all its faces (only flat boundary cells are removed)
    f = points[report.boundary_faces]
    enclosed = np.einsum("ij,ij->i", f[:, 0], np.cross(f[:, 1], f[:, 2])).sum() / 6.0
    assert enclosed == pytest.approx(q["volume"].sum(), rel=1e-9)
    old_points, old_tets = arrays(before)
    old_faces = {tuple(face) for face in np.sort(check_topology(old_tets, len(old_points)).boundary_faces, 1)}
    new_faces = {tuple(face) for face in np.sort(report.boundary_faces, 1)}
    assert len(old_faces ^ new_faces) <= 0.02 * len(old_faces)
    assert q["volume"].sum() == pytest.approx(before.volume, rel=0.02)
    if exact_volume is not None:
        assert q["volume"].sum() == pytest.approx(exact_volume, rel=0.02)
    for name in quality.METRICS:
        np.testing.assert_allclose(after.cell_data[name], q[name])
    np.testing.assert_allclose(after["sdf"], model(points))
    assert set(np.flatnonzero(after["boundary"])) == set(boundary.tolist())


@pytest.fixture(scope="module")
def sphere_raw():
    return raw_mesh(sdf.sphere(1.0), 0.2)


def test_raw_distmesh_has_slivers_that_the_stage_removes(sphere_raw):
    ball = sdf.sphere(1.0)
    assert sphere_raw["min_dihedral_angle"].min() < 10  # the problem is real
    better = fepre.improve(sphere_raw, ball)
    assert_improved(sphere_raw, better, ball, 0.2)
    assert better.volume == pytest.approx(4 / 3 * np.pi, rel=0.03)  # inscribed polyhedron at h=0.2
    assert better["min_dihedral_angle"].min() >= 20  # the aim, not just the floor
    assert better.field_data["improve_min_dihedral_before"][0] == pytest.approx(sphere_raw["min_dihedral_angle"].min())


@pytest.mark.slow
@pytest.mark.parametrize(
    "name, model, h, size, exact",
    [
        ("torus", sdf.torus(1.0, 0.4), 0.1, None, 2 * np.pi**2 * 0.4**2),
        (
            "cylinder with spherical hole, graded",
            sdf.cylinder(radius=1.0, height=2.0) - sdf.sphere(0.5),
            0.1,
            lambda p: 1.0 + 1.5 * np.maximum(np.linalg.norm(p, axis=1) - 0.5, 0.0),
            2 * np.pi - 4 / 3 * np.pi * 0.125,
        ),
        (
            "smooth union of capsules",
            sdf.union(sdf.capsule((-0.6, 0, 0), (0.6, 0, 0), 0.3), sdf.capsule((0, -0.6, 0), (0, 0.6, 0.3), 0.3), k=0.2),
            0.1,
            None,
            None,
        ),
    ],
)
def test_target_models(name, model, h, size, exact):
    raw = raw_mesh(model, h, size=size)
    better = fepre.improve(raw, model)
    # the polyhedral volume of a coarse mesh is short of the exact one by O(h^2); the stage itself
    # keeps the raw mesh's volume within 2% (asserted inside)
    assert_improved(raw, better, model, h, exact_volume=None)
    if exact is not None:
        assert better.volume == pytest.approx(exact, rel=0.04)


@pytest.mark.slow  # 4 s of the default run on 2 cores
def test_gyroid_infill_walls_of_three_elements():
    """A genuine gyroid infill (sheet 0.15 = 3 h, shell 0.2 = 4 h): about half of its cells lie
    within one h of the boundary, where relaxation alone stalls (mean radius ratio 0.877 before
    the shape rounds, 0.908 measured with them)."""
    part = sdf.infill(sdf.box((1.0, 1.0, 0.5)), sdf.gyroid(1.0, 0.15), 0.2)
    raw = raw_mesh(part, 0.05)
    better = fepre.improve(raw, part)
    assert_improved(raw, better, part, 0.05, mean_rr=0.903)


def test_distmesh_runs_the_stage_by_default():
    ball = sdf.sphere(1.0)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", fepre.ConvergenceWarning)
        mesh = fepre.distmesh(ball, 0.2)
    assert mesh["min_dihedral_angle"].min() >= 20
    assert mesh["radius_ratio"].mean() >= MEAN_RR_TARGET
    assert mesh.field_data["distmesh_slivers_seconds"][0] > 0


def test_fixed_nodes_never_move_and_seed_reproduces(sphere_raw):
    ball = sdf.sphere(1.0)
    points, tets = arrays(sphere_raw)
    fixed = np.zeros(len(points), bool)
    fixed[::7] = True
    new_points, new_tets, info = improve_arrays(points, tets, ball, 0.2, fixed_mask=fixed, seed=3)
    np.testing.assert_array_equal(new_points[fixed], points[fixed])
    assert info["min_dihedral_after"] >= WORST_TARGET
    again_points, again_tets, _ = improve_arrays(points, tets, ball, 0.2, fixed_mask=fixed, seed=3)
    np.testing.assert_array_equal(again_points, new_points)
    np.testing.assert_array_equal(again_tets, new_tets)


@pytest.mark.slow  # 3 s of the default run on 2 cores
def test_improves_a_pytetwild_mesh(tmp_path, monkeypatch):
    pytetwild = pytest.importorskip("pytetwild")
    monkeypatch.chdir(tmp_path)  # fTetWild writes __tracked_surface.stl into the working folder
    ball = sdf.sphere(1.0)
    surface = pv.Sphere(radius=1.0, theta_resolution=24, phi_resolution=24).triangulate().clean()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        mesh = pytetwild.tetrahedralize_pv(surface, edge_length_abs=0.3, quiet=True)
    better = fepre.improve(mesh, ball)
    q = quality.tet_quality(*arrays(better))
    assert q["volume"].min() > 0
    assert q["min_dihedral_angle"].min() >= max(WORST_TARGET, quality.tet_quality(*arrays(mesh))["min_dihedral_angle"].min())
    assert q["volume"].sum() == pytest.approx(4 / 3 * np.pi, rel=0.03)


def test_the_stage_stops_when_a_target_the_model_forbids_stops_improving():
    # a 15 deg wedge: no cell on its edge reaches 25 deg; the rounds stop once neither the worst
    # angle nor the count of cells below the target improves for UNMET_PATIENCE rounds (before,
    # all 40 rounds ran: on organic models a quarter of the meshing time)
    from fepre.distmesh.slivers import DEFAULT_MAXITER, UNMET_PATIENCE

    t = np.tan(np.radians(7.5))
    wedge = sdf.box((2.0, 2.0, 2.0)) & sdf.plane((-t, 0, 1)) & sdf.plane((-t, 0, -1))
    raw = raw_mesh(wedge, 0.15)
    with pytest.warns(fepre.ConvergenceWarning, match="min_dihedral=25"):
        better = fepre.improve(raw, wedge)
    rounds = int(better.field_data["improve_rounds"][0])
    assert UNMET_PATIENCE <= rounds <= DEFAULT_MAXITER // 2
    assert better["min_dihedral_angle"].min() == pytest.approx(15.0, abs=0.5)  # the knife's own angle


# ---------------------------------------------------------------------------------- bad input
def test_unattainable_target_warns_and_returns_the_best_mesh(sphere_raw):
    ball = sdf.sphere(1.0)
    with pytest.warns(fepre.ConvergenceWarning, match="min_dihedral=60"):
        better = fepre.improve(sphere_raw, ball, min_dihedral=60, maxiter=2)
    assert better["volume"].min() > 0
    assert better["min_dihedral_angle"].min() >= WORST_TARGET


@pytest.mark.parametrize("value", [70.6, 90, -1, float("nan")])
def test_impossible_min_dihedral_is_refused(sphere_raw, value):
    with pytest.raises(ValueError, match="min_dihedral"):
        fepre.improve(sphere_raw, sdf.sphere(1.0), min_dihedral=value)


@pytest.mark.parametrize("value", [0, -3, 2.5])
def test_bad_maxiter_is_refused(sphere_raw, value):
    with pytest.raises((ValueError, TypeError), match="maxiter"):
        fepre.improve(sphere_raw, sdf.sphere(1.0), maxiter=value)


def test_model_that_does_not_match_the_mesh(sphere_raw):
    with pytest.raises(ValueError, match="model does not match the mesh"):
        fepre.improve(sphere_raw, sdf.sphere(2.0))


def test_mesh_that_is_not_purely_tetrahedral():
    with pytest.raises(ValueError, match="purely tetrahedral"):
        fepre.improve(pv.ImageData(dimensions=(3, 3, 3)).cast_to_unstructured_grid(), sdf.sphere(1.0))
    with pytest.raises(TypeError, match="UnstructuredGrid"):
        fepre.improve(pv.Sphere(), sdf.sphere(1.0))


def test_broken_arrays_are_refused(sphere_raw):
    ball = sdf.sphere(1.0)
    points, tets = arrays(sphere_raw)
    with pytest.raises(ValueError, match="positively oriented"):
        improve_arrays(points, tets[:, [0, 2, 1, 3]], ball, 0.2)
    with pytest.raises(ValueError, match="must form a solid"):
        improve_arrays(points, np.concatenate([tets, tets[:1]]), ball, 0.2)
    with pytest.raises(ValueError, match="closed manifold boundary"):
        # two cells sharing only an edge: the boundary is pinched along that edge
        p = np.array([[0, 0, 0], [0, 0, 1], [1, 0, 0], [0, 1, 0], [-1, 0, 0], [0, -1, 0]], float)
        improve_arrays(p, np.array([[0, 2, 3, 1], [0, 4, 5, 1]]), ball, 1.0)
    with pytest.raises(ValueError, match="tets must index"):
        improve_arrays(points, tets + len(points), ball, 0.2)
    with pytest.raises(ValueError, match="h must be > 0"):
        improve_arrays(points, tets, ball, 0.0)


def test_cells_that_overlap_after_a_move_refuse_the_run(sphere_raw, monkeypatch):
    # a move that left a face in three cells (cow.obj at (D/100, D/50) once met it in a flip
    # round) is a MeshingError of the stage, which distmesh turns into a skipped stage and a
    # warning, not a ValueError from deep inside
    from fepre.distmesh import slivers
    from fepre.distmesh.tet_topology import NonManifoldCells

    def overlapping(*args, **kwargs):
        raise NonManifoldCells("tets must form a manifold mesh; a face is shared by more than two tetrahedra")

    monkeypatch.setattr(slivers, "flip_round", overlapping)
    points, tets = arrays(sphere_raw)
    with pytest.raises(fepre.MeshingError, match="the quality stage broke the mesh topology: tets must form a manifold"):
        improve_arrays(points, tets, sdf.sphere(1.0), 0.2)
    with pytest.warns(fepre.ConvergenceWarning, match="the quality stage .* failed and was skipped: the quality stage broke"):
        mesh = fepre.distmesh(sdf.sphere(1.0), 0.3)
    assert mesh.volume == pytest.approx(4 / 3 * np.pi, rel=0.05)
