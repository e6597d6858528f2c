"""Which edge of a cell left bad the insertion rounds split (issue 32, cow.obj at D/50): a wedge
of two caps splits their chord, a split that mends a cell at once goes first, and an edge whose
split the stage undid comes after every other choice."""

from __future__ import annotations

import numpy as np

from fepre import sdf
from fepre.distmesh.bad_cell_splits import split_bad_cells, split_candidates, stable_edge_keys
from fepre.distmesh.surface_refine import split_scores
from fepre.distmesh.tet_shape import ShapeTargets, signed_volume
from fepre.distmesh.tet_topology import face_neighbours, faces_on_boundary
from fepre.quality import tet_quality


def _positive(points, tets):
    tets = np.array(tets)
    flipped = signed_volume(points[tets]) < 0
    tets[flipped] = tets[flipped][:, [1, 0, 2, 3]]
    return tets


def _largest_face_angle(points, faces):
    tri = points[faces]
    sides = np.linalg.norm(tri[:, [1, 2, 0]] - tri[:, [2, 0, 1]], axis=2)
    a = sides.max(axis=1)
    b, c = np.sort(sides, axis=1)[:, 0], np.sort(sides, axis=1)[:, 1]
    return np.degrees(np.arccos(np.clip((b * b + c * c - a * a) / (2 * b * c), -1, 1))).max()


def _two_caps():
    # cow.obj at D/50, the tail/leg junction: a cell whose two boundary faces a b c, a b d are caps
    # (146 deg at c and d) on their common chord a b, its inner edge c d 0.05 below the surface
    # z = 0; the faces a c d, b c d are shared with two cells reaching down to v
    a, b, c, d, v = [-1, 0, 0], [1, 0, 0], [0, 0.3, -0.05], [0, -0.3, -0.05], [0, 0, -2]
    points = np.array([a, b, c, d, v], dtype=float)
    return points, _positive(points, [[0, 1, 2, 3], [0, 2, 3, 4], [1, 2, 3, 4]])


def test_a_wedge_of_two_caps_splits_their_chord_not_its_inner_edge():
    points, tets = _two_caps()
    faces = faces_on_boundary(tets, face_neighbours(tets, len(points)))
    assert np.isin(faces, [0, 1, 2, 3]).all(axis=1).sum() == 2  # a wedge
    off = np.zeros((1, 6))
    off[0, 5] = 0.05  # EDGE_OF_TET's last edge, c d: its midpoint off the surface
    candidates = split_candidates(points, tets, np.array([0]), len(points), off)
    assert candidates[0].tolist() == [0, 1]
    # the rounds' split (h = 0.4: c d's midpoint 0.125 h off the zero set, the second series'
    # chord rule) leaves no cap: every boundary face on the plane is right-angled at the new vertex
    new_points, new_tets, split = split_bad_cells(points, tets, sdf.plane((0, 0, 1)), 0.4, off_surface_first=True)
    assert split == 1 and np.allclose(new_points[-1], 0.0)
    faces = faces_on_boundary(new_tets, face_neighbours(new_tets, len(new_points)))
    top = faces[np.abs(new_points[faces][:, :, 2]).max(axis=1) < 0.1]
    assert len(top) == 4 and _largest_face_angle(new_points, top) < 90.5
    assert _largest_face_angle(points, np.array([[0, 1, 2]])) > 145.0  # the cap before


def _lone_cell():
    # cow.obj at D/50, an ear's tip: one cell apart from the rest (all four faces on the
    # boundary), its vertices on the surface (here: its circumsphere), in units of h
    points = np.array([[-0.243, -0.194, -0.634], [0.017, 0.546, -0.086], [-0.297, -0.606, 0.035],
                       [0.523, 0.254, 0.684]])
    rows = 2.0 * (points[1:] - points[0])
    centre = np.linalg.solve(rows, (points[1:] ** 2).sum(axis=1) - (points[0] ** 2).sum())
    radius = float(np.linalg.norm(points[0] - centre))
    return points, _positive(points, [[0, 1, 2, 3]]), sdf.sphere(radius).translate(tuple(centre))


def test_a_lone_cell_takes_the_split_that_mends_it():
    points, tets, model = _lone_cell()
    assert tet_quality(points, tets)["min_dihedral_angle"][0] < 22.0
    # its longest edge's midpoint projects too far; the next longest (the old choice) makes a
    # 2.4 deg cell; the split of edge 1 2 makes two cells of 39 and 45 deg
    made = split_scores(points, tets, model, 1.0, np.array([[0, 3], [2, 3], [1, 2]]))
    assert made[0] == -np.inf and made[1] < 5.0 and made[2] > 35.0
    new_points, new_tets, split = split_bad_cells(points, tets, model, 1.0)
    assert split == 1 and abs(model(new_points[-1:])[0]) < 1e-6
    angles = tet_quality(new_points, new_tets)["min_dihedral_angle"]
    assert len(new_tets) == 2 and angles.min() > 38.0
    assert sorted(map(sorted, new_tets.tolist())) == [[0, 1, 3, 4], [0, 2, 3, 4]]  # edge 1 2 split


def test_an_undone_split_comes_after_the_other_choices():
    points, tets = _two_caps()
    score = ShapeTargets().score(points[tets])
    assert score[0] < 25.0
    first = split_bad_cells(points, tets, sdf.plane((0, 0, 1)), 0.4, off_surface_first=True)
    again = split_bad_cells(points, tets, sdf.plane((0, 0, 1)), 0.4, off_surface_first=True,
                            tried=stable_edge_keys(np.array([[1, 0]])))
    assert first[2] == again[2] == 1
    # the chord a b is gone from the first mesh's cells, kept in the second's (another edge split)
    assert (0, 1) not in _edges(first[1]) and (0, 1) in _edges(again[1])


def _edges(cells):
    pairs = cells[:, [[0, 1], [0, 2], [0, 3], [1, 2], [1, 3], [2, 3]]].reshape(-1, 2)
    return set(map(tuple, np.sort(pairs, axis=1).tolist()))
