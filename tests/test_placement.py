"""Placement-independent meshing (issue 33: "Parts far from the origin").

A cube with a hole 1e4 from the origin stopped with "DistMesh could not choose a valid solid ... 5
boundary nodes off the zero set" at h = 0.15: fepre.features' Newton solves stop at 1e-13 of the
part's size, below the rounding of coordinates at 1e4 (1.8e-12), so 243 of 1570 crease points
failed, the hole's rims broke into pieces and the feature nodes were wrong. fepre now meshes,
detects and sizes a far part in a local frame near the origin (fepre.placement) and moves the
result back: the same mesh up to the translation.
"""

from __future__ import annotations

import sys
import warnings

import numpy as np
import pytest

import fepre
from fepre import sdf
from fepre.placement import local_offset

CUBE_WITH_HOLE = sdf.box(2) - sdf.cylinder(radius=0.4, height=3)
EXACT_VOLUME = 8.0 - np.pi * 0.4**2 * 2.0


def _mesh(model, h, **kwargs):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return fepre.distmesh(model, h, **kwargs)


def _cells(mesh):
    return mesh.cells_dict[10]


def _assert_same_up_to(mesh, reference, offset, size=2.0):
    """Same cells, points equal after the translation to 1e-9 of the part's size, same quality."""
    assert mesh.n_cells == reference.n_cells and mesh.n_points == reference.n_points
    np.testing.assert_array_equal(_cells(mesh), _cells(reference))
    moved_back = np.asarray(mesh.points) - np.asarray(offset, float)
    assert np.abs(moved_back - np.asarray(reference.points)).max() <= 1e-9 * size
    for name in ("min_dihedral_angle", "max_dihedral_angle", "radius_ratio"):
        np.testing.assert_allclose(mesh[name], reference[name], rtol=0, atol=1e-6)


@pytest.fixture(scope="module")
def at_origin():
    return _mesh(CUBE_WITH_HOLE, 0.15)


def test_local_offset_is_zero_near_the_origin_and_round_far_from_it():
    assert not local_offset((-1, -1, -1), (1, 1, 1)).any()
    assert not local_offset((0, 0, 0), (1, 1, 1)).any()  # a periodic cell [0, L]
    assert not local_offset((0.5, 0.5, 0.5), (2, 2, 2)).any()
    assert local_offset((9999, 9999, 9999), (10001, 10001, 10001)).tolist() == [1e4, 1e4, 1e4]
    assert local_offset((-10001, -1, -1), (-9999, 1, 1)).tolist() == [-1e4, 0.0, 0.0]
    assert local_offset((1233.9, 0, 0), (1325.2, 50, 50)).tolist() == [1300.0, 0.0, 0.0]
    # the placement, not the box's centre: box((2, 1, 1), center=(1, .5, .5)).translate((1e4, 0, 0))
    assert local_offset((1e4, 0, 0), (1e4 + 2, 1, 1)).tolist() == [1e4, 0.0, 0.0]
    assert local_offset((12345.25, 0, 0), (12347.25, 1, 1)).tolist() == [12346.0, 0.0, 0.0]


@pytest.mark.parametrize("offset", [(1e4, 1e4, 1e4), (-1e4, 0.0, 0.0)])
def test_a_cube_with_a_hole_meshes_the_same_far_from_the_origin(at_origin, offset):
    """Before: MeshingError at (1e4, 1e4, 1e4) (5 boundary nodes off the zero set) and at
    (-1e4, 0, 0) (1 node)."""
    far = _mesh(CUBE_WITH_HOLE.translate(offset), 0.15)
    _assert_same_up_to(far, at_origin, offset)
    assert abs(far.volume / EXACT_VOLUME - 1.0) < 0.005
    assert far["min_dihedral_angle"].min() > 20.0
    lower = np.asarray(far.bounds).reshape(3, 2)[:, 0]
    np.testing.assert_allclose(lower, np.asarray(offset) - 1.0, rtol=0, atol=1e-9)


