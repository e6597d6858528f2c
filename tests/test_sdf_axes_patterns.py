"""Primitives along any axis (`axis=` of cylinder, cone, torus) and polar patterns, against
independent formulas in the axis' own frame."""

from __future__ import annotations

import warnings

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import fepre
from fepre import sdf

RNG = np.random.default_rng(7)


def frame(points: np.ndarray, center, axis) -> tuple[np.ndarray, np.ndarray]:
    """(t, rho): coordinate along the unit axis and distance from it."""
    a = np.asarray(axis, float) / np.linalg.norm(axis)
    d = points - np.asarray(center, float)
    t = d @ a
    return t, np.linalg.norm(d - t[:, None] * a, axis=1)


def capped_cylinder(points, radius, height, center, axis):
    t, rho = frame(points, center, axis)
    q = np.column_stack([rho - radius, np.abs(t) - height / 2])
    return np.linalg.norm(np.maximum(q, 0), axis=1) + np.minimum(q.max(axis=1), 0)


axes = st.tuples(*[st.floats(-1, 1, allow_nan=False)] * 3).filter(lambda v: np.linalg.norm(v) > 0.1)


@settings(max_examples=40, deadline=None)
@given(axis=axes, center=st.tuples(*[st.floats(-2, 2)] * 3))
def test_cylinder_along_any_axis_is_the_exact_distance(axis, center):
    points = RNG.uniform(-4, 4, (400, 3))
    got = sdf.cylinder(radius=0.7, height=2.2, center=center, axis=axis)(points)
    assert np.allclose(got, capped_cylinder(points, 0.7, 2.2, center, axis), atol=1e-12)


@settings(max_examples=40, deadline=None)
@given(axis=axes)
def test_torus_along_any_axis_is_the_exact_distance(axis):
    points = RNG.uniform(-3, 3, (400, 3))
    t, rho = frame(points, (0.5, 0, -1), axis)
    expected = np.hypot(rho - 1.5, t) - 0.4
    assert np.allclose(sdf.torus(1.5, 0.4, center=(0.5, 0, -1), axis=axis)(points), expected, atol=1e-12)


def test_cone_along_an_axis_points_its_apex_that_way():
    tip = sdf.cone(radius=1.0, height=2.0, center=(1, 1, 1), axis="x")
    assert tip([3.0, 1.0, 1.0]) == pytest.approx(0.0, abs=1e-12)  # the apex
    assert tip([1.0, 1.0, 1.0]) == pytest.approx(0.0, abs=1e-12)  # the base centre, on the base
    assert tip([0.0, 1.0, 1.0]) == pytest.approx(1.0, abs=1e-12)  # 1 below the base
    points = RNG.uniform(-3, 3, (300, 3))
    local = sdf.cone(radius=1.0, height=2.0)  # the same cone along z, evaluated in the x frame
    mapped = np.column_stack([points[:, 1] - 1, points[:, 2] - 1, points[:, 0] - 1])
    assert np.allclose(np.abs(tip(points)), np.abs(local(mapped)), atol=1e-12)


def test_named_axes_and_the_default():
    points = RNG.uniform(-2, 2, (200, 3))
    z = sdf.cylinder(radius=0.5, height=1.5)
    assert np.array_equal(sdf.cylinder(radius=0.5, height=1.5, axis=(0, 0, 3))(points), z(points))
    assert np.allclose(sdf.cylinder(radius=0.5, height=1.5, axis="y")(points), z(points[:, [0, 2, 1]]), atol=1e-12)
    assert type(z).__name__ == "Cylinder"  # the z axis adds no transform


@pytest.mark.parametrize(
    "call, message",
    [
        (lambda: sdf.cylinder(axis="w"), "axis must be 'x', 'y', 'z' or a 3-vector; got 'w'"),
        (lambda: sdf.torus(axis=(0, 0, 0)), "axis must be a non-zero vector"),
        (lambda: sdf.cone(axis=(1, 2)), "axis"),
        (lambda: sdf.polar_pattern(sdf.sphere(0.1), 0), "count"),
        (lambda: sdf.polar_pattern(sdf.sphere(0.1), 4, angle=0), r"angle must be in \(0, 360\]"),
        (lambda: sdf.polar_pattern(sdf.circle(1.0), 4), "3D SDF"),
        (lambda: sdf.polar_pattern("ball", 4), "shape must be an SDF"),
    ],
)
def test_bad_axes_and_patterns_name_the_parameter(call, message):
    with pytest.raises((ValueError, TypeError), match=message):
        call()


def test_polar_pattern_is_the_union_of_turned_copies():
    pin = sdf.cylinder(radius=0.2, height=1.0, center=(1.0, 0.0, 0.0), axis="x")
    star = sdf.polar_pattern(pin, 5, axis=(0, 0, 1), center=(0.5, 0.0, 0.0))
    points = RNG.uniform(-2, 2, (2000, 3))
    copies = []
    for k in range(5):
        angle = 2 * np.pi * k / 5
        c, s = np.cos(angle), np.sin(angle)
        centre = np.array([0.5 + 0.5 * c, 0.5 * s, 0.0])
        copies.append(capped_cylinder(points, 0.2, 1.0, centre, (c, s, 0.0)))
    assert np.allclose(star(points), np.min(copies, axis=0), atol=1e-12)
    fan = sdf.polar_pattern(sdf.sphere(0.1, center=(1, 0, 0)), 3, angle=90)  # 0, 45, 90 deg
    assert fan([0.0, 1.0, 0.0]) == pytest.approx(-0.1) and fan([np.sqrt(0.5), np.sqrt(0.5), 0]) == pytest.approx(-0.1)
    assert fan([-1.0, 0.0, 0.0]) > 0.5


@pytest.mark.slow
def test_a_flange_with_a_bolt_circle_meshes_to_its_volume():
    holes = sdf.polar_pattern(sdf.cylinder(radius=4.0, height=30.0, center=(30.0, 0.0, 0.0)), 8)
    flange = sdf.cylinder(radius=40.0, height=10.0) - holes - sdf.cylinder(radius=12.0, height=30.0)
    features = fepre.features(flange, h=4.0)
    assert len(features.curves) == 2 * (8 + 2)  # each hole's two rims, the outer and inner rims
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", fepre.ConvergenceWarning)
        mesh = fepre.distmesh(flange, h=2.5)  # 22k cells; at h = 4 the r = 4 holes are hexagons (+1.3%)
    exact = np.pi * (40.0**2 - 12.0**2) * 10.0 - 8 * np.pi * 4.0**2 * 10.0
    assert mesh.volume == pytest.approx(exact, rel=0.01)
    assert mesh["min_dihedral_angle"].min() >= 25.0
