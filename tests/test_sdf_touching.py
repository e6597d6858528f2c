"""Solids that touch: shared faces are not part of the surface, on grids whose nodes lie on them.

A flange modelled as ``disk | hub`` with the hub standing on the disk gave, at spacing 1.0, a
surface with an internal double wall: 2 components and genus 8 for 1 and 7 (issue 12)."""

from __future__ import annotations

import math

import numpy as np
import pytest

import fepre
from fepre import sdf
from fepre.sdf.touching import TOUCH_TOLERANCE

METHODS = ["flying_edges", "marching_cubes", "marching_tetrahedra", "surface_nets", "dual_contouring"]


def flange():
    disk = sdf.cylinder(radius=5.0, height=1.0, center=(0, 0, 0.5))
    hub = sdf.cylinder(radius=2.5, height=3.0, center=(0, 0, 2.5))  # stands on the disk at z = 1
    bolts = sdf.polar_pattern(sdf.cylinder(radius=0.4, height=3.0, center=(3.8, 0, 0.5)), 4)
    part = (disk | hub) - sdf.cylinder(radius=1.2, height=10.0) - bolts
    volume = math.pi * (25 * 1 + 6.25 * 3 - 1.44 * 4) - 4 * math.pi * 0.16
    return part, volume, 1 + 4  # genus: the bore and four bolt holes


def t_section():
    flange_part = sdf.extrude(sdf.polygon([(-3, 2), (3, 2), (3, 3), (-3, 3)]), height=4.0)
    web = sdf.extrude(sdf.polygon([(-0.5, -2), (0.5, -2), (0.5, 2), (-0.5, 2)]), height=4.0)  # touches at y = 2
    return flange_part | web, (6 * 1 + 1 * 4) * 4.0, 0


def pocket():
    body = sdf.box((4.0, 4.0, 2.0), center=(0, 0, 1.0))
    tool = sdf.box((2.0, 2.0, 1.0), center=(0, 0, 1.5))  # its top is flush with the body's top, z = 2
    return body - tool, 32.0 - 4.0, 0


PARTS = {"flange": (flange, 0.1), "t_section": (t_section, 0.25), "pocket": (pocket, 0.25)}


@pytest.mark.parametrize("method", METHODS)
@pytest.mark.parametrize("name", sorted(PARTS))
def test_touching_solids_give_one_closed_surface_on_aligned_grids(name, method):
    make, spacing = PARTS[name]
    part, volume, genus = make()
    surface = fepre.isosurface(fepre.sample(part, spacing=spacing), method=method)
    check = fepre.check_surface(surface, part)
    assert (check.components, check.genus) == (1, genus)
    assert check.watertight and check.manifold
    assert abs(check.volume - volume) <= 0.5 * spacing * check.area  # edges chamfered by up to half a cell


def test_shared_faces_are_inside_a_union_and_outside_a_difference_on_the_grid():
    spacing = 0.25
    t_part, _, _ = t_section()
    image = fepre.sample(t_part, spacing=spacing)
    points, values = np.asarray(image.points), np.asarray(image["sdf"])
    tolerance = TOUCH_TOLERANCE * t_part.length_scale
    shared = (np.abs(points[:, 1] - 2.0) < 1e-9) & (np.abs(points[:, 0]) < 0.5 - 1e-9) & (np.abs(points[:, 2]) < 2 - 1e-9)
    assert shared.sum() > 20 and np.all(values[shared] == np.float32(-tolerance))
    outer = (np.abs(points[:, 1] - 2.0) < 1e-9) & (np.abs(points[:, 0]) > 0.5 + 1e-9) & (np.abs(points[:, 0]) < 3 - 1e-9)
    outer &= np.abs(points[:, 2]) < 2 - 1e-9  # the flange's underside: real boundary, left at 0
    assert outer.sum() > 20 and np.abs(values[outer]).max() < 1e-6  # float32 rounding of the polygon
    assert np.all(values[outer] != np.float32(-tolerance))
    p_part, _, _ = pocket()
    image = fepre.sample(p_part, spacing=spacing)
    points, values = np.asarray(image.points), np.asarray(image["sdf"])
    opening = (np.abs(points[:, 2] - 2.0) < 1e-9) & (np.abs(points[:, :2]) < 1 - 1e-9).all(axis=1)
    assert opening.sum() > 10 and np.all(values[opening] > 0)


