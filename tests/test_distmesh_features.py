"""DistMesh with sharp features: corners and edges of CSG parts are mesh nodes and stay sharp."""

from __future__ import annotations

import warnings

import numpy as np
import pytest
from scipy.spatial import cKDTree

import fepre
from fepre import sdf
from fepre.mesh_metrics import boundary_faces, model_hausdorff
from fepre.parts import (
    CUBE_WITH_HOLE_VOLUME,
    L_BRACKET_VOLUME as BRACKET_VOLUME,
    SLOTTED_BOX_VOLUME,
    cube_with_hole,
    cube_with_hole_corners,
    l_bracket,
    l_bracket_corners,
    slotted_box,
    slotted_box_corners,
)

BRACKET_CORNERS = l_bracket_corners()


def mesh_of(model, h, **options):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", fepre.ConvergenceWarning)
        return fepre.distmesh(model, h, **options)


def assert_valid(mesh, model, h):
    assert (mesh["volume"] > 0).all()
    boundary = np.unique(boundary_faces(np.asarray(mesh.cells_dict[10])))
    assert np.abs(model(mesh.points[boundary])).max() <= 1e-3 * h


def corner_gap(mesh, corners):
    distance, _ = cKDTree(mesh.points).query(corners)
    return float(distance.max())


@pytest.fixture(scope="module")
def cube_mesh():
    model, hole = cube_with_hole()
    return model, hole, mesh_of(model, 0.5)


def test_cube_with_hole_corners_rims_volume_hausdorff_and_quality(cube_mesh):
    model, hole, mesh = cube_mesh
    h = 0.5
    assert_valid(mesh, model, h)
    assert corner_gap(mesh, cube_with_hole_corners()) <= 1e-9
    assert int((mesh["feature"] == 2).sum()) == 8
    # nodes of the hole's rims: on the top or bottom face and on the hole, to 1e-9
    rim = mesh.points[(mesh["feature"] == 1) & (np.abs(hole(mesh.points)) < 1e-6)]
    assert len(rim) == 2 * round(2 * np.pi / h)
    assert np.abs(hole(rim)).max() <= 1e-9
    assert np.minimum(np.abs(rim[:, 2]), np.abs(rim[:, 2] - 5)).max() <= 1e-9
    # the mesh boundary is the true surface away from the hole, both ways
    to_surface, from_surface = model_hausdorff(mesh, model, spacing=h / 8, exclude=hole, margin=h)
    assert max(to_surface, from_surface) <= 0.01 * h
    assert mesh.volume == pytest.approx(CUBE_WITH_HOLE_VOLUME, rel=0.005)
    assert mesh["min_dihedral_angle"].min() >= 12.0


def test_without_features_the_edges_are_rounded():
    """On a cube turned off the lattice's axes (along them, the lattice's own layer is snapped
    onto each face and its corner points land on the cube's corners, features or not)."""
    from scipy.spatial.transform import Rotation

    model, hole = cube_with_hole()
    axis = np.array([1.0, 2.0, 3.0])
    turned, turned_hole = model.rotate(20.0, axis, (0.0, 0.0, 0.0)), hole.rotate(20.0, axis, (0.0, 0.0, 0.0))
    corners = Rotation.from_rotvec(np.radians(20.0) * axis / np.linalg.norm(axis)).apply(cube_with_hole_corners())
    assert np.abs(turned(corners)).max() <= 1e-9
    rounded = mesh_of(turned, 0.5, features=False)
    assert corner_gap(rounded, corners) > 1e-3
    to_surface, from_surface = model_hausdorff(rounded, turned, spacing=0.5 / 8, exclude=turned_hole, margin=0.5)
    assert from_surface > 0.05  # the corners are cut off
    assert not (rounded["feature"] > 0).any()


def test_slotted_box_is_exact_everywhere():
    model, _ = slotted_box()
    h = 0.25
    mesh = mesh_of(model, h)
    assert_valid(mesh, model, h)
    assert corner_gap(mesh, slotted_box_corners()) <= 1e-9
    # every face is planar: the mesh is the part to round-off
    assert max(model_hausdorff(mesh, model, spacing=h / 8)) <= 1e-9
    assert mesh.volume == pytest.approx(SLOTTED_BOX_VOLUME, rel=1e-9)
    assert mesh["min_dihedral_angle"].min() >= 12.0


def test_l_bracket_corners_and_hausdorff_away_from_hole_and_fillet():
    model, hole, _ = l_bracket()
    h = 0.2
    mesh = mesh_of(model, h)
    assert_valid(mesh, model, h)
    assert corner_gap(mesh, BRACKET_CORNERS) <= 1e-9
    fillet = sdf.capsule((0.6, -1.0, 0.6), (0.6, 3.0, 0.6), 0.6)  # around the filleted inner edge
    to_surface, from_surface = model_hausdorff(mesh, model, spacing=h / 8, exclude=hole | fillet, margin=h)
    assert max(to_surface, from_surface) <= 0.01 * h
    assert mesh.volume == pytest.approx(BRACKET_VOLUME, rel=0.005)
    assert mesh["min_dihedral_angle"].min() >= 12.0


