"""The quality stage's surface guard: boundary vertices stay on their own surface patch."""

import numpy as np

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
