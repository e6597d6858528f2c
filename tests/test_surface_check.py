"""fepre.check_surface against meshes whose answers are known."""

from __future__ import annotations

import math

import numpy as np
import pytest
import pyvista as pv

import fepre
from fepre import sdf


def octahedron(center=(0.0, 0.0, 0.0)):
    points = np.array([[1, 0, 0], [-1, 0, 0], [0, 1, 0], [0, -1, 0], [0, 0, 1], [0, 0, -1]], float) + center
    faces = np.array([[0, 2, 4], [2, 1, 4], [1, 3, 4], [3, 0, 4], [2, 0, 5], [1, 2, 5], [3, 1, 5], [0, 3, 5]])
    return points, faces


def polydata(points, faces):
    return pv.PolyData.from_regular_faces(points, faces)


def test_octahedron_figures_are_exact():
    check = fepre.check_surface(polydata(*octahedron()))
    assert check.watertight and check.manifold and check.oriented
    assert (check.points, check.triangles, check.components) == (6, 8, 1)
    assert check.euler_characteristic == 2 and check.genus == 0
    assert check.area == pytest.approx(8 * math.sqrt(3) / 2)
    assert check.volume == pytest.approx(4 / 3)
    assert check.min_angle == pytest.approx(60.0)
    assert check.degenerate_triangles == 0


def test_flipped_triangle_is_not_oriented_and_inverted_surface_has_negative_volume():
    points, faces = octahedron()
    flipped = faces.copy()
    flipped[0] = flipped[0, ::-1]
    check = fepre.check_surface(polydata(points, flipped))
    assert check.watertight and not check.oriented and check.genus is None
    assert fepre.check_surface(polydata(points, faces[:, ::-1])).volume == pytest.approx(-4 / 3)


def test_open_surface_and_two_components_and_pinched_vertex():
    points, faces = octahedron()
    assert not fepre.check_surface(polydata(points, faces[1:])).watertight
    second_points, second_faces = octahedron(center=(3.0, 0.0, 0.0))
    pair = polydata(np.vstack([points, second_points]), np.vstack([faces, second_faces + 6]))
    check = fepre.check_surface(pair)
    assert check.components == 2 and check.euler_characteristic == 4 and check.manifold
    # two octahedra sharing one vertex: every edge still has two triangles, but the vertex is not manifold
    touching_points, touching_faces = octahedron(center=(2.0, 0.0, 0.0))
    touching_faces = np.where(touching_faces == 1, 0, touching_faces + 6)
    pinched = polydata(np.vstack([points, touching_points]), np.vstack([faces, touching_faces]))
    check = fepre.check_surface(pinched)
    assert check.watertight and not check.manifold


def test_degenerate_triangles_are_counted():
    points = np.array([[0, 0, 0], [1, 0, 0], [2, 0, 0], [0, 1, 0]], float)
    check = fepre.check_surface(polydata(points, np.array([[0, 1, 3], [0, 1, 2], [1, 1, 3]])))
    assert check.degenerate_triangles == 2


def test_model_errors_and_hausdorff_to_a_shifted_copy():
    ball = sdf.sphere(1.0)
    surface = fepre.isosurface(ball, spacing=0.1, method="marching_cubes")
    check = fepre.check_surface(surface, ball)
    assert check.error_unit == pytest.approx(0.1)
    assert 0 < check.mean_sdf_error <= check.max_sdf_error < 0.1
    assert check.hausdorff < 1e-6  # the default reference is flying edges on the same grid
    shifted = surface.translate((0.05, 0.0, 0.0), inplace=False)
    assert fepre.check_surface(surface, reference=shifted).hausdorff == pytest.approx(0.05, rel=0.05)


def test_str_is_a_readable_table():
    text = str(fepre.check_surface(polydata(*octahedron())))
    assert "watertight" in text and "euler characteristic  2" in text and "hausdorff" in text


def test_distance_to_surface_matches_vtk_and_hausdorff_is_sampled_on_big_surfaces():
    import pyvista as pv
    import vtk

    from fepre.surface import check as check_module
    from fepre.surface.distance import distance_to_surface

    ball = pv.Sphere(theta_resolution=24, phi_resolution=24)
    queries = np.random.default_rng(3).normal(size=(500, 3)) * 0.6
    implicit = vtk.vtkImplicitPolyDataDistance()
    implicit.SetInput(ball)
    expected = np.abs([implicit.EvaluateFunction(q) for q in queries])
    got = distance_to_surface(queries, np.asarray(ball.points), np.asarray(ball.regular_faces))
    np.testing.assert_allclose(got, expected, atol=1e-12)
    shifted = ball.translate((0.02, 0.0, 0.0), inplace=False)
    exact = check_module._hausdorff(ball, shifted)
    limit = check_module.HAUSDORFF_VERTICES
    try:
        check_module.HAUSDORFF_VERTICES = 100  # sampled: a lower bound, close on an even surface
        sampled = check_module._hausdorff(ball, shifted)
    finally:
        check_module.HAUSDORFF_VERTICES = limit
    assert exact == pytest.approx(0.02, rel=0.05) and 0.8 * exact <= sampled <= exact


def test_components_thinner_than_the_grid_are_counted_and_the_cli_warns(tmp_path, capsys):
    """An acute wedge's tip, thinner than the grid, is caught by a few nodes here and there:
    extra components that the check reports as thinner than the spacing (corpus part acute-1)."""
    from fepre.cli import main
    from fepre.corpus import parts

    part = {p.name: p for p in parts(0, 4, ["acute"])}["acute-1"]
    check = fepre.check_surface(fepre.isosurface(part.model, method="surface_nets", spacing=0.5 * part.h))
    assert (check.components, check.thin_components) == (4, 3)
    whole = fepre.check_surface(fepre.isosurface(part.model, method="surface_nets", spacing=0.2 * part.h))
    assert whole.components - whole.thin_components == 1  # a tip is thinner than any grid
    # a plate 1.2 spacings thick (its surface thinner) is one thin component; a ball of radius
    # 3 spacings is not
    plate = fepre.check_surface(fepre.isosurface(sdf.box((4.0, 4.0, 0.4)), spacing=1.0 / 3.0))
    assert plate.thin_components == 1
    ball = fepre.check_surface(fepre.isosurface(sdf.sphere(1.0), spacing=1.0 / 3.0))
    assert ball.thin_components == 0
    model_file = tmp_path / "wedge.py"
    model_file.write_text(
        "from fepre.corpus import parts\n"
        "model = {p.name: p for p in parts(0, 4, ['acute'])}['acute-1'].model\n"
    )
    assert main(["surface", str(model_file), "-o", str(tmp_path / "wedge.stl"), "--method", "surface_nets",
                 "--spacing", str(0.5 * part.h), "--quiet"]) == 0
    err = capsys.readouterr().err
    assert "warning: 3 of the 4 components are thinner than the spacing" in err
