"""fepre.compare: every figure matches an independent computation (VTK's own filters)."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest
import pyvista as pv

import fepre
from fepre import MeshingError, sdf
from fepre.compare import Comparison
from fepre.mesh_metrics import hausdorff, mesh_metrics
from fepre.references import REFERENCES, _positive_tets

SPHERE_VOLUME = 4.0 * math.pi / 3.0
H = 0.5


@pytest.fixture(scope="module")
def sphere_comparison() -> Comparison:
    return fepre.compare(sdf.sphere(1.0), H, references=("pytetwild",), exact_volume=SPHERE_VOLUME, surface_spacing=0.125)


def _min_dihedral(points: np.ndarray, tets: np.ndarray) -> np.ndarray:
    """Worst dihedral angle per tet: at each edge, the angle between the other two vertices
    projected onto the plane normal to the edge (not fepre's face-normal formula)."""
    worst = np.full(len(tets), 180.0)
    for i, j in ((0, 1), (0, 2), (0, 3), (1, 2), (1, 3), (2, 3)):
        k, l = (m for m in range(4) if m not in (i, j))
        origin = points[tets[:, i]]
        edge = points[tets[:, j]] - origin
        edge /= np.linalg.norm(edge, axis=1, keepdims=True)
        a = points[tets[:, k]] - origin
        b = points[tets[:, l]] - origin
        a -= np.einsum("ij,ij->i", a, edge)[:, None] * edge
        b -= np.einsum("ij,ij->i", b, edge)[:, None] * edge
        cosine = np.einsum("ij,ij->i", a, b) / (np.linalg.norm(a, axis=1) * np.linalg.norm(b, axis=1))
        worst = np.minimum(worst, np.degrees(np.arccos(np.clip(cosine, -1, 1))))
    return worst


def _vtk_figures(mesh: pv.UnstructuredGrid, model) -> dict[str, float]:
    """The same figures computed independently: VTK filters, Verdict, and plain geometry."""
    volumes = mesh.compute_cell_sizes(length=False, area=False, vertex_count=False)["Volume"]
    # (Verdict's tet "min_angle" is not always the smallest dihedral, so it is not used here)
    min_angle = _min_dihedral(np.asarray(mesh.points), mesh.cells_dict[pv.CellType.TETRA])
    vtk_radius_ratio = mesh.cell_quality("radius_ratio")["radius_ratio"]  # R / (3 r), >= 1
    surface = mesh.extract_surface(pass_pointid=True, algorithm="dataset_surface")
    boundary = np.unique(np.asarray(surface.point_data["vtkOriginalPointIds"]))
    return {
        "volume": float(volumes.sum()),
        "min_volume": float(volumes.min()),
        "min_dihedral": float(min_angle.min()),
        "below_15": int(np.count_nonzero(min_angle < 15.0)),
        "mean_radius_ratio": float(np.mean(1.0 / vtk_radius_ratio)),
        "boundary_sdf_max": float(np.abs(model(mesh.points[boundary])).max()),
        "boundary_nodes": int(boundary.size),
    }


@pytest.mark.parametrize("name", ["fepre", "pytetwild"])
def test_figures_match_an_independent_computation(sphere_comparison, name):
    result = sphere_comparison[name]
    mesh, metrics = result.mesh, result.metrics
    vtk = _vtk_figures(mesh, sdf.sphere(1.0))
    assert metrics["elements"] == mesh.n_cells > 100
    assert metrics["nodes"] == mesh.n_points
    assert vtk["min_volume"] > 0, "cells must be oriented the VTK way (positive volume)"
    assert metrics["inverted"] == 0
    assert metrics["volume"] == pytest.approx(vtk["volume"], rel=1e-10)
    assert metrics["volume_error"] == pytest.approx((vtk["volume"] - SPHERE_VOLUME) / SPHERE_VOLUME, abs=1e-12)
    assert abs(metrics["volume_error"]) < 0.12  # inscribed chords at h = 0.5 lose several percent
    assert metrics["boundary_nodes"] == vtk["boundary_nodes"]
    assert metrics["boundary_sdf_max"] == pytest.approx(vtk["boundary_sdf_max"], rel=1e-9)
    assert metrics["min_dihedral_angle_min"] == pytest.approx(vtk["min_dihedral"], abs=1e-7)
    assert metrics["below_15"] == vtk["below_15"]
    assert metrics["radius_ratio_mean"] == pytest.approx(vtk["mean_radius_ratio"], rel=1e-6)
    assert metrics["seconds"] > 0
    # the boundary's farthest point from the sphere is a chord's sag, of order h^2 / (8 R) per edge
    assert vtk["boundary_sdf_max"] - 0.01 <= metrics["hausdorff"] < H**2 / 2


def test_the_references_mesh_the_same_fine_surface(sphere_comparison):
    surface = sphere_comparison.surface
    radii = np.linalg.norm(surface.points, axis=1)
    assert np.abs(radii - 1).max() < 0.01  # flying edges at spacing 0.125
    assert sphere_comparison.surface_check.watertight
    assert sphere_comparison.volume_source == "exact"
    assert sphere_comparison.names == ["fepre", "pytetwild"]


def test_table_and_dict_carry_the_figures(sphere_comparison):
    table = sphere_comparison.table()
    fepre_cells = sphere_comparison["fepre"].metrics["elements"]
    tetwild_cells = sphere_comparison["pytetwild"].metrics["elements"]
    header = table.splitlines()[0].split()
    assert header == ["fepre", "pytetwild"]
    row = next(line for line in table.splitlines() if line.startswith("tetrahedra"))
    assert row.split()[1:] == [str(fepre_cells), str(tetwild_cells)]
    data = json.loads(json.dumps(sphere_comparison.to_dict()))
    assert data["meshes"]["pytetwild"]["elements"] == tetwild_cells
    assert data["h"] == H and data["settings"]["surface_spacing"] == 0.125
    assert "pytetwild" in data["settings"]["versions"]


def test_hausdorff_of_concentric_spheres_is_the_radius_gap():
    inner = pv.Sphere(radius=1.0, theta_resolution=60, phi_resolution=60)
    outer = pv.Sphere(radius=1.1, theta_resolution=60, phi_resolution=60)
    to_outer, to_inner = hausdorff(inner, outer)
    # vertices lie on the spheres; chords and centroids sag inward by at most r (1 - cos(pi/60)) ~ 1.5e-3
    assert to_outer == pytest.approx(0.1, abs=1.6e-3)
    assert to_inner == pytest.approx(0.1, abs=1.6e-3)
    shifted = inner.translate((0.05, 0, 0), inplace=False)
    assert max(hausdorff(inner, shifted)) == pytest.approx(0.05, abs=2e-3)


def test_metrics_of_one_known_tetrahedron():
    p = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]], float)
    grid = pv.UnstructuredGrid({pv.CellType.TETRA: np.array([[0, 1, 2, 3]])}, p)
    metrics = mesh_metrics(grid, sdf.sphere(2.0), volume=1 / 3)
    assert metrics["volume"] == pytest.approx(1 / 6)
    assert metrics["volume_error"] == pytest.approx(-0.5)
    assert metrics["boundary_nodes"] == 4
    assert metrics["boundary_sdf_max"] == pytest.approx(2.0)  # the origin is 2 inside the sphere
    assert metrics["boundary_sdf_mean"] == pytest.approx((2.0 + 3 * 1.0) / 4)
    assert metrics["max_dihedral_angle_max"] == pytest.approx(90.0)
    assert metrics["min_dihedral_angle_min"] == pytest.approx(math.degrees(math.acos(1 / math.sqrt(3))))


