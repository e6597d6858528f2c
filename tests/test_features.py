"""fepre.features: corners and feature curves of CSG models, against their analytic positions."""

from __future__ import annotations

import math
import warnings

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import fepre
from fepre import sdf
from fepre.parts import cube_with_hole, l_bracket, l_bracket_corners, slotted_box, slotted_box_corners


def box_corners(size, center=(0.0, 0.0, 0.0)):
    half = np.asarray(size, float) / 2
    signs = np.array([[i, j, k] for i in (-1, 1) for j in (-1, 1) for k in (-1, 1)], float)
    return np.asarray(center, float) + signs * half


def assert_same_points(found, expected, tol):
    """Every expected point has a found one within ``tol`` and the counts agree."""
    assert len(found) == len(expected), f"{len(found)} found, {len(expected)} expected"
    from scipy.spatial import cKDTree

    distance, _ = cKDTree(found).query(expected)
    assert distance.max() <= tol, distance.max()


def curve_spacings(curve):
    pairs = curve.segments
    return np.linalg.norm(curve.points[pairs[:, 1]] - curve.points[pairs[:, 0]], axis=1)


def test_box_has_its_8_corners_and_12_edges_with_nodes_h_apart():
    found = fepre.features(sdf.box((2.0, 1.0, 1.5)), h=0.25)
    assert_same_points(found.corners, box_corners((2.0, 1.0, 1.5)), 1e-11)
    assert len(found.curves) == 12 and not any(c.closed for c in found.curves)
    lengths = sorted(round(c.length, 9) for c in found.curves)
    assert lengths == [1.0] * 4 + [1.5] * 4 + [2.0] * 4
    for curve in found.curves:
        assert curve.angle == pytest.approx(90.0, abs=1e-6)
        assert np.all(np.abs(curve_spacings(curve) - 0.25) < 1e-9)
        # every node on both faces: two coordinates at the box's half sizes
        on_faces = np.isclose(np.abs(curve.points), [1.0, 0.5, 0.75], atol=1e-11).sum(axis=1)
        assert np.all(on_faces >= 2)
        ends = curve.points[[0, -1]]  # the ends are corners
        assert np.all(np.isclose(np.abs(ends), [1.0, 0.5, 0.75], atol=1e-11).all(axis=1))
    assert len(found.nodes) == 8 + 4 * (7 + 3 + 5)  # corners + inner nodes of the 12 edges
    assert not found.skipped


def test_smooth_parts_have_no_features():
    for model in (sdf.sphere(1.0), sdf.torus(1.0, 0.4), sdf.capsule((0, 0, 0), (1, 0, 0), 0.3),
                  sdf.union(sdf.sphere(0.6), sdf.sphere(0.6, center=(0.7, 0, 0)), k=0.3),
                  sdf.rounded_box((1, 1, 1), 0.2)):
        found = fepre.features(model, h=0.1)
        assert not found and len(found.nodes) == 0, model.describe()


def test_cube_with_hole_corners_edges_and_the_two_rims():
    model, hole = cube_with_hole()
    found = fepre.features(model, h=0.25)
    assert_same_points(found.corners, 5.0 * box_corners((1, 1, 1), (0.5, 0.5, 0.5)) / 1.0, 1e-10)
    rims = [c for c in found.curves if c.closed]
    assert len(rims) == 2 and len(found.curves) == 14
    for rim in rims:
        radius = np.linalg.norm(rim.points[:, :2] - 2.5, axis=1)
        np.testing.assert_allclose(radius, 1.0, atol=1e-10)
        z = rim.points[:, 2]
        assert np.allclose(z, z[0], atol=1e-10) and min(abs(z[0]), abs(z[0] - 5)) < 1e-10
        assert len(rim.points) == round(2 * math.pi / 0.25)
        assert rim.angle == pytest.approx(90.0, abs=1e-6)


def test_rotated_box_features_are_found_at_rotated_positions():
    box = sdf.box((2.0, 1.0, 0.5))
    moved = box.rotate(37.0, axis=(1.0, 2.0, 0.5)).translate((0.3, -0.2, 0.1))
    found = fepre.features(moved, h=0.2)
    matrix = moved.matrix
    expected = box_corners((2.0, 1.0, 0.5)) @ matrix[:3, :3].T + matrix[:3, 3]
    assert_same_points(found.corners, expected, 1e-10)
    assert len(found.curves) == 12
    assert sum(c.length for c in found.curves) == pytest.approx(4 * (2.0 + 1.0 + 0.5), rel=1e-9)


