"""Named boundary sets hold exactly the faces on their surface (issue 33), with their areas.

Each part here has a set whose exact area is known; the set's area (``boundary_areas`` of the
grid fepre.export returns, quadratic faces over their curved shape for ``order=2``) must match it
to 0.1%. Before the fix a face joined the set whose function was nearest zero at its centroid,
within a quarter of h: a floor took the first row of a shallow chamfer's or a fillet's faces.
"""

from __future__ import annotations

import re
import warnings

import numpy as np
import pytest
import pyvista as pv

import fepre
from fepre import sdf
from fepre.export import BoundaryWarning, tag_boundaries

from test_export_meshes import kuhn_box

# The enclosure: 14 x 10 x 5, rounded vertical edges (R 2), its bottom edges chamfered 30 degrees
# over 2.5 (so the flat floor is the rectangle 9 x 5), hollowed from z = 2.5 with 1.5 walls.
SIZE, RADIUS, CHAMFER, SLOPE = (14.0, 10.0, 5.0), 2.0, 2.5, np.radians(30.0)
FLOOR = sdf.plane((0, 0, -1), (0, 0, 0))
FLOOR_AREA = (SIZE[0] - 2 * CHAMFER) * (SIZE[1] - 2 * CHAMFER)


def enclosure() -> sdf.SDF:
    a, b, c = SIZE
    part = sdf.extrude(sdf.rounded_rectangle((a, b), RADIUS), c).translate((0, 0, c / 2))
    for sign in (1, -1):
        part = part & sdf.plane((sign * np.sin(SLOPE), 0, -np.cos(SLOPE)), (sign * (a / 2 - CHAMFER), 0, 0))
        part = part & sdf.plane((0, sign * np.sin(SLOPE), -np.cos(SLOPE)), (0, sign * (b / 2 - CHAMFER), 0))
    cavity = sdf.extrude(sdf.rounded_rectangle((a - 3.0, b - 3.0), RADIUS - 1.5), c).translate((0, 0, c / 2 + 2.5))
    return part - cavity


def meshed(part, h):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", fepre.ConvergenceWarning)
        return fepre.distmesh(part, h=h)


@pytest.fixture(scope="module")
def enclosure_mesh():
    part = enclosure()
    return part, meshed(part, 1.0)


def set_area(grid, name):
    names = grid.field_data["boundary_names"].tolist()
    return float(grid.field_data["boundary_areas"][names.index(name)])


def test_enclosure_floor_is_the_flat_floor_not_the_chamfer(tmp_path, enclosure_mesh):
    # Before: 60.02 against 45 (+33%), the chamfer's first row of faces in the floor set.
    part, mesh = enclosure_mesh
    with warnings.catch_warnings():
        warnings.simplefilter("error", BoundaryWarning)  # its edge is a crease: nothing to say
        grid = fepre.export(mesh, tmp_path / "box.vtu", boundaries={"floor": FLOOR}, model=part)
    assert set_area(grid, "floor") == pytest.approx(FLOOR_AREA, rel=1e-3)
    faces = fepre.export.boundary_faces(grid)
    on_floor = faces.extract_cells(faces["boundary_id"] == 0)
    assert np.abs(np.asarray(on_floor.points)[:, 2]).max() <= 1e-3  # every node on the floor
    counts = grid.field_data["boundary_face_counts"]
    assert counts.tolist() == np.bincount(faces["boundary_id"], minlength=2).tolist()
    total = float(grid.extract_surface(algorithm=None).area)
    assert float(grid.field_data["boundary_areas"].sum()) == pytest.approx(total, rel=1e-9)


def test_fillet_next_to_the_floor_stays_out_of_it(tmp_path):
    # The part: a rounded box (R 2 on every edge, so the fillet leaves the floor
    # tangentially), hollowed. Before: 58.6 against the flat 8 x 4 = 32 (+83%), the fillet's faces
    # tilted up to 60 degrees in the set. Now every face of the set is flat on the floor; with no
    # mesh node on the tangent line the set ends within a row of faces of it, so its area is below
    # 32 by at most the tangent rectangle's perimeter times h, and a warning says so and by how
    # much at most (the area of the faces next to it that turn off the floor by under 20 degrees).
    a, b, c, r, h = 12.0, 8.0, 5.0, 2.0, 1.0
    part = sdf.rounded_box((a, b, c), r, center=(0, 0, c / 2)) - sdf.box((a - 3, b - 3, c), center=(0, 0, c / 2 + 1.5))
    mesh = meshed(part, h)
    with pytest.warns(BoundaryWarning, match=r"'floor': along \d+ faces of its edge .*a fillet leaves it") as caught:
        grid = fepre.export(mesh, tmp_path / "box.vtu", boundaries={"floor": FLOOR}, model=part)
    band = float(re.search(r"by up to ([\d.]+)", str(caught[0].message)).group(1))
    assert set_area(grid, "floor") < (a - 2 * r) * (b - 2 * r) <= set_area(grid, "floor") + band
    faces = fepre.export.boundary_faces(grid)
    floor = faces.extract_cells(faces["boundary_id"] == 0)
    assert np.abs(np.asarray(floor.points)[:, 2]).max() <= 1e-3 * h
    flat = (a - 2 * r) * (b - 2 * r)
    assert flat - 2 * (a + b - 4 * r) * h <= set_area(grid, "floor") <= flat * (1 + 1e-9)


