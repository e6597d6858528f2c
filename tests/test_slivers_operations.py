"""The quality stage's operations on small exact configurations: kernels, flips, smoothing, boundary cells."""

from __future__ import annotations

import numpy as np
import pytest

import fepre
from fepre import quality, sdf
from fepre.distmesh.boundary_slivers import remove_boundary_slivers
from fepre.distmesh.flips import flip_round, ring_triangulations, shape_flip_round
from fepre.distmesh.smoothing import relax_round, smooth_round
from fepre.distmesh.tet_shape import (
    ShapeTargets,
    dihedral_extremes,
    ideal_vertex_positions,
    min_dihedral,
    radius_ratio,
    shape_measures,
    signed_volume,
    tet_min_dihedral,
)
from fepre.distmesh.tet_topology import edge_keys, face_keys, face_neighbours, faces_on_boundary, open_boundary_reason

TRIANGLE = [(1, 0, 0), (-0.5, np.sqrt(3) / 2, 0), (-0.5, -np.sqrt(3) / 2, 0)]
TARGETS = ShapeTargets()


def score(points, tets):
    return TARGETS.score(points[tets])


def boundary_edges(tets, n):
    faces = faces_on_boundary(tets, face_neighbours(tets, n))
    return np.unique(edge_keys(faces[:, [0, 1, 1, 2, 2, 0]].reshape(-1, 2), n))


def test_min_dihedral_matches_fepre_quality_on_random_cells():
    rng = np.random.default_rng(1)
    points = rng.normal(size=(400, 3))
    tets = rng.integers(0, 400, size=(2000, 4))
    tets = tets[(np.sort(tets, 1)[:, 1:] != np.sort(tets, 1)[:, :-1]).all(1)]
    negative = signed_volume(points[tets]) < 0
    tets[negative] = tets[negative][:, [0, 2, 1, 3]]
    mine = tet_min_dihedral(points, tets)
    reference = quality.tet_quality(points, tets)["min_dihedral_angle"]
    valid = mine > 0
    assert valid.mean() > 0.99
    np.testing.assert_allclose(mine[valid], reference[valid], atol=1e-9)
    # inverted cells rank below every valid one
    assert (min_dihedral(points[tets[:, [0, 2, 1, 3]]]) == -1).all()


def test_ideal_position_makes_a_regular_cell():
    points = np.array([TRIANGLE[0], TRIANGLE[2], TRIANGLE[1], (0.3, 0.1, 0.05)])
    ideal = ideal_vertex_positions(points, np.array([[0, 1, 2, 3]]))[3, :, 0]
    moved = points.copy()
    moved[3] = ideal
    assert float(min_dihedral(moved)) == pytest.approx(np.degrees(np.arccos(1 / 3)), abs=1e-9)


@pytest.mark.parametrize("n, count", [(3, 1), (4, 2), (5, 5), (6, 14), (7, 42)])
def test_ring_triangulations_are_all_the_catalan_triangulations(n, count):
    triangulations = ring_triangulations(n)
    assert triangulations.shape == (count, n - 2, 3)
    assert len({tuple(sorted(map(tuple, t))) for t in triangulations}) == count


@pytest.mark.parametrize("z, before, after", [(0.2, 2, 3), (1.2, 3, 2)])
def test_two_three_and_three_two_flips_keep_the_region(z, before, after):
    """Apexes close to the triangle: 2 -> 3 flip; far from it: 3 -> 2; volume and boundary kept."""
    points = np.array([*TRIANGLE, (0, 0, z), (0, 0, -z)], dtype=float)
    configurations = {2: np.array([[0, 1, 2, 3], [0, 2, 1, 4]]), 3: np.array([[0, 2, 3, 4], [2, 1, 3, 4], [1, 0, 3, 4]])}
    tets = configurations[before]
    q = score(points, tets)
    new, new_q, flips, touched = flip_round(points, tets, q, 70.0, boundary_edges(tets, 5))
    assert flips == 1 and len(new) == after
    assert new_q.min() > q.min()
    np.testing.assert_allclose(new_q, score(points, new))
    assert signed_volume(points[new]).sum() == pytest.approx(signed_volume(points[tets]).sum(), rel=1e-12)
    old_faces = {tuple(sorted(f)) for f in faces_on_boundary(tets, face_neighbours(tets, 5))}
    new_faces = {tuple(sorted(f)) for f in faces_on_boundary(new, face_neighbours(new, 5))}
    assert old_faces == new_faces
    # the better configuration is left alone
    again = flip_round(points, new, new_q, 70.0, boundary_edges(new, 5))
    assert again[2] == 0