@given(angle=st.floats(0.0, 360.0), axis=st.tuples(*[st.floats(-1, 1)] * 3).filter(lambda a: np.linalg.norm(a) > 0.1),
       shift=st.tuples(*[st.floats(-2, 2)] * 3))
@settings(max_examples=12, deadline=None)
def test_property_corners_of_rigidly_moved_boxes(angle, axis, shift):
    box = sdf.box((1.0, 0.7, 0.4))
    moved = box.rotate(angle, axis=axis).translate(shift)
    found = fepre.features(moved, h=0.2)
    if not hasattr(moved, "matrix"):  # the identity collapses to the box itself
        matrix = np.eye(4)
    else:
        matrix = moved.matrix
    expected = box_corners((1.0, 0.7, 0.4)) @ matrix[:3, :3].T + matrix[:3, 3]
    assert_same_points(found.corners, expected, 1e-9)
    assert np.abs(moved(found.nodes)).max() < 1e-9


def test_slotted_box_concave_and_convex_edges():
    model, _ = slotted_box()
    found = fepre.features(model, h=0.2)
    assert_same_points(found.corners, slotted_box_corners(), 1e-10)
    assert len(found.curves) == 24
    assert sum(c.length for c in found.curves) == pytest.approx(4 * 4 + 4 * 2 + 4 * 1 + 2 * (2.4 + 0.6) * 2 + 4 * 0.5, rel=1e-9)


def test_l_bracket_outer_corners_and_no_corner_at_the_filleted_inner_edge():
    model, _, _ = l_bracket()
    found = fepre.features(model, h=0.2)
    outer = l_bracket_corners()
    from scipy.spatial import cKDTree

    distance, _ = cKDTree(found.corners).query(outer)
    assert distance.max() < 1e-10
    # the raw inner corner of the two plates is inside the fillet: never a feature
    inner_edge = np.linalg.norm(found.nodes[:, [0, 2]] - 0.6, axis=1)
    assert inner_edge.min() > 0.05
    assert np.abs(model(found.nodes)).max() < 1e-9
    # the hole's two rims are closed curves of radius 0.4
    rims = [c for c in found.curves if c.closed]
    assert len(rims) == 2
    for rim in rims:
        np.testing.assert_allclose(np.linalg.norm(rim.points[:, :2] - [2.8, 1.0], axis=1), 0.4, atol=1e-10)


def test_cylinder_rims_and_cone_apex():
    rod = fepre.features(sdf.cylinder(radius=0.5, height=1.0), h=0.1)
    assert len(rod.corners) == 0 and len(rod.curves) == 2 and all(c.closed for c in rod.curves)
    for rim in rod.curves:
        np.testing.assert_allclose(np.linalg.norm(rim.points[:, :2], axis=1), 0.5, atol=1e-10)
        np.testing.assert_allclose(np.abs(rim.points[:, 2]), 0.5, atol=1e-10)
    tip = fepre.features(sdf.cone(radius=1.0, height=2.0), h=0.2)
    np.testing.assert_allclose(tip.corners, [[0.0, 0.0, 2.0]], atol=1e-12)
    (rim,) = tip.curves
    assert rim.angle == pytest.approx(90.0 + math.degrees(math.atan(0.5)), abs=1e-6)


def test_polygon_extrusion_edges_follow_the_crease_angle():
    square = fepre.features(sdf.extrude(sdf.polygon([[0, 0], [1, 0], [1, 1], [0, 1]]), 0.5), h=0.125)
    assert len(square.corners) == 8 and len(square.curves) == 12
    # a 48-gon turns by 7.5 degrees per vertex: no vertical edges and no corners, only the two
    # rims (one curve per side, joined end to end)
    prism = sdf.extrude(sdf.regular_polygon(48, 1.0), 0.5)
    disk = fepre.features(prism, h=0.125)
    assert len(disk.corners) == 0
    assert all(np.ptp(c.points[:, 2]) < 1e-12 for c in disk.curves)
    perimeter = 48 * 2 * math.sin(math.pi / 48)
    assert sum(c.length for c in disk.curves) == pytest.approx(2 * perimeter, rel=1e-9)
    # with a 5 degree threshold the 48 vertical edges are features too, ending in 96 corners
    sharp = fepre.features(prism, h=0.125, angle=5.0)
    assert len(sharp.corners) == 96
    assert sum(np.ptp(c.points[:, 2]) > 0.49 for c in sharp.curves) == 48