def test_point_evaluation_is_unchanged():
    # Only grid sampling settles shared faces (a point list pays nothing for it).
    part, _, _ = t_section()
    assert float(part([0.0, 2.0, 0.0])) == 0.0


@pytest.mark.parametrize("method", METHODS)
def test_surfaces_on_aligned_grids_have_no_coincident_vertices_or_degenerate_triangles(method):
    # Grid nodes on the faces gave coincident vertices and zero-area triangles (2,568 on the
    # flange STL, min angle 0); the surface is now welded where nodes lie on the level.
    part, _, genus = flange()
    surface = fepre.isosurface(fepre.sample(part, spacing=0.1), method=method)
    points = np.asarray(surface.points)
    assert len(np.unique(points, axis=0)) == len(points)
    check = fepre.check_surface(surface, part)
    assert check.degenerate_triangles == 0 and check.min_angle > 0.0
    assert (check.components, check.genus, check.watertight, check.manifold) == (1, genus, True, True)


@pytest.mark.parametrize("method", ["flying_edges", "marching_cubes", "marching_tetrahedra", "surface_nets"])
@pytest.mark.parametrize("chunks", [None, 8])
def test_nodes_a_rounding_error_off_the_level_are_welded(method, chunks):
    # A label image's smoothed value at a node came out 1e-9 off its level: the crossings on the
    # node's edges landed 6e-7 spacings apart, not on one point, and `fepre surface labels.vti
    # --level 0.5` wrote 222 zero-area triangles. A box whose faces lie 6e-8 outside grid planes
    # does the same; its vertices there are welded now, as for a node exactly on the level.
    # (Dual contouring is left out: its own merging of cell vertices leaves this box open, as
    # before; it is named in the design's open items.)
    box = sdf.box((1 + 1.2e-7, 1.25 + 1.2e-7, 0.75 + 1.2e-7))
    surface = fepre.isosurface(box, method=method, spacing=0.125, bounds=((-1, -1, -1), (1, 1, 1)), chunks=chunks)
    check = fepre.check_surface(surface, box)
    assert check.degenerate_triangles == 0
    assert (check.components, check.genus, check.watertight, check.manifold) == (1, 0, True, True)
    if method != "marching_tetrahedra":  # it cuts the box's edges and corners by its own diagonals
        assert check.volume == pytest.approx(0.9375, rel=1e-6)


def test_check_surface_counts_topology_as_a_reader_of_the_file_does(tmp_path):
    # Raw marching cubes output on an aligned grid keeps coincident vertices apart by their ids;
    # an STL reader merges them. check_surface now counts as the reader does.
    import pyvista as pv

    from fepre.surface.marching_cubes import marching_cubes
    from fepre.surface.extract import triangle_polydata

    part, _, _ = flange()
    grid = fepre.sample(part, spacing=0.1)
    values = np.asarray(grid["sdf"]).reshape(tuple(reversed(grid.dimensions)))
    points, triangles = marching_cubes(values, 0.0, np.asarray(grid.origin), np.asarray(grid.spacing), 1)
    raw = triangle_polydata(points, triangles)
    assert len(np.unique(np.asarray(raw.points), axis=0)) < raw.n_points  # coincident vertices
    raw.save(tmp_path / "raw.stl")
    read = pv.read(tmp_path / "raw.stl")
    as_read = fepre.check_surface(read, merge_coincident=False)
    merged = fepre.check_surface(raw)
    # (point counts differ by the STL's float32 rounding, which merges a few more)
    topology = lambda c: (c.components, c.genus, c.watertight, c.manifold)  # noqa: E731
    assert topology(merged) == topology(as_read) == (1, 5.0, True, True)
    assert abs(merged.points - as_read.points) <= 1e-3 * as_read.points
    assert fepre.check_surface(raw, merge_coincident=False).points == raw.n_points