def test_features_do_not_depend_on_placement():
    """Before: at 1e4 the features came out as 31 broken curves (26.6 long instead of 29) and
    two nodes were skipped; at 1e5 the rims were missing."""
    near = fepre.features(CUBE_WITH_HOLE, 0.15)
    for offset in ((1e4, 1e4, 1e4), (1e5, 0.0, -1e5)):
        with warnings.catch_warnings():
            warnings.simplefilter("error")  # no FeatureWarning
            far = fepre.features(CUBE_WITH_HOLE.translate(offset), 0.15)
        assert len(far.curves) == len(near.curves) == 14 and len(far.corners) == 8
        assert sum(c.closed for c in far.curves) == 2
        np.testing.assert_allclose(far.nodes - np.asarray(offset), near.nodes, rtol=0, atol=1e-9)


def test_a_size_field_does_not_depend_on_placement():
    part = sdf.box((4, 2, 1)) - sdf.cylinder(radius=0.15, height=3)
    near = fepre.size_field(part, 0.08, 0.4)
    far = fepre.size_field(part.translate((1e4, 1e4, 1e4)), 0.08, 0.4)
    np.testing.assert_allclose(far.origin - 1e4, near.origin, rtol=0, atol=1e-9)
    np.testing.assert_array_equal(far.values, near.values)


@pytest.mark.slow
def test_a_triangle_mesh_models_curvature_sizes_do_not_depend_on_placement():
    """A faceted surface shows its curvature in the angles between facets, which the size field
    asks the model for (``facet_curvature``). Meshed at 1e4 the model is seen through the local
    frame's translation, which did not pass it on: a tessellated bar of radius 3 got the wall's
    size on its side instead of the chords' (a new user's bracket fillet: 4.08 for 2.5, a clevis
    9% fewer cells)."""
    import pyvista as pv

    bar = pv.Cylinder(radius=3.0, height=20.0, resolution=96).triangulate()
    far = bar.copy()
    offset = np.array([1e4, -1e4, 5e3])
    far.points = np.asarray(far.points, dtype=np.float64) + offset
    side = np.array([[0.0, 3.0 * np.cos(a), 3.0 * np.sin(a)] for a in np.linspace(0.0, 6.0, 7)])
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        near = fepre.size_field(sdf.mesh(bar), 0.2, 4.0)(side)
        moved = fepre.size_field(sdf.mesh(far), 0.2, 4.0)(side + offset)
    assert near.max() < 1.0  # the chords of a radius of 3 (the wall alone asks for 6 / 3 = 2)
    np.testing.assert_allclose(moved, near, rtol=1e-6)


@pytest.mark.slow  # 5 s of the default run on 2 cores
def test_a_graded_mesh_of_a_part_at_1e4_is_the_one_at_the_origin():
    """Before: MeshingError (5 boundary nodes off the zero set)."""
    part = sdf.box((4, 2, 1)) - sdf.cylinder(radius=0.15, height=3)
    near = _mesh(part, (0.08, 0.4))
    far = _mesh(part.translate((1e4, 1e4, 1e4)), (0.08, 0.4))
    _assert_same_up_to(far, near, (1e4, 1e4, 1e4), size=4.0)
    assert abs(far.volume / (8.0 - np.pi * 0.15**2) - 1.0) < 0.005


@pytest.mark.slow
@pytest.mark.parametrize("offset", [1e3, 1e5])
def test_the_cube_with_a_hole_at_1e3_and_1e5(at_origin, offset):
    _assert_same_up_to(_mesh(CUBE_WITH_HOLE.translate((offset,) * 3), 0.15), at_origin, (offset,) * 3)


def test_fixed_points_size_callable_and_callback_stay_in_the_users_frame():
    offset = np.array([1e4, -2e4, 5e3])
    part = sdf.box(2).translate(offset)
    fixed = np.array([[0.3, 0.1, -0.2]]) + offset
    seen = []
    mesh = _mesh(part, 0.5, fixed=fixed, size=lambda p: 1.0 + 0.0 * p[:, 0],
                 callback=lambda state: seen.append(state.points.mean(axis=0)))
    assert (np.asarray(mesh.points) == fixed[0]).all(axis=1).any()  # bit for bit
    assert np.abs(np.asarray(seen) - offset).max() < 1.0
    assert abs(mesh.volume - 8.0) < 1e-6 * 8.0


