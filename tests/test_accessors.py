"""The PyVista plugin: `dataset.fepre` accessors, the `.inp` writer, fepre.plot and plot_model."""

from __future__ import annotations

import subprocess
import sys

import meshio
import numpy as np
import pytest
import pyvista as pv
from PIL import Image

import fepre
from fepre import sdf
from fepre.quality import tet_quality

BALL = sdf.sphere(1.0)


@pytest.fixture(scope="module")
def mesh():
    """A ball by plain Delaunay (slivers included): surface points plus an interior lattice."""
    from fepre.references import _positive_tets

    shell = pv.Sphere(radius=1.0, theta_resolution=16, phi_resolution=12).points
    t = np.arange(-0.6, 0.61, 0.3)
    lattice = np.stack(np.meshgrid(t, t, t), axis=-1).reshape(-1, 3)
    points = np.concatenate([shell, lattice[np.linalg.norm(lattice, axis=1) < 0.75]])
    tets = pv.PolyData(points).delaunay_3d().cells_dict[pv.CellType.TETRA]
    return _positive_tets(points.astype(np.float64), tets)


def _non_blank(path) -> float:
    image = np.asarray(Image.open(path).convert("RGB"))
    return float(np.any(image < 235, axis=2).mean())


def test_quality_and_summary_accessors(mesh):
    bare = pv.UnstructuredGrid({pv.CellType.TETRA: mesh.cells_dict[pv.CellType.TETRA]}, mesh.points)
    with_quality = bare.fepre.quality()
    expected = tet_quality(mesh.points, mesh.cells_dict[pv.CellType.TETRA])
    for name, values in expected.items():
        np.testing.assert_allclose(with_quality.cell_data[name], values, rtol=1e-12)
    assert "radius_ratio" not in bare.cell_data  # a copy unless inplace
    summary = bare.fepre.summary()
    assert summary.cells == mesh.n_cells
    assert summary["min_dihedral_angle"]["min"] == pytest.approx(expected["min_dihedral_angle"].min())
    assert bare.fepre is bare.fepre  # PyVista caches the accessor per dataset


def test_image_isosurface_and_surface_check_accessors():
    grid = fepre.sample(BALL, spacing=0.1)
    for method in ("flying_edges", "marching_cubes"):
        surface = grid.fepre.isosurface(method=method)
        direct = fepre.isosurface(grid, method=method)
        assert surface.n_points == direct.n_points and surface.n_cells == direct.n_cells
        check = surface.fepre.check(BALL)
        assert check.watertight and check.euler_characteristic == 2
        assert check.volume == pytest.approx(4 * np.pi / 3, rel=0.01)


def test_save_inp_goes_through_fepre_export(mesh, tmp_path):
    path = tmp_path / "ball.inp"
    mesh.save(path)
    text = path.read_text()
    assert text.startswith("*HEADING") and "C3D4" in text
    back = meshio.read(path)
    assert len(back.points) == mesh.n_points and len(back.cells[0].data) == mesh.n_cells
    # keyword options reach the writer
    mesh.save(tmp_path / "ball2.inp", order=2)
    assert meshio.read(tmp_path / "ball2.inp").cells[0].type == "tetra10"


def test_export_and_improve_accessors(mesh, tmp_path):
    written = mesh.fepre.export(tmp_path / "ball.msh", boundaries={"shell": BALL})
    assert written.n_points == mesh.n_points
    assert "shell" in meshio.read(tmp_path / "ball.msh").field_data
    improved = mesh.fepre.improve(BALL)
    quality = tet_quality(improved.points, improved.cells_dict[pv.CellType.TETRA])
    assert quality["volume"].min() > 0
    assert quality["min_dihedral_angle"].min() >= tet_quality(mesh.points, mesh.cells_dict[pv.CellType.TETRA])["min_dihedral_angle"].min() - 1e-9


@pytest.mark.slow  # 3 s of the default run on 2 cores
def test_plot_quality_plot_and_plot_model_screenshots(mesh, tmp_path):
    assert mesh.fepre.plot_quality("radius_ratio", off_screen=True, screenshot=tmp_path / "rr.png") == tmp_path / "rr.png"
    assert _non_blank(tmp_path / "rr.png") > 0.05
    fepre.plot(mesh, clip=False, off_screen=True, screenshot=tmp_path / "whole.png")
    assert _non_blank(tmp_path / "whole.png") > 0.05
    fepre.plot_model(sdf.torus(1.0, 0.3), off_screen=True, screenshot=tmp_path / "torus.png")
    assert _non_blank(tmp_path / "torus.png") > 0.05
    with pytest.raises(ValueError, match="metric must be one of"):
        fepre.plot(mesh, metric="skewness", off_screen=True, screenshot=tmp_path / "x.png")
    with pytest.raises(TypeError, match="UnstructuredGrid"):
        fepre.plot(pv.Sphere(), off_screen=True, screenshot=tmp_path / "x.png")


def test_import_fepre_registers_the_plugin_without_importing_pyvista():
    code = (
        "import sys, fepre\n"
        "assert 'pyvista' not in sys.modules, 'import fepre loaded pyvista'\n"
        "import pyvista as pv\n"
        "assert type(pv.UnstructuredGrid().fepre).__name__ == 'UnstructuredGridAccessor'\n"
        "assert type(pv.ImageData().fepre).__name__ == 'ImageDataAccessor'\n"
        "assert type(pv.PolyData().fepre).__name__ == 'PolyDataAccessor'\n"
        "assert any(w.extension == '.inp' for w in pv.registered_writers())\n"
    )
    result = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True)
    assert result.returncode == 0, result.stderr


@pytest.mark.slow
def test_plot_accepts_a_vtu_mixing_boundary_triangles_with_tetrahedra(tmp_path):
    # fepre's VTU holds tetrahedra only; files from other tools often add the boundary triangles.
    import pyvista as pv

    mesh = fepre.distmesh(sdf.sphere(1.0), 0.4)
    path = tmp_path / "ball.vtu"
    faces = fepre.export.tag_boundaries(mesh).cast_to_unstructured_grid()
    pv.merge([mesh, faces], merge_points=True).save(path)
    mixed = pv.read(path)
    assert {int(t) for t in set(mixed.celltypes.tolist())} == {5, 10}  # triangles and tetrahedra
    shot = fepre.plot(mixed, screenshot=tmp_path / "ball.png", off_screen=True)
    assert shot is not None and (tmp_path / "ball.png").stat().st_size > 5000