def test_size_function_grades_the_curve_nodes():
    def size(points):
        return 1.0 + points[:, 0] + 1.0  # 1 at x = -1, 3 at x = 1

    found = fepre.features(sdf.box(2.0), h=0.1, size=size)
    along_x = [c for c in found.curves if np.ptp(c.points[:, 0]) > 1.9]
    assert len(along_x) == 4
    for curve in along_x:
        spacing = curve_spacings(curve)
        middle = 0.5 * (curve.points[curve.segments[:, 0], 0] + curve.points[curve.segments[:, 1], 0])
        expected = 0.1 * (2.0 + middle)
        np.testing.assert_allclose(spacing, expected, rtol=0.15)


def test_features_closer_than_half_h_are_skipped_with_a_warning():
    plate = sdf.box((2.0, 2.0, 0.04))  # thinner than h/2: its two rims nearly coincide
    with pytest.warns(fepre.FeatureWarning, match="thin walls"):
        found = fepre.features(plate, h=0.2)
    assert any("not kept" in message for message in found.skipped)
    nodes = found.nodes
    from scipy.spatial import cKDTree

    pairs = cKDTree(nodes).query_pairs(0.5 * 0.2 - 1e-9)
    assert not pairs  # what is kept is at least h/2 apart
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        fepre.features(plate, h=0.2, warn=False)


def test_distance_to_features_and_polydata():
    found = fepre.features(sdf.box(2.0), h=0.5)
    distance, nearest = found.distance([[1.5, 1.5, 0.2], [0.0, 0.0, 3.0], [1.0, 1.0, 1.0]])
    np.testing.assert_allclose(distance, [math.sqrt(0.5), math.sqrt(5.0), 0.0], atol=1e-12)
    np.testing.assert_allclose(nearest[0], [1.0, 1.0, 0.2], atol=1e-12)
    mesh = found.to_polydata()
    assert mesh.n_lines == 12 and mesh.n_verts == 8
    assert int(mesh.point_data["corner"].sum()) == 8
    assert "corners          8" in str(found)


def test_patch_protocol_values_vanish_on_their_patches():
    part = sdf.box(2.0) - sdf.cylinder(radius=0.5, height=3.0)
    points = np.array([[1.0, 0.3, 0.2], [0.0, 0.5, 0.1], [0.6, -0.4, 1.0]])
    values, labels = part.patch_labels(points)
    np.testing.assert_allclose(values, 0.0, atol=1e-12)
    assert len(set(labels.tolist())) == 3
    np.testing.assert_allclose(part.patch_values(labels, points), 0.0, atol=1e-12)
    # a patch's function extends its surface: the x = 1 face's plane, the hole's cylinder
    far = np.array([[3.0, 5.0, 5.0], [0.0, 2.0, 9.0]])
    np.testing.assert_allclose(part.patch_values(labels[:2], far), [2.0, -1.5], atol=1e-12)


@pytest.mark.parametrize(
    "call, error, match",
    [
        (lambda: fepre.features(sdf.box(1.0), h=0.0), ValueError, "h"),
        (lambda: fepre.features(sdf.box(1.0), h=0.1, angle=180.0), ValueError, "angle"),
        (lambda: fepre.features(sdf.box(1.0), h=0.1, angle=float("nan")), ValueError, "angle"),
        (lambda: fepre.features("box", h=0.1), TypeError, "model"),
        (lambda: fepre.features(sdf.circle(1.0), h=0.1), TypeError, "3D"),
        (lambda: fepre.features(sdf.plane(), h=0.1), ValueError, "bounds"),
        (lambda: fepre.features(sdf.box(1.0), h=0.1, spacing=-1.0), ValueError, "spacing"),
        (lambda: fepre.features(sdf.box(1.0), h=0.1, size=3.0), TypeError, "size"),
        (lambda: sdf.box(1.0).patch_values([6], [[0, 0, 0]]), ValueError, "patch_count"),
        (lambda: sdf.box(1.0).patch_values([0.5], [[0, 0, 0]]), ValueError, "labels"),
    ],
)
def test_bad_input(call, error, match):
    with pytest.raises(error, match=match):
        call()


