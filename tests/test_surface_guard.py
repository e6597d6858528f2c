"""The quality stage's surface guard: boundary vertices stay on their own surface patch."""

import numpy as np
import pytest

from fepre import sdf
from fepre.distmesh.surface_guard import SurfaceGuard


def two_plates():
    # two 1-thick plates with a 0.6 gap between them (z in [-0.5, 0.5] and [1.1, 2.1])
    return sdf.box((4, 4, 1), center=(0, 0, 0)) | sdf.box((4, 4, 1), center=(0, 0, 1.6))


def test_a_move_onto_the_other_body_across_a_gap_is_refused():
    part = two_plates()
    points = np.array([[0.0, 0.0, 0.5], [0.0, 0.0, 1.1]])
    guard = SurfaceGuard(part, 1.0, points, np.array([True, True]))
    vertices = np.array([0, 0, 1, 1])
    old = points[vertices]
    new = np.array([[0.3, 0.0, 0.5], [0.0, 0.0, 1.1], [0.2, 0.1, 1.1], [0.0, 0.0, 0.5]])
    assert guard.moves_allowed(vertices, old, new).tolist() == [True, False, True, False]


def test_a_move_round_a_crease_is_refused_and_along_a_smooth_patch_allowed():
    ball = sdf.sphere(1.0)
    cube = sdf.box((2, 2, 2))
    points = np.array([[0.0, 0.0, 1.0], [0.0, 0.0, 1.0]])
    guard = SurfaceGuard(ball, 0.2, points[:1], np.array([True]))
    along = np.array([[np.sin(0.1), 0.0, np.cos(0.1)]])
    assert guard.moves_allowed(np.array([0]), points[:1], along).tolist() == [True]
    guard = SurfaceGuard(cube, 0.2, np.array([[0.9, 0.0, 1.0]]), np.array([True]))
    # from the top face over the edge onto the side face: another patch, normal 90 deg away
    assert guard.moves_allowed(np.array([0]), np.array([[0.9, 0.0, 1.0]]), np.array([[1.0, 0.0, 0.9]])).tolist() == [False]


def test_faces_that_leave_the_surface_are_refused():
    ball = sdf.sphere(1.0)
    guard = SurfaceGuard(ball, 0.2, np.zeros((1, 3)), np.array([False]))
    t = 0.1
    on = np.array([[[1, 0, 0], [np.cos(t), np.sin(t), 0], [np.cos(t), 0, np.sin(t)]]], dtype=float)
    # the same face turned inside out (normal pointing inwards) and one sunk 0.1 deep
    flipped = on[:, ::-1]
    sunk = on * 0.9
    assert guard.faces_allowed(None, np.concatenate([on, flipped, sunk])).tolist() == [True, False, False]
    # a face no worse than before passes
    assert guard.faces_allowed(sunk, sunk * 1.01).tolist() == [True]


def _lift(x, y):
    return np.array([x, y, np.sqrt(1 - x * x - y * y)])


def _ring(cx, r, degrees):
    return [_lift(cx + r * np.cos(np.radians(t)), r * np.sin(np.radians(t))) for t in degrees]


def folding_cap():
    """Two cells under a unit sphere's pole, each with one boundary face (chords of the sphere,
    0.35 wide). Cell 0's free vertex 0 sits squeezed next to its face's other edge (score 10.6);
    the regular position for it (0.2, 0) on the sphere makes its face cross cell 1's face, whose
    circumcircle overlaps (issue 32: demosthenes' base, where a move of 0.23 h folded two faces
    the guard's own face checks passed)."""
    from fepre.distmesh.tet_topology import face_keys
    from fepre.quality import signed_volumes

    goal, a, b = _ring(0.0, 0.2, (0, 120, 240))
    p, q, r = _ring(0.17, 0.2, (180, 300, 60))
    below = []
    for face in ((goal, a, b), (p, q, r)):
        normal = np.cross(face[1] - face[0], face[2] - face[0])
        below.append(np.mean(face, axis=0) - normal / np.linalg.norm(normal) * np.linalg.norm(a - b) * np.sqrt(2 / 3))
    points = np.array([_lift(-0.07, 0.0), a, b, below[0], p, q, r, below[1]])
    tets = np.array([[0, 1, 2, 3], [4, 5, 6, 7]])
    flip = signed_volumes(points, tets) < 0
    tets[flip] = tets[flip][:, [1, 0, 2, 3]]
    faces = np.array([[0, 1, 2], [4, 5, 6]])
    boundary = np.isin(np.arange(8), faces)
    return points, tets, faces, np.sort(face_keys(faces, 8)), boundary, goal


