"""The initial points' boundary layer: the lattice's own layer on flat faces along an axis,
points placed one per cube elsewhere."""

from __future__ import annotations

import warnings

import numpy as np
import pytest

import fepre
from fepre import sdf
from fepre.distmesh.initial_points import _CELL, boundary_layer_points, lattice, surface_points


def _layer(model, h, margin=None):
    lower, upper = (np.asarray(v, float) for v in model.bounds)
    margin = h if margin is None else margin
    points = lattice(lower - margin, upper + margin, h, "bcc")
    values = model(points)
    surface, inside = boundary_layer_points(model, points, values, lower, h, "bcc")
    return points, values, surface, inside


def test_a_flat_face_along_an_axis_gets_the_lattices_own_layer_and_the_next_one():
    # the lattice starts h below the box: its layer nearest the top face (z = 0.49) lies 0.02
    # above it, the next one 0.035 under it
    box, h = sdf.box((2.0, 1.5, 0.98)), 0.1
    points, values, surface, inside = _layer(box, h)
    top = surface[np.abs(surface[:, 2] - 0.49) < 1e-12]
    top = top[(np.abs(top[:, :2]) < [1.0 - 2 * h, 0.75 - 2 * h]).all(axis=1)]  # away from the rim
    assert len(top) > 100
    # each top point is a lattice point of the layer nearest the face moved straight onto it
    a = _CELL["bcc"] * h
    layer = points[np.abs(points[:, 2] - 0.49) <= a / 4 + 1e-12]
    distance = np.abs(layer[None, :, :2] - top[:, None, :2]).max(axis=2)
    assert distance.min(axis=1).max() <= 1e-12
    # and the next layer down is kept, though the rule for curved surfaces (points deeper than
    # h/2) would drop it
    kept = points[inside & (np.abs(points[:, :2]) < [1.0 - 2 * h, 0.75 - 2 * h]).all(axis=1)]
    depth = 0.49 - kept[:, 2]
    assert depth.min() == pytest.approx(a / 2 - 0.02, abs=1e-9)
    assert depth.min() < 0.5 * h
    assert (np.abs(depth - depth.min()) < 1e-9).sum() >= 0.9 * len(top)


def test_curved_surfaces_keep_one_point_per_cube():
    """A cylinder along z: its normal passes the x and y axes, but the surface is not flat there
    (snapped, the points would stack in columns along the generators)."""
    cylinder, h = sdf.cylinder(1.0, 6.0), 0.2
    points, values, surface, inside = _layer(cylinder, h)
    side = surface[np.abs(surface[:, 2]) < 3.0 - 1e-9]
    lower = np.asarray(cylinder.bounds[0], float)
    placed = surface_points(cylinder, points[np.abs(values) < h], lower, h)
    placed_side = placed[np.abs(placed[:, 2]) < 3.0 - 1e-9]
    assert len(side) == len(placed_side)
    np.testing.assert_array_equal(np.sort(side, axis=0), np.sort(placed_side, axis=0))
    np.testing.assert_array_equal(inside[values > -0.5 * h], False)


def test_a_wall_thinner_than_one_and_a_half_h_keeps_no_next_layer():
    """Only the points deeper than h/2, as on curved surfaces: a plate one size thick (a size
    field's ``elements_across=1``) keeps one cell across it."""
    a = _CELL["bcc"]
    # (the lattice starts h below the plate: at these thicknesses its layer nearest the top face
    # lies outside it and the next one inside, within h/2 of the face)
    for thickness, kept in ((1.1, False), (2.15, True)):
        plate, h = sdf.box((4.0, 4.0, thickness)), 1.0
        points, values, surface, inside = _layer(plate, h)
        deeper = values < -0.5 * h
        shallow = ~deeper & (values <= -a / 4 * h)
        assert shallow.any()
        assert inside[deeper].all()
        assert inside[shallow].any() == kept


def test_a_box_starts_near_the_lattices_quality_and_settles_in_half_the_iterations():
    """Before: points picked one per cube sat over the next layer along the faces: a 2 x 1.5 x 1
    box at h = 0.1 started at a mean volume-edge ratio of 0.82 and took 73 iterations (now 0.89
    and 33), for the same final quality."""
    history = []
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        mesh = fepre.distmesh(sdf.box((2.0, 1.5, 1.0)), 0.1,
                              callback=lambda state: history.append((state.iteration, state.mean_quality)))
    assert history[0][1] >= 0.87
    assert history[-1][0] <= 45
    assert history[-1][1] >= 0.89
    assert mesh["min_dihedral_angle"].min() >= 30.0
    assert mesh.volume == pytest.approx(3.0, rel=1e-9)