def test_tee_end_is_pi_r_squared(tmp_path):
    # Two cylinders (radius 1) in a tee; the end of the branch is a disc. Quadratic faces put the
    # rim's midside nodes on the circle. Before: 3.0615 (the linear faces' polygon, -2.5%) and no
    # area shown.
    part = sdf.cylinder(1.0, 6.0, axis="x") | sdf.cylinder(1.0, 3.0, center=(0, 0, 1.5), axis="z")
    mesh = meshed(part, 0.4)
    grid = fepre.export(mesh, tmp_path / "tee.inp", order=2, model=part,
                        boundaries={"end": sdf.plane((0, 0, 1), (0, 0, 3.0))})
    assert set_area(grid, "end") == pytest.approx(np.pi, rel=1e-3)
    back = pv.read(tmp_path / "tee.inp")  # fepre's reader: the same sets, the same areas
    assert np.allclose(back.field_data["boundary_areas"], grid.field_data["boundary_areas"], rtol=1e-9)
    assert back.field_data["boundary_face_counts"].tolist() == grid.field_data["boundary_face_counts"].tolist()


def test_bore_is_two_pi_r_l(tmp_path):
    # A bore of radius 1 through a 4 x 4 x 2 block: the set is the bore's wall, 2 pi r L, and no
    # face of the flat sides (normals across the bore's gradient) joins it.
    part = sdf.box((4.0, 4.0, 2.0)) - sdf.cylinder(1.0, 4.0)
    mesh = meshed(part, 0.4)
    grid = fepre.export(mesh, tmp_path / "bore.vtu", order=2, model=part,
                        boundaries={"bore": sdf.cylinder(1.0, 20.0)})
    assert set_area(grid, "bore") == pytest.approx(2 * np.pi * 2.0, rel=1e-3)


def test_faces_need_every_node_on_the_surface_and_its_normal():
    # (1) Three nodes on the unit sphere (in the plane z = 0.2, 25 degrees apart): on the surface,
    # but the face's normal is 77.7 degrees from the sphere's at its centroid: not in the set,
    # unless boundary_angle allows 80 degrees.
    d = 0.2
    angles = np.radians([0.0, 25.0, 50.0])
    triangle = np.c_[np.sqrt(1 - d * d) * np.cos(angles), np.sqrt(1 - d * d) * np.sin(angles), np.full(3, d)]
    apex = triangle.mean(axis=0) - [0, 0, 0.3]
    tilted = pv.UnstructuredGrid({pv.CellType.TETRA: np.array([[0, 2, 1, 3]])}, np.vstack([triangle, apex]))
    with pytest.warns(BoundaryWarning, match="'ball' match no boundary face"):
        assert tag_boundaries(tilted, {"ball": sdf.sphere(1.0)})["boundary_id"].tolist() == [1, 1, 1, 1]
    assert tag_boundaries(tilted, {"ball": sdf.sphere(1.0)}, boundary_angle=80)["boundary_id"].tolist() == [0, 1, 1, 1]
    # (2) A face crossing the plane z = 0 at its centroid, nodes 0.05 above and below it (0.05 h):
    # the centroid rule (fepre < 0.9) took it; the nodes are not on the plane, so it is not in.
    across = np.array([[0, 0, -0.05], [1, 0, 0.05], [0, 1, 0.0], [0.3, 0.3, 1.0]])
    grid = pv.UnstructuredGrid({pv.CellType.TETRA: np.array([[0, 1, 2, 3]])}, across)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", BoundaryWarning)
        assert tag_boundaries(grid, {"floor": lambda p: p[:, 2]})["boundary_id"].tolist() == [1, 1, 1, 1]


@pytest.mark.slow  # 6 s of the default run on 2 cores
def test_a_set_by_an_unbounded_plane_is_not_told_to_take_another_surface():
    """A keyway's floor named by the plane z = 11.5, which runs on through the crown of a journal
    of radius 12 beside it: the journal's faces near the plane (0.1-0.5 below its top, tilted
    by up to 17 degrees) were "parallel faces near it", and the warning advised
    boundary_tolerance=0.25, which took 277 of them (516.7 for 240). fepre's own mesh puts the
    floor's nodes on it: no warning, the set exact (new-user trial)."""
    shaft = sdf.cylinder(15, 60, center=(30, 0, 0), axis="x") | sdf.cylinder(12, 50, center=(85, 0, 0), axis="x")
    part = shaft - sdf.box((40, 6, 10), center=(30, 0, 16.5))
    mesh = fepre.distmesh(part, (1.5, 7.5))
    with warnings.catch_warnings():
        warnings.simplefilter("error", BoundaryWarning)
        faces = tag_boundaries(mesh, {"key_floor": sdf.plane((0, 0, 1), (0, 0, 11.5))})
    floor = np.flatnonzero(np.asarray(faces["boundary_id"]) == 0)
    corners = np.asarray(faces.points)[np.asarray(faces.faces).reshape(-1, 4)[floor, 1:]]
    area = 0.5 * np.linalg.norm(np.cross(corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0]), axis=1).sum()
    assert area == pytest.approx(240.0, rel=1e-9)