def test_a_failing_reference_is_reported_not_fatal(monkeypatch):
    def broken(surface, h, seed=0):
        raise MeshingError("no tetrahedra from this surface")

    monkeypatch.setitem(REFERENCES, "gmsh", ("gmsh", broken))
    model = sdf.sphere(1.0)
    cube = pv.ImageData(dimensions=(5, 5, 5), spacing=(0.35,) * 3, origin=(-0.7,) * 3).triangulate()
    mesh = _positive_tets(np.asarray(cube.points), cube.cells_dict[pv.CellType.TETRA])  # any valid tet mesh
    result = fepre.compare(model, 0.5, mesh=mesh, seconds=1.0, references=("gmsh",), surface_spacing=0.25)
    assert result["gmsh"].mesh is None and "no tetrahedra" in result["gmsh"].error
    assert "gmsh failed: no tetrahedra" in result.table()
    assert result.to_dict()["failed"] == {"gmsh": "no tetrahedra from this surface"}
    assert result["fepre"].metrics["seconds"] == 1.0
    assert result.volume_source.startswith("enclosed by the flying-edges surface")


def test_a_triangle_mesh_model_gives_the_references_its_own_triangles(monkeypatch):
    # `fepre compare torus.STL` gave pytetwild a surface resampled at h/4 (80.6k cells in 35 s,
    # against 73.7k in 14 s from the file's own triangles), and the volume it was measured
    # against was that surface's, not the file's
    seen = []

    def reference(surface, h, seed=0):
        seen.append(surface)
        raise MeshingError("not run here")

    monkeypatch.setitem(REFERENCES, "gmsh", ("gmsh", reference))
    ring = pv.ParametricTorus(ringradius=1.0, crosssectionradius=0.3).triangulate().clean()
    model = sdf.mesh(ring)
    cube = pv.ImageData(dimensions=(5, 5, 5), spacing=(0.35,) * 3, origin=(-0.7,) * 3).triangulate()
    mesh = _positive_tets(np.asarray(cube.points), cube.cells_dict[pv.CellType.TETRA])
    result = fepre.compare(model, 0.2, mesh=mesh, seconds=1.0, references=("gmsh",))
    [surface] = seen
    assert surface.n_cells == len(model.faces) and np.array_equal(surface.regular_faces, model.faces)
    assert result.volume_reference == pytest.approx(model.volume, rel=1e-12)
    assert result.volume_source == "enclosed by the model's own triangles"
    assert result.table().endswith("Hausdorff against the model's own triangles")
    # a spacing asked for: the model is resampled, as for any model
    fepre.compare(model, 0.2, mesh=mesh, seconds=1.0, references=("gmsh",), surface_spacing=0.05)
    assert seen[1].n_cells != len(model.faces)