def test_four_four_flip_takes_the_short_diagonal():
    # an octahedron around the axis a-b whose equator is a long, thin rhombus
    ring = [(1, 0, 0), (0, 0.35, 0), (-1, 0, 0), (0, -0.35, 0)]
    points = np.array([*ring, (0, 0, -0.45), (0, 0, 0.45)], dtype=float)
    tets = np.array([[4, 5, i, (i + 1) % 4] for i in range(4)])
    negative = signed_volume(points[tets]) < 0
    tets[negative] = tets[negative][:, [0, 2, 1, 3]]
    q = tet_min_dihedral(points, tets)
    new, new_q, flips, _ = flip_round(points, tets, q, 70.0, boundary_edges(tets, 6))
    assert flips == 1 and len(new) == 4
    # every new cell holds the short diagonal 1-3 of the rhombus
    assert all({1, 3} <= set(cell) for cell in new.tolist())
    assert new_q.min() > q.min()
    assert signed_volume(points[new]).sum() == pytest.approx(signed_volume(points[tets]).sum(), rel=1e-12)


def test_smoothing_recentres_a_displaced_vertex_and_never_inverts():
    r = 1 / np.sqrt(3)
    points = np.array([[0.35, 0.25, 0.1], [r, r, r], [r, -r, -r], [-r, r, -r], [-r, -r, r]])
    tets = np.array([[0, 1, 2, 3], [0, 1, 4, 2], [0, 1, 3, 4], [0, 2, 4, 3]])
    q = score(points, tets)
    movable = np.array([True, False, False, False, False])
    on_boundary = ~movable
    rng = np.random.default_rng(0)
    for _ in range(10):
        points, q, moved, _ = smooth_round(points, tets, q, 70.0, movable, on_boundary, sdf.sphere(1.0), 1.0, rng, 1e-4)
        assert (tet_min_dihedral(points, tets) > 0).all()
        np.testing.assert_allclose(q, score(points, tets))
    assert np.linalg.norm(points[0]) < 1e-6
    smallest, largest, _ = dihedral_extremes(points[tets])
    assert smallest.min() == pytest.approx(np.degrees(np.arctan(np.sqrt(2) / 2)), abs=1e-6)  # 35.26 deg
    assert largest.max() == pytest.approx(120.0, abs=1e-6)


def test_open_boundary_reason():
    closed = np.array([[1, 2, 3], [0, 3, 2], [0, 1, 3], [0, 2, 1]])
    assert open_boundary_reason(closed, 4) == ""
    assert "open" in open_boundary_reason(closed[:3], 4)
    assert "same direction" in open_boundary_reason(np.concatenate([closed, closed[:1]]), 4)