@pytest.mark.slow
def test_regions_far_from_the_origin():
    """Before: a valid mesh, but another one (1146 cells against 1166 at h = 0.25)."""
    offset = (1e4, 0.0, 0.0)
    bar = sdf.box((2, 1, 1), center=(1, 0.5, 0.5))
    left, right = sdf.box((1, 1, 1), center=(0.5, 0.5, 0.5)), sdf.box((1, 1, 1), center=(1.5, 0.5, 0.5))
    mesh = _mesh(bar.translate(offset), 0.34, regions={"a": left.translate(offset), "b": right.translate(offset)})
    near = _mesh(bar, 0.34, regions={"a": left, "b": right})
    np.testing.assert_array_equal(mesh["region_id"], near["region_id"])
    _assert_same_up_to(mesh, near, offset)


@pytest.mark.slow
def test_a_periodic_cell_with_its_lower_corner_far_from_the_origin():
    lower = np.array([1e4, 1e4, 1e4])
    mesh = _mesh(sdf.gyroid(period=1.0, thickness=0.2), 0.15, periodic=1.0, bounds=(lower, lower + 1.0))
    np.testing.assert_array_equal(mesh.field_data["periodic_lower"], lower)
    nodes = fepre.periodic_nodes(mesh)
    points = np.asarray(mesh.points)
    assert len(nodes.slaves) > 0
    assert np.abs(points[nodes.slaves] - nodes.shifts * 1.0 - points[nodes.masters]).max() < 1e-9


@pytest.mark.parametrize("backend", ["scipy", "gmsh"])
def test_delaunay_of_far_points_is_the_one_near_the_origin(backend):
    """Before: Qhull triangulated a 6^3 lattice at 1e4 with other cells than at the origin."""
    if backend == "gmsh":
        pytest.importorskip("gmsh")
    from fepre.distmesh.delaunay import loop_tetrahedralize, tetrahedralize

    lattice = np.stack(np.meshgrid(*[np.arange(6.0)] * 3, indexing="ij"), -1).reshape(-1, 3)
    np.testing.assert_array_equal(tetrahedralize(lattice + 1e4, backend), tetrahedralize(lattice, backend))
    np.testing.assert_array_equal(loop_tetrahedralize(lattice - 1e5, backend, 1.0), loop_tetrahedralize(lattice, backend, 1.0))


def test_an_error_about_a_far_part_names_the_frame():
    part = sdf.box(2).translate((1e4, 0.0, 0.0))
    with pytest.raises(ValueError, match="fixed") as raised:
        fepre.distmesh(part, 0.5, fixed=[[1e4 + 5.0, 0.0, 0.0]])
    if sys.version_info >= (3, 11):  # exception notes
        assert any("moved by (-10000.0, 0.0, 0.0)" in note for note in raised.value.__notes__)


@pytest.mark.slow  # 4 s of the default run on 2 cores
def test_the_size_fields_warning_names_places_where_the_far_part_is():
    """The size field's under-hmin warning named local coordinates, (-0.2, 9.7, 0.3), for a plate
    at (1e4, -5e3, 0): both through size_field and through distmesh(h=(hmin, hmax))."""
    import warnings

    plate = sdf.box((20.0, 20.0, 0.6)).translate((1e4, -5e3, 0.0))
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        fepre.size_field(plate, 0.3, 4.0, features=False)
        fepre.distmesh(plate, h=(0.3, 4.0), slivers=False)
    named = [str(w.message) for w in caught if "size field stops at hmin" in str(w.message)]
    assert len(named) == 2
    for message in named:
        where = message.split(" at (", 1)[1].split(")", 1)[0]
        x, y, z = (float(v) for v in where.split(", "))
        assert 1e4 - 10 <= x <= 1e4 + 10 and -5e3 - 10 <= y <= -5e3 + 10 and -0.3 <= z <= 0.3