def test_a_move_that_folds_the_boundary_passes_the_local_checks_and_is_undone():
    from fepre.distmesh.smoothing import relax_round, smooth_round
    from fepre.distmesh.surface_guard import folding_vertices
    from fepre.distmesh.tet_shape import ShapeTargets
    from fepre.triangle_crossings import crossing_faces

    ball, h, targets = sdf.sphere(1.0), 0.3, ShapeTargets()
    points, tets, faces, keys, boundary, goal = folding_cap()
    guard = SurfaceGuard(ball, h, points, boundary)
    quality = targets.score(points[tets])
    assert quality[0] < 11 and len(crossing_faces(points, faces)) == 0
    moved = points.copy()
    moved[0] = goal
    assert crossing_faces(moved, faces).tolist() == [[0, 1]]
    # the local checks: own patch, path and the vertex's own faces on the surface all pass ...
    assert guard.moves_allowed(np.array([0]), points[[0]], goal[None]).tolist() == [True]
    assert guard.faces_allowed(points[faces[:1]], moved[faces[:1]]).tolist() == [True]
    # ... the crossing test does not
    assert folding_vertices(points, moved, keys, np.array([0])).tolist() == [0]
    assert folding_vertices(points, points, keys, np.array([0])).tolist() == []
    movable = np.zeros(8, dtype=bool)
    movable[0] = True
    new, new_quality, count = relax_round(points, tets, quality, 25.0, movable, boundary, ball, 1e-4 * h,
                                          targets=targets, guard=guard, boundary_face_keys=keys)
    assert count == 0 and np.array_equal(new, points) and np.array_equal(new_quality, quality)
    new, new_quality, count, touched = smooth_round(points, tets, quality, 33.0, movable, boundary, ball, h,
                                                    np.random.default_rng(0), 1e-4 * h, targets=targets, guard=guard,
                                                    boundary_face_keys=keys)
    assert len(crossing_faces(new, faces)) == 0
    assert np.allclose(new_quality, targets.score(new[tets]))
    # without the guard nothing stops the fold (the regular position scores 70.5)
    new, new_quality, count = relax_round(points, tets, quality, 25.0, movable, boundary, ball, 1e-4 * h, targets=targets)
    assert count == 1 and new_quality[0] > 70 and crossing_faces(new, faces).tolist() == [[0, 1]]


@pytest.mark.parametrize("seed", range(5))
def test_the_grid_prefilter_keeps_every_centre_within_reach(seed):
    # folding_vertices asks a tree of the changed faces' centres only about the centres in grid
    # cells next to theirs; the answer must be the one for every centre
    from scipy.spatial import cKDTree

    from fepre.distmesh.surface_guard import _near_cells

    rng = np.random.default_rng(seed)
    centres = rng.random((4000, 3)) * 10.0 ** seed + 10.0 ** seed
    changed = rng.choice(len(centres), size=1 + 7 * seed, replace=False)
    reach = 0.04 * 10.0 ** seed
    tree = cKDTree(centres[changed])
    within = np.flatnonzero(tree.query_ball_point(centres, reach, return_length=True) > 0)
    candidates = _near_cells(centres, changed, reach)
    assert len(candidates) < len(centres) / 2
    assert np.array_equal(candidates[tree.query_ball_point(centres[candidates], reach, return_length=True) > 0], within)