def test_mesh_made_elsewhere_warns_how_far_its_nodes_are():
    # A mesh whose boundary nodes sit 0.2-0.8% of h off the surface (as gmsh's or pytetwild's may,
    # and a tessellated STEP part's nodes under an exact cylinder: a bore set took 18 of its 370
    # faces, -94.7% of its area): nothing is within 1e-3 h. Within FACET_TOLERANCE the set takes
    # them at the tolerance that does, and says so; farther, it warns with that tolerance and
    # leaves them, rather than leaving the set silently empty.
    mesh = kuhn_box((0, 0, 0), (2.0, 1.0, 1.0), (8, 4, 4))
    points = np.asarray(mesh.points).copy()
    rng = np.random.default_rng(0)
    bottom = points[:, 2] == 0.0
    offsets = rng.uniform(0.0005, 0.002, bottom.sum()) * rng.choice([-1, 1], bottom.sum())
    points[bottom, 2] += offsets
    mesh.points = points
    bottom_plane = {"bottom": sdf.plane((0, 0, -1), (0, 0, 0))}
    with pytest.warns(BoundaryWarning, match=r"boundaries 'bottom': the faces along its surface have their nodes a "
                                             r"median 0.00[5-7]\d* h off it .* Taken with boundary_tolerance=0.01 for "
                                             r"this set: 64 faces, against 0 at the default 0.001"):
        faces = tag_boundaries(mesh, bottom_plane)
    assert np.count_nonzero(faces["boundary_id"] == 0) == 64
    with warnings.catch_warnings():
        warnings.simplefilter("error", BoundaryWarning)
        faces = tag_boundaries(mesh, bottom_plane, boundary_tolerance=0.01)
    assert np.count_nonzero(faces["boundary_id"] == 0) == 64
    points[bottom, 2] += 10 * offsets  # 2-9% of h: not a tessellation's facets; named, not taken
    mesh.points = points
    with pytest.warns(BoundaryWarning, match=r"boundaries 'bottom': 0 faces .* 64 parallel faces near it have none: "
                                             r"their nodes lie a median 0.0[5-7]\d* h .* pass boundary_tolerance=0.1"):
        faces = tag_boundaries(mesh, bottom_plane)
    assert np.count_nonzero(faces["boundary_id"] == 0) == 0


def test_coplanar_faces_facing_both_ways_go_to_the_gradient_s_way_only(tmp_path):
    """A Z-bracket: the lower arm's top and the upper arm's underside both lie on z = 5. The set
    "plane z = 5, normal +z" took both (160 instead of 80, a new user's trial): the normal was
    compared with the gradient up to sign. A set all of whose faces face one way still takes
    them whichever way its function's gradient points (a bottom named by ``p[:, 2]``)."""
    lower = sdf.box((10, 8, 5)).translate((5, 4, 2.5))
    web = sdf.box((5, 8, 10)).translate((12.5, 4, 5))
    upper = sdf.box((10, 8, 5)).translate((20, 4, 7.5))
    mesh = meshed(lower | web | upper, 1.0)
    with pytest.warns(BoundaryWarning, match=r"'lower_top': \d+ face\(s\) on its surface \(area 80\) face against"):
        grid = fepre.export(mesh, tmp_path / "z.vtu", boundaries={"lower_top": sdf.plane((0, 0, 1), (0, 0, 5))})
    assert set_area(grid, "lower_top") == pytest.approx(80.0, rel=1e-9)
    with pytest.warns(BoundaryWarning, match=r"'upper_bottom': \d+ face\(s\) on its surface \(area 80\)"):
        grid = fepre.export(mesh, tmp_path / "z.vtu", boundaries={"upper_bottom": lambda p: 5.0 - p[:, 2]})
    faces = fepre.export.boundary_faces(grid)
    chosen = faces.extract_cells(faces["boundary_id"] == 0)
    assert chosen.bounds[0] == pytest.approx(15.0) and chosen.area == pytest.approx(80.0, rel=1e-9)
    with warnings.catch_warnings():
        warnings.simplefilter("error", BoundaryWarning)
        grid = fepre.export(mesh, tmp_path / "z.vtu", boundaries={"bottom": lambda p: p[:, 2]})
    assert set_area(grid, "bottom") == pytest.approx(80.0 + 40.0, rel=1e-9)  # the lower arm's and the web's