def test_shape_flips_raise_the_radius_ratio_and_keep_the_worst_angle_and_the_region():
    ball = sdf.sphere(1.0)
    raw = fepre.distmesh(ball, 0.25, slivers=False)
    points = np.asarray(raw.points, dtype=np.float64)
    tets = raw.cells_dict[10].astype(np.int64)
    n = len(points)
    on_boundary = np.zeros(n, dtype=bool)
    on_boundary[faces_on_boundary(tets, face_neighbours(tets, n)).ravel()] = True
    points[on_boundary] = ball.project(points[on_boundary], iterations=20)
    # the stage's order: slivers flipped away and one relaxation pass first
    tets, q, _, _ = flip_round(points, tets, score(points, tets), 28.0, boundary_edges(tets, n))
    points, q, _ = relax_round(points, tets, q, 20.0, np.ones(n, dtype=bool), on_boundary, ball, 1e-5)
    ratio = radius_ratio(points[tets])
    floor = 28.0
    new, new_q, new_ratio, flips = shape_flip_round(points, tets, q, ratio, 0.8, floor, boundary_edges(tets, len(points)))
    assert flips > 0
    np.testing.assert_allclose(new_ratio, radius_ratio(points[new]))
    np.testing.assert_allclose(new_q, score(points, new))
    assert new_ratio.mean() > ratio.mean() + 0.001  # 0.0021 measured (26 flips)
    assert (new_ratio < 0.8).sum() < (ratio < 0.8).sum()
    assert new_ratio.min() >= ratio.min()
    assert new_q.min() >= min(q.min(), floor) and (new_q > 0).all()
    assert signed_volume(points[new]).sum() == pytest.approx(signed_volume(points[tets]).sum(), rel=1e-12)
    old_faces = {tuple(sorted(f)) for f in faces_on_boundary(tets, face_neighbours(tets, len(points)))}
    new_faces = {tuple(sorted(f)) for f in faces_on_boundary(new, face_neighbours(new, len(points)))}
    assert old_faces == new_faces


def test_shape_measures_match_fepre_quality():
    rng = np.random.default_rng(2)
    points = rng.normal(size=(300, 3))
    tets = rng.integers(0, 300, size=(20000, 4))  # more than one kernel block
    tets = tets[(np.sort(tets, 1)[:, 1:] != np.sort(tets, 1)[:, :-1]).all(1)]
    negative = signed_volume(points[tets]) < 0
    tets[negative] = tets[negative][:, [0, 2, 1, 3]]
    angle, ratio = shape_measures(points[tets])
    reference = quality.tet_quality(points, tets)
    valid = angle > 0
    np.testing.assert_array_equal(angle, tet_min_dihedral(points, tets))
    np.testing.assert_allclose(ratio[valid], reference["radius_ratio"][valid], atol=1e-12)
    assert (radius_ratio(points[tets[:, [0, 2, 1, 3]]]) == -1).all()


@pytest.mark.parametrize("z, removed", [(5.0, 1), (0.3, 0)])
def test_boundary_edges_on_a_crease_are_never_flipped(z, removed):
    """Three cells around an axis, each with two boundary faces meeting at its rim edge: a tall
    bipyramid's rim is nearly flat (169 deg) and a cell may go; a flat one's rim is a 62 deg crease."""
    points = np.array([*TRIANGLE, (0, 0, z), (0, 0, -z)], dtype=float)
    tets = np.array([[0, 2, 3, 4], [2, 1, 3, 4], [1, 0, 3, 4]])
    n = len(points)
    faces = faces_on_boundary(tets, face_neighbours(tets, n))
    face_keys_ = np.unique(face_keys(faces, n))
    on_boundary = np.ones(n, dtype=bool)
    on_zero_set = lambda p: np.zeros(len(p))  # noqa: E731 - every centroid counts as on the surface
    q = tet_min_dihedral(points, tets)
    new, _, count, new_faces, _ = remove_boundary_slivers(
        points, tets, q, 90.0, on_boundary, face_keys_, boundary_edges(tets, n), on_zero_set, 1.0
    )
    assert count == removed and len(new) == 3 - removed
    assert open_boundary_reason(faces_on_boundary(new, face_neighbours(new, n)), n) == ""