def test_a_rotated_block_on_a_plate_has_the_corners_and_curves_of_the_upright_one():
    """Rotated, the block's bottom face (one plane with the plate's top, seen from the other side)
    decided the value at some vertices at the foot of its walls by rounding; Newton on that pair
    and a wall found "corners" all along the foot: 33 candidates for 16, 14 skipped as too close."""
    plate, block = sdf.box((6, 6, 4)), sdf.box((3, 3, 3), center=(0.5, 0.5, 3.5))
    upright = fepre.features(plate | block, 1.0)
    with warnings.catch_warnings():
        warnings.simplefilter("error", fepre.FeatureWarning)
        rotated = fepre.features((plate | block).rotate(37.0, (0.3, 0.5, 0.8)), 1.0, warn=False)
    assert (len(upright.corners), len(upright.curves)) == (16, 24)
    assert (len(rotated.corners), len(rotated.curves)) == (16, 24)


def test_nodes_of_one_curve_closer_than_half_h_are_not_both_kept():
    """A curve that doubles back within h/4 (a hairpin 0.2 h wide) or is shorter than h/2 (two
    nodes 0.024 h apart, as on truck.obj at D/50) put two fixed nodes closer than any element can
    join: cells of 0.0 degrees. Of such a pair the later node goes, and the count joins the
    warning."""
    from fepre.features.conflicts import resolve_conflicts
    from fepre.features.curves import FeatureCurve

    hairpin = FeatureCurve(np.array([[0, 0, 0], [1, 0, 0], [2, 0, 0], [2, 0.2, 0], [1, 0.2, 0], [0, 0.2, 0]], float), (0, 1), False, 90.0)
    stub = FeatureCurve(np.array([[5, 5, 5], [5.024, 5, 5]]), (1, 2), False, 90.0)
    h = lambda points: np.ones(len(points))
    corners, curves, skipped = resolve_conflicts(np.zeros((0, 3)), [hairpin, stub], h, 10.0, 30.0)
    nodes = np.concatenate([c.points for c in curves])
    gaps = np.linalg.norm(nodes[:, None] - nodes[None], axis=2) + np.eye(len(nodes)) * 9
    assert gaps.min() >= 0.5
    np.testing.assert_allclose(nodes, [[0, 0, 0], [1, 0, 0], [2, 0, 0]])  # the way back and the stub go
    assert any("5 feature curve node(s) within 0.5 h" in message for message in skipped)  # the stub's first too, alone


def test_the_crease_search_samples_a_band_and_finds_the_whole_grids_surface():
    """Issue 33: the fine surface the creases come from is sampled in a band of one cell
    diagonal; its vertices and triangles are the whole grid's, bit for bit (a triangle-mesh
    model: 32 s for the whole grid, 12 s in the band)."""
    import pyvista as pv

    from fepre.cad_parts import flange
    from fepre.features.detect import _GRID_SHIFT, fine_surface
    from fepre.surface.flying_edges import flying_edges

    model, spacing = flange().model, 0.25
    lower, upper = (np.asarray(b, float) for b in model.bounds)
    vertices, triangles = fine_surface(model, spacing, (lower, upper))
    origin = lower - _GRID_SHIFT * spacing
    counts = np.ceil((upper - lower) / spacing + 2 * _GRID_SHIFT).astype(np.int64) + 1
    axes = [origin[k] + spacing * np.arange(counts[k]) for k in range(3)]
    grid = pv.ImageData(dimensions=tuple(int(c) for c in counts), spacing=(spacing,) * 3, origin=tuple(origin))
    grid.point_data["sdf"] = model.values_on_axes(*axes, dtype=np.float32).reshape(-1)
    whole_vertices, whole_triangles = flying_edges(grid, "sdf", 0.0)
    assert len(triangles) > 10_000
    assert np.array_equal(vertices, np.asarray(whole_vertices, np.float64))
    assert np.array_equal(triangles, np.asarray(whole_triangles, np.int64))


def test_a_hairpin_wider_than_a_quarter_h_is_kept_whole():
    """A crease that doubles back 0.3 h wide (bunny_small.off at h = (D/50, D/12) has one 0.28-0.5 h
    wide): cutting it at its turn left an 11.0 deg cell at the cut, kept whole the mesh reaches
    26.1 deg. All its nodes stay, in one curve."""
    from fepre.features.conflicts import resolve_conflicts
    from fepre.features.curves import FeatureCurve

    points = np.array([[0, 0, 0], [1, 0, 0], [2, 0, 0], [2.6, 0.15, 0], [2, 0.3, 0], [1, 0.3, 0], [0, 0.3, 0]], float)
    hairpin = FeatureCurve(points, (0, 1), False, 90.0)
    corners, curves, skipped = resolve_conflicts(np.zeros((0, 3)), [hairpin], lambda p: np.ones(len(p)), 10.0, 30.0)
    assert len(curves) == 1 and not skipped
    np.testing.assert_array_equal(curves[0].points, points)