@pytest.mark.parametrize(
    "kwargs, error, words",
    [
        ({"h": 0.0}, ValueError, "h must be > 0"),
        ({"h": 0.5, "references": ("netgen",)}, ValueError, "references must name"),
        ({"h": 0.5, "mesh": pv.Sphere()}, TypeError, "mesh must be a pyvista.UnstructuredGrid"),
        ({"h": 0.5, "exact_volume": -1.0}, ValueError, "exact_volume must be > 0"),
        ({"h": 0.5, "surface_spacing": "fine"}, TypeError, "surface_spacing"),
    ],
)
def test_bad_arguments_name_the_parameter(kwargs, error, words):
    with pytest.raises(error, match=words):
        fepre.compare(sdf.sphere(1.0), **kwargs)


def test_model_must_be_an_sdf():
    with pytest.raises(TypeError, match="model must be an fepre SDF"):
        fepre.compare(lambda p: p, 0.5)


def test_gmsh_reference_meshes_a_sharp_part_remeshed_or_with_its_surface_kept():
    from fepre.demo import l_bracket
    from fepre.references import gmsh_mesh, reference_surface

    surface = reference_surface(l_bracket()[0], 0.1)
    mesh = gmsh_mesh(surface, 0.4)  # gmsh cannot remesh this sampled surface's edges: it keeps it
    note = mesh.field_data.get("reference_note")
    assert note is None or str(note[0]).startswith("surface kept as sampled")
    volumes = mesh.compute_cell_sizes(length=False, area=False, vertex_count=False)["Volume"]
    assert volumes.min() > 0
    assert volumes.sum() == pytest.approx(surface.volume, rel=0.01 if note is not None else 0.05)
    assert mesh.field_data["reference_seconds"][0] > 0


def test_a_reference_surface_without_sharp_edges_on_request():
    # the CAD sizing bench gives gmsh flying edges where it refuses a dual-contoured surface
    from fepre.references import reference_surface

    cube = sdf.box(2.0)
    sharp, smooth = reference_surface(cube, 0.25), reference_surface(cube, 0.25, sharp=False)
    assert str(sharp.field_data["surface_method"][0]) == "dual_contouring"
    assert str(smooth.field_data["surface_method"][0]) == "flying_edges"
    assert sharp.volume == pytest.approx(8.0, rel=1e-6) and smooth.volume < 8.0  # the edges chamfered