def test_user_fixed_points_combine_with_features():
    box = sdf.box(1.0)
    on_edge = np.array([[0.5, 0.5, 0.1]])  # between the edge's feature nodes at z = 0 and 0.25
    mesh = mesh_of(box, 0.25, fixed=on_edge)
    assert corner_gap(mesh, on_edge) == 0.0
    corners = np.array([[x, y, z] for x in (-0.5, 0.5) for y in (-0.5, 0.5) for z in (-0.5, 0.5)])
    assert corner_gap(mesh, corners) <= 1e-9
    # the feature node at z = 0 (closer than h/2 to it) is left out; the one at 0.25 is kept
    edge = mesh.points[(np.abs(mesh.points[:, 0] - 0.5) < 1e-9) & (np.abs(mesh.points[:, 1] - 0.5) < 1e-9)]
    assert np.min(np.abs(edge[:, 2] - 0.0)) > 1e-3
    assert np.min(np.abs(edge[:, 2] - 0.25)) < 1e-9


def test_thin_plate_warns_names_what_was_skipped_and_meshes():
    plate = sdf.box((2.0, 2.0, 0.1))  # half an edge thick: its two rims cannot both be kept
    with pytest.warns(fepre.FeatureWarning, match="closer than 0.5 h to another corner"):
        mesh = mesh_of(plate, 0.2)
    assert_valid(mesh, plate, 0.2)
    assert mesh.volume == pytest.approx(2 * 2 * 0.1, rel=0.05)


def test_improve_keeps_feature_nodes_in_place(cube_mesh):
    model, hole, _ = cube_mesh
    raw = mesh_of(model, 0.5, slivers=False)
    better = fepre.improve(raw, model)
    assert better["min_dihedral_angle"].min() >= 20.0
    assert corner_gap(better, cube_with_hole_corners()) <= 1e-9
    assert max(model_hausdorff(better, model, spacing=0.5 / 8, exclude=hole, margin=0.5)) <= 0.005
    assert int(better.field_data["improve_pinned"][0]) >= int((raw["feature"] > 0).sum())


def test_feature_options_are_checked():
    with pytest.raises(ValueError, match="feature_angle"):
        fepre.DistMeshOptions(feature_angle=200.0)
    with pytest.raises(TypeError, match="features"):
        fepre.DistMeshOptions(features="yes")


def test_nearly_tangent_crease_meshes_with_or_without_it():
    # a shallow spherical dimple in the top face: its rim is a crease of only 11.5 degrees
    part = sdf.box(2.0) - sdf.sphere(1.0, center=(0.0, 0.0, 1.98))
    exact = 8.0 - np.pi * 0.02**2 * (3.0 - 0.02) / 3.0
    for angle, rims in ((30.0, 0), (5.0, 1)):
        found = fepre.features(part, 0.2, angle=angle)
        assert sum(c.closed for c in found.curves) == rims
        mesh = mesh_of(part, 0.2, feature_angle=angle)
        assert_valid(mesh, part, 0.2)
        assert corner_gap(mesh, found.corners) <= 1e-9
        assert mesh.volume == pytest.approx(exact, rel=1e-3)
        assert mesh["min_dihedral_angle"].min() >= 12.0


def random_csg(seed: int):
    """Three random boxes, rotated cylinders or spheres, combined by union and difference."""
    rng = np.random.default_rng(seed)

    def primitive():
        kind, centre = rng.integers(3), rng.uniform(-0.5, 0.5, 3)
        if kind == 0:
            return sdf.box(rng.uniform(0.5, 1.5, 3), center=centre)
        if kind == 1:
            return sdf.cylinder(rng.uniform(0.2, 0.6), rng.uniform(0.5, 1.5), center=centre).rotate(
                rng.uniform(0, 180), rng.normal(size=3))
        return sdf.sphere(rng.uniform(0.3, 0.7), center=centre)

    a, b, c = primitive(), primitive(), primitive()
    return [(a | b) - c, (a & sdf.box(1.6)) | b, a - b - c][rng.integers(3)]


# Seed 2's surface had a gap of 2.3 h where the cut box's faces meet the sphere, and the quality
# stage, which could not add nodes, left it at 7.8 deg with a ConvergenceWarning; with vertex
# insertion (3 nodes) it reaches 26.8 deg, and every seed here meets the three targets.
@pytest.mark.parametrize("seed", [1, 2, 4, 7, 10])
def test_random_csg_parts_mesh_validly_with_features(seed):
    model = random_csg(seed)
    reference = fepre.isosurface(model, spacing=0.01).volume
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        mesh = fepre.distmesh(model, 0.12)
    assert_valid(mesh, model, 0.12)
    assert mesh.volume == pytest.approx(reference, rel=0.02)
    assert not any(issubclass(w.category, fepre.ConvergenceWarning) for w in caught)
    assert mesh["min_dihedral_angle"].min() >= 25.0
    assert mesh["max_dihedral_angle"].max() <= 150.0
    assert mesh["radius_ratio"].min() >= 0.25
    found = fepre.features(model, 0.12, warn=False)
    assert corner_gap(mesh, found.corners) <= 1e-9 if len(found.corners) else True