def test_a_profile_drawn_from_the_axis_revolves_into_one_solid():
    # revolve(polygon([(0, 0), (10, 0), ..., (0, 120)])) was -0 along the whole axis: 25-34
    # surface components and zero-area faces along it. The profile is now revolved with its
    # mirror image, and grid nodes on the axis are inside.
    shaft = sdf.revolve(sdf.polygon([(0, 0), (10, 0), (10, 40), (6, 40), (6, 120), (0, 120)]))
    exact = math.pi * (100 * 40 + 36 * 80)
    grid = fepre.sample(shaft, spacing=1.0)
    points, values = np.asarray(grid.points), np.asarray(grid["sdf"])
    axis = (np.abs(points[:, 0]) < 1e-9) & (np.abs(points[:, 1]) < 1e-9) & (points[:, 2] > 0.5) & (points[:, 2] < 119.5)
    assert axis.sum() == 119 and np.all(values[axis] < 0)
    for method in METHODS:
        check = fepre.check_surface(fepre.isosurface(grid, method=method, model=shaft), shaft)
        assert check.components == 1, method
        # dual contouring had 6 non-manifold edges on the end face at z = 0: the polygon's
        # gradient at grid nodes a few ulps off its edge pointed anywhere
        assert (check.genus, check.watertight, check.manifold, check.degenerate_triangles) == (0, True, True, 0), method
        assert abs(check.volume - exact) <= 0.5 * 1.0 * check.area
    assert sdf.revolve(sdf.circle(0.5), offset=2.0).exact  # off the axis: unchanged


def _section_boundary_distance(profile_vertices, query_rz, samples_per_unit=200):
    """Distance from (r, z) points to the boundary of the revolved section, by brute force: the
    profile's edges sampled densely, without the edge on the axis (inside the solid)."""
    from scipy.spatial import cKDTree

    vertices = np.asarray(profile_vertices, float)
    pieces = []
    for a, b in zip(vertices, np.roll(vertices, -1, axis=0)):
        if a[0] == 0 and b[0] == 0:
            continue
        count = int(np.ceil(np.linalg.norm(b - a) * samples_per_unit)) + 1
        pieces.append(a + np.linspace(0, 1, count)[:, None] * (b - a))
    boundary = np.concatenate(pieces)
    return cKDTree(boundary).query(query_rz)[0]


@pytest.mark.parametrize("name", ["revolve", "revolve_offset"])
def test_a_profile_from_the_axis_revolves_with_the_exact_distance(name):
    """The union with the mirror image was about -r near the axis (a point 0.5 from the axis of
    a radius-10 shaft read -0.5): DistMesh pulled nodes onto the axis. The section's true
    boundary gives the distance itself."""
    profile = [(0, 0), (10, 0), (10, 40), (6, 40), (6, 80), (0, 80)]
    if name == "revolve":
        shaft = sdf.revolve(sdf.polygon(profile))
    else:  # the same profile drawn 3 to the left and shifted back by the offset
        shaft = sdf.revolve(sdf.polygon([(x - 3, z) for x, z in profile]), offset=3.0)
    assert shaft.exact
    rng = np.random.default_rng(7)
    points = rng.uniform((-14, -14, -5), (14, 14, 85), size=(4000, 3))
    rz = np.column_stack([np.hypot(points[:, 0], points[:, 1]), points[:, 2]])
    expected = _section_boundary_distance(profile, rz)
    values = shaft(points)
    assert np.abs(np.abs(values) - expected).max() < 0.01  # the sampling of the brute force
    inside = ((rz[:, 0] < 10) & (rz[:, 1] > 0) & (rz[:, 1] < 40)) | ((rz[:, 0] < 6) & (rz[:, 1] >= 40) & (rz[:, 1] < 80))
    np.testing.assert_array_equal(values < 0, inside)
    assert float(shaft([0.5, 0.0, 20.0])) == pytest.approx(-9.5)


def test_a_profile_across_the_axis_revolves_its_union_with_its_mirror_image():
    """An off-centre rectangle from x = -3 to 5: the solid is the radius-5 cylinder."""
    crossing = sdf.revolve(sdf.polygon([(-3, 0), (5, 0), (5, 10), (-3, 10)]))
    points = np.array([[0, 0, 5], [4, 0, 5], [6, 0, 5], [0, 0, 12], [3, 0, 11]], float)
    np.testing.assert_allclose(crossing(points), [-5, -1, 1, 2, np.hypot(0, 1)], atol=1e-12)
    assert crossing.bounds == ((-5.0, -5.0, 0.0), (5.0, 5.0, 10.0))