def test_gmsh_reference_that_does_not_finish_is_stopped_and_reported():
    from fepre.references import gmsh_mesh, reference_surface

    surface = reference_surface(sdf.sphere(1.0), 0.1)
    with pytest.raises(fepre.MeshingError, match="did not finish .* within 0.001 s"):
        gmsh_mesh(surface, 0.2, timeout=0.001)


@pytest.mark.slow  # 14 s of the default run on 2 cores
def test_a_script_without_a_main_guard_runs_once_and_writes_nothing_else(tmp_path):
    # The README tour run as a plain script printed its lines twice and ended in a
    # multiprocessing RuntimeError ("gmsh aborted"): the gmsh child imported the user's __main__.
    # pytetwild left a 0.5 MB __tracked_surface.stl in the working folder.
    import subprocess
    import sys

    script = tmp_path / "tour.py"
    script.write_text(
        "import fepre\nfrom fepre import sdf\nprint('tour line')\n"
        "part = sdf.box((1, 1, 1))\n"
        "result = fepre.compare(part, h=0.5, references=('pytetwild', 'gmsh'), progress=False)\n"
        "print('failed:', [r.name for r in result.results if r.error])\n"
    )
    done = subprocess.run([sys.executable, str(script)], cwd=tmp_path, capture_output=True, text=True, timeout=300)
    assert done.returncode == 0, done.stderr[-2000:]
    assert done.stdout.splitlines() == ["tour line", "failed: []"]
    assert "Traceback" not in done.stderr
    assert [p.name for p in tmp_path.iterdir()] == ["tour.py"]


@pytest.mark.slow  # 4 s of the default run on 2 cores
def test_report_says_how_each_mesher_ran_and_its_mean_edge_length(tmp_path):
    # The gmsh reference ran without its optimisers and the report did not say how any
    # reference was made; gmsh's edges come out longer than asked, so h alone misleads.
    from fepre.mesh_metrics import mean_edge_length

    model = sdf.box(1.0)
    result = fepre.compare(model, h=0.25, references=("gmsh",), progress=False)
    table = result.table()
    assert "OptimizeNetgen = 1" in table and "Optimize = 1" in table
    assert "fepre: fepre.distmesh at h = 0.25 with its quality stage" in table
    for r in result.results:
        cells = np.asarray(r.mesh.cells_dict[pv.CellType.TETRA])
        pairs = {tuple(sorted(e)) for c in cells.tolist() for e in
                 [(c[0], c[1]), (c[0], c[2]), (c[0], c[3]), (c[1], c[2]), (c[1], c[3]), (c[2], c[3])]}
        points = np.asarray(r.mesh.points)
        expected = np.mean([np.linalg.norm(points[a] - points[b]) for a, b in pairs])
        assert r.metrics["mean_edge_length"] == pytest.approx(expected, rel=1e-12)
        assert mean_edge_length(points, cells) == pytest.approx(expected, rel=1e-12)
        assert r.metrics["ms_per_1000_cells"] == pytest.approx(1e6 * r.seconds / r.mesh.n_cells)
    assert "mean edge length" in table and "time per 1000 cells [ms]" in table
    html = result.to_html(tmp_path / "r.html").read_text()
    assert "How each mesher ran" in html and "OptimizeNetgen = 1" in html


def test_gmsh_reference_runs_with_its_optimisers(tmp_path):
    import gmsh

    from fepre.references import GMSH_OPTIONS, _gmsh_tetrahedra, reference_surface

    path = tmp_path / "cube.stl"
    reference_surface(sdf.box(1.0), 0.1).save(path)
    gmsh.initialize(interruptible=False)
    try:
        gmsh.option.setNumber("General.Terminal", 0)
        points, tets = _gmsh_tetrahedra(str(path), 0.3, 0, remesh=True)
        assert {name: gmsh.option.getNumber(name) for name in GMSH_OPTIONS} == GMSH_OPTIONS
    finally:
        gmsh.finalize()
    assert tets.shape[1] == 4 and len(tets) > 50