def test_face_keys_do_not_wrap_above_two_million_points():
    """(s0 n + s1) n + s2 wraps int64 above 2^21 points: with n = 2^22, faces whose smallest
    index differs by 2^20 got the same key, so two separate cells were glued."""
    n = 2**22
    k = 2**20
    tets = np.array([[0, k + 5, k + 6, n - 1], [k, k + 5, k + 6, n - 2]])
    np.testing.assert_array_equal(face_neighbours(tets, n), -np.ones((2, 4), dtype=np.int64))
    keys = face_keys(tets[:, [0, 1, 2]], n)
    assert keys[0] != keys[1]
    assert np.unique(face_keys(np.array([[5, 1, 2], [2, 5, 1], [1, 2, 6]]), n)).size == 2
    # the wide keys sort in the order of the sorted triples
    triples = np.random.default_rng(0).integers(0, n, size=(200, 3))
    order = np.argsort(face_keys(triples, n), kind="stable")
    s = np.sort(triples, axis=1)
    np.testing.assert_array_equal(order, np.lexsort((s[:, 2], s[:, 1], s[:, 0])))
    from fepre.distmesh.topology import boundary_faces, tet_faces

    _, counts, _ = tet_faces(tets)
    assert (counts == 1).all() and counts.size == 8
    assert boundary_faces(tets).shape == (8, 3)


def test_in_sorted_matches_isin_for_int_and_wide_keys():
    from fepre.distmesh.tet_topology import in_sorted

    rng = np.random.default_rng(1)
    for n in (1000, 2**22):
        keys = np.unique(face_keys(rng.integers(0, n, size=(300, 3)), n))
        query = face_keys(rng.integers(0, n, size=(200, 3)), n)
        query[:50] = keys[rng.integers(0, keys.size, 50)]
        np.testing.assert_array_equal(in_sorted(query, keys), np.isin(query, keys))
    assert not in_sorted(np.array([1, 2]), np.zeros(0, dtype=np.int64)).any()


def test_shape_score_is_the_worst_of_the_three_measures_mapped_to_degrees():
    targets = ShapeTargets(25.0, 150.0, 0.25)
    rng = np.random.default_rng(3)
    corners = rng.normal(size=(500, 4, 3))
    smallest, largest, ratio = dihedral_extremes(corners)
    score = targets.score(corners)
    valid = smallest >= 0
    expected = np.minimum.reduce([smallest, 25.0 / 30.0 * (180.0 - largest), 100.0 * ratio])
    np.testing.assert_allclose(score[valid], expected[valid])
    assert (score[~valid] == -1).all()
    # a cell meets the three targets exactly when its score reaches min_dihedral
    meets = (smallest >= 25) & (largest <= 150) & (ratio >= 0.25)
    assert (meets == (score >= 25.0 - 1e-12))[valid].all()


@pytest.mark.parametrize("bridges, removed", [(False, 0), (True, 1)])
def test_a_cap_out_in_the_air_goes_only_when_bridges_are_removed(bridges, removed):
    """The flat bipyramid's cells (rim a 62 deg crease) with their centroids 0.5 h outside the
    part: caps bridging a valley of a faceted surface. They stay, unless within
    ``bridges_removed()``, where one goes (the cells removed in one call share no vertex)."""
    from contextlib import nullcontext

    from fepre.distmesh.boundary_slivers import bridges_removed

    points = np.array([*TRIANGLE, (0, 0, 0.3), (0, 0, -0.3)], dtype=float)
    tets = np.array([[0, 2, 3, 4], [2, 1, 3, 4], [1, 0, 3, 4]])
    n = len(points)
    faces = faces_on_boundary(tets, face_neighbours(tets, n))
    face_keys_ = np.unique(face_keys(faces, n))
    out_in_the_air = lambda p: np.full(len(p), 0.5)  # noqa: E731
    with bridges_removed() if bridges else nullcontext():
        new, _, count, _, _ = remove_boundary_slivers(
            points, tets, tet_min_dihedral(points, tets), 90.0, np.ones(n, dtype=bool), face_keys_,
            boundary_edges(tets, n), out_in_the_air, 1.0)
    assert count == removed and len(new) == 3 - removed
    assert open_boundary_reason(faces_on_boundary(new, face_neighbours(new, n)), n) == ""
