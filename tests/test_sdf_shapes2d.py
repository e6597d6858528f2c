"""2D shapes (circle, rectangle, polygon) and the 2D -> 3D solids (extrude, revolve).

Polygon distances are checked against a brute-force reference written independently: the
smallest point-segment distance over all edges, signed by the winding number (a sum of angles,
not the crossing parity the implementation uses).
"""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.spatial import cKDTree

from fepre import sdf

RNG = np.random.default_rng(7)


@pytest.fixture(autouse=True)
def _reseed():
    """Every test sees the same random points, whatever ran before it."""
    RNG.bit_generator.state = np.random.default_rng(7).bit_generator.state


def polygon_reference(points, vertices):
    a = vertices
    b = np.roll(vertices, -1, axis=0)
    e = b - a
    w = points[:, None, :] - a[None]
    t = np.clip(np.einsum("pej,ej->pe", w, e) / np.einsum("ej,ej->e", e, e), 0, 1)
    distance = np.linalg.norm(w - t[..., None] * e, axis=2).min(axis=1)
    return np.where(winding(points, vertices), -distance, distance)


def winding(points, vertices):
    """True where the winding number is non-zero (sum of signed angles subtended by edges)."""
    u = vertices[None, :, :] - points[:, None, :]
    v = np.roll(vertices, -1, axis=0)[None] - points[:, None, :]
    angle = np.arctan2(u[..., 0] * v[..., 1] - u[..., 1] * v[..., 0], np.einsum("pej,pej->pe", u, v))
    return np.abs(angle.sum(axis=1)) > np.pi


def star_polygon(rng, count):
    """A random simple (star-shaped) polygon with ``count`` vertices.

    Star-shaped about the origin only when every angular gap is below pi: otherwise the edge
    across the gap can cross the others.
    """
    while True:
        angles = np.sort(rng.uniform(0, 2 * np.pi, count))
        angles = angles[np.diff(np.r_[angles, angles[0] + 2 * np.pi]) > 1e-3]
        if len(angles) < 3 or np.diff(np.r_[angles, angles[0] + 2 * np.pi]).max() < 0.95 * np.pi:
            break
    radii = rng.uniform(0.3, 1.5, len(angles))
    return np.column_stack([radii * np.cos(angles), radii * np.sin(angles)]) + rng.uniform(-1, 1, 2)


def around2(model, count=3000, margin=0.3, rng=RNG):
    lo, hi = np.array(model.bounds[0]), np.array(model.bounds[1])
    pad = margin * (hi - lo)
    return rng.uniform(lo - pad, hi + pad, size=(count, len(lo)))


# ---------------------------------------------------------------------------- 2D shapes
def test_circle_rectangle_and_rounded_rectangle_closed_forms():
    points = RNG.uniform(-3, 3, size=(4000, 2))
    disk = sdf.circle(1.2, center=(0.5, -0.5))
    np.testing.assert_allclose(disk(points), np.linalg.norm(points - [0.5, -0.5], axis=1) - 1.2, atol=1e-14)
    lo, hi = np.array([-1.0, -0.25]), np.array([1.0, 0.75])
    rect = sdf.rectangle((2.0, 1.0), center=(0.0, 0.25))
    nearest = np.clip(points, lo, hi)
    depth = np.minimum(points - lo, hi - points).min(axis=1)
    reference = np.where(depth > 0, -depth, np.linalg.norm(points - nearest, axis=1))
    np.testing.assert_allclose(rect(points), reference, atol=1e-12)
    rounded = sdf.rounded_rectangle((2.0, 1.0), 0.25, center=(0.0, 0.25))
    inner_lo, inner_hi = lo + 0.25, hi - 0.25
    nearest = np.clip(points, inner_lo, inner_hi)
    depth = np.minimum(points - inner_lo, inner_hi - points).min(axis=1)
    inner = np.where(depth > 0, -depth, np.linalg.norm(points - nearest, axis=1))
    np.testing.assert_allclose(rounded(points), inner - 0.25, atol=1e-12)
    assert rect.dim == disk.dim == rounded.dim == 2
    assert rect.bounds == rounded.bounds == ((-1.0, -0.25), (1.0, 0.75))


@given(seed=st.integers(0, 2**32 - 1), count=st.integers(3, 40))
@settings(max_examples=40, deadline=None)
def test_polygon_is_exact_for_random_simple_polygons_of_either_orientation(seed, count):
    rng = np.random.default_rng(seed)
    vertices = star_polygon(rng, count)
    if len(vertices) < 3:
        return
    shape = sdf.polygon(vertices)
    points = np.vstack(
        [
            around2(shape, 600, rng=rng),
            vertices[rng.integers(0, len(vertices), 200)] + rng.normal(scale=0.02, size=(200, 2)),
            # Same y as the vertices: the degenerate case of the crossing rule.
            np.column_stack([rng.uniform(-3, 3, len(vertices)), vertices[:, 1]]),
        ]
    )
    reference = polygon_reference(points, vertices)
    np.testing.assert_allclose(shape(points), reference, atol=1e-12)
    np.testing.assert_allclose(sdf.polygon(vertices[::-1])(points), reference, atol=1e-12)


def test_polygon_non_convex_values_vertices_and_edges():
    comb = np.array([(0, 0), (5, 0), (5, 3), (4, 3), (4, 1), (3, 1), (3, 3), (2, 3), (2, 1), (1, 1), (1, 3), (0, 3)], float)
    shape = sdf.polygon(comb)
    assert shape([1.5, 2.0]) == pytest.approx(0.5)  # in a notch, between two teeth
    assert shape([0.5, 2.0]) == pytest.approx(-0.5)  # inside a tooth
    np.testing.assert_allclose(shape(comb), 0.0, atol=1e-15)  # the vertices themselves
    midpoints = (comb + np.roll(comb, -1, axis=0)) / 2
    np.testing.assert_allclose(shape(midpoints), 0.0, atol=1e-15)
    points = RNG.uniform(-1, 6, size=(5000, 2))
    np.testing.assert_allclose(shape(points), polygon_reference(points, comb), atol=1e-12)
    closed = sdf.polygon(np.vstack([comb, comb[:1]]))  # a repeated closing vertex is dropped
    assert len(closed.vertices) == len(comb)
    assert repr(shape) == "polygon(vertices=12, area=11)"  # 5 x 1 base and three 1 x 2 teeth


def test_polygon_with_many_edges_and_points_is_blocked_and_exact():
    vertices = star_polygon(np.random.default_rng(3), 3000)
    shape = sdf.polygon(vertices)
    points = RNG.uniform(-2.5, 2.5, size=(800, 2))
    np.testing.assert_allclose(shape(points), polygon_reference(points, vertices), atol=1e-12)
    grid = shape.values_on_axes(np.linspace(-2, 2, 40), np.linspace(-2, 2, 30), dtype=np.float64)
    yy, xx = np.meshgrid(np.linspace(-2, 2, 30), np.linspace(-2, 2, 40), indexing="ij")
    np.testing.assert_allclose(grid.ravel(), shape(np.column_stack([xx.ravel(), yy.ravel()])), atol=1e-14)


def test_simplicity_check_of_a_large_polygon_finds_a_single_crossing():
    t = np.linspace(0, 2 * np.pi, 20_000, endpoint=False)
    r = 1 + 0.3 * np.sin(50 * t)
    wiggly = np.column_stack([r * np.cos(t), r * np.sin(t)])
    assert len(sdf.polygon(wiggly).vertices) == 20_000  # a sweep, not 2e8 pair tests
    crossed = wiggly.copy()
    crossed[5000] = crossed[15000] + [0.01, 0.0]
    with pytest.raises(ValueError, match="simple polygon; edge (4999|5000) .* intersects edge"):
        sdf.polygon(crossed)


def test_regular_polygon_apothem_and_vertices():
    hexagon = sdf.regular_polygon(6, radius=2.0, center=(1, 1), angle=30)
    assert hexagon([1.0, 1.0]) == pytest.approx(-2.0 * np.cos(np.pi / 6))
    assert hexagon([1.0, 3.0]) == pytest.approx(0.0, abs=1e-12)  # a vertex at 90 degrees
    assert abs(hexagon.area) == pytest.approx(1.5 * np.sqrt(3) * 4.0)


BAD_POLYGONS = [
    ([(0, 0), (1, 1), (1, 0), (0, 1)], "simple"),  # bow tie
    ([(0, 0), (2, 0), (2, 2), (1, 0), (0, 2)], "simple"),  # vertex touching an edge
    ([(0, 0), (3, 0), (3, 1), (2, 0), (1, 0), (0, 1)], "simple"),  # collinear overlapping edges
    ([(0, 0), (1, 0), (2, 0)], "simple"),  # degenerate: folds back
    ([(0, 0), (1, 0), (1, 0), (0, 1)], "repeat"),
    ([(0, 0), (1, 0)], "at least 3"),
    ([(0, 0), (1, 0), (np.nan, 1)], "finite"),
    ([(0, 0, 0), (1, 0, 0), (0, 1, 0)], r"\(N, 2\)"),
    ([(0, 0), (1, 0), (0,)], "rectangular"),
]


@pytest.mark.parametrize("vertices, fragment", BAD_POLYGONS)
def test_bad_polygons_are_refused(vertices, fragment):
    with pytest.raises(ValueError, match="vertices") as info:
        sdf.polygon(vertices)
    assert info.match(fragment)


@pytest.mark.parametrize(
    "make, error, fragment",
    [
        (lambda: sdf.circle(0), ValueError, "radius"),
        (lambda: sdf.circle(1, center=(0, 0, 0)), ValueError, "center"),
        (lambda: sdf.rectangle((1, -1)), ValueError, "size"),
        (lambda: sdf.rounded_rectangle((1, 2), 0.6), ValueError, "radius"),
        (lambda: sdf.regular_polygon(2), ValueError, "sides"),
        (lambda: sdf.regular_polygon(5.5), TypeError, "sides"),
        (lambda: sdf.polygon("abc"), TypeError, "vertices"),
        (lambda: sdf.extrude(sdf.sphere(), 1.0), ValueError, "shape2d"),
        (lambda: sdf.extrude("circle", 1.0), TypeError, "shape2d"),
        (lambda: sdf.extrude(sdf.circle(), 0.0), ValueError, "height"),
        (lambda: sdf.extrude(sdf.circle(), float("inf")), ValueError, "height"),
        (lambda: sdf.revolve(sdf.box()), ValueError, "shape2d"),
        (lambda: sdf.revolve(None), TypeError, "shape2d"),
        (lambda: sdf.revolve(sdf.circle(), offset=float("nan")), ValueError, "offset"),
    ],
)
def test_bad_arguments_are_refused_naming_the_parameter(make, error, fragment):
    with pytest.raises(error, match=fragment):
        make()


def test_2d_points_must_be_n_by_2():
    with pytest.raises(ValueError, match=r"\(N, 2\)"):
        sdf.circle()(np.zeros((4, 3)))
    assert sdf.circle()([3.0, 4.0]) == pytest.approx(4.0)


# ---------------------------------------------------------------------------- extrude
L_SHAPE = np.array([(0, 0), (2, 0), (2, 1), (1, 1), (1, 2), (0, 2)], float)


def prism_surface(vertices, height, per_unit=120):
    """Dense points on the side walls and caps of a prism of ``vertices`` from -h/2 to h/2."""
    walls = []
    z = np.linspace(-height / 2, height / 2, int(per_unit * height) + 1)
    for a, b in zip(vertices, np.roll(vertices, -1, axis=0)):
        t = np.linspace(0, 1, int(per_unit * np.linalg.norm(b - a)) + 1)
        edge = a + t[:, None] * (b - a)
        walls.append(np.column_stack([np.repeat(edge, len(z), axis=0), np.tile(z, len(t))]))
    lo, hi = vertices.min(axis=0), vertices.max(axis=0)
    gx, gy = (np.linspace(lo[i], hi[i], int(per_unit * (hi[i] - lo[i])) + 1) for i in range(2))
    flat = np.column_stack([g.ravel() for g in np.meshgrid(gx, gy, indexing="ij")])
    flat = flat[polygon_reference(flat, vertices) <= 1e-12]
    caps = [np.column_stack([flat, np.full(len(flat), s * height / 2)]) for s in (-1, 1)]
    return np.vstack(walls + caps)


def check_cloud(model, surface, inside, points, spacing):
    cloud, _ = cKDTree(surface).query(points)
    values = model(points)
    assert np.all(np.abs(values) <= cloud + 1e-9)
    assert np.all(cloud - np.abs(values) <= spacing)
    sure = cloud > spacing
    np.testing.assert_array_equal(values[sure] < 0, inside(points[sure]))


def test_extruded_polygon_is_exact_against_a_surface_cloud():
    height = 0.8
    model = sdf.extrude(sdf.polygon(L_SHAPE), height)
    assert model.exact and model.bounds == ((0.0, 0.0, -0.4), (2.0, 2.0, 0.4))
    surface = prism_surface(L_SHAPE, height)
    points = np.vstack(
        [
            around2(model, 800),
            surface[RNG.integers(0, len(surface), 3000)] + RNG.normal(scale=0.05, size=(3000, 3)),
        ]
    )

    def inside(p):
        return winding(p[:, :2], L_SHAPE) & (np.abs(p[:, 2]) < height / 2)

    check_cloud(model, surface, inside, points, spacing=0.01)


def test_extruded_circle_is_the_capped_cylinder():
    model = sdf.extrude(sdf.circle(0.7), 1.6)
    points = RNG.uniform(-1.5, 1.5, size=(5000, 3))
    r, z = np.hypot(points[:, 0], points[:, 1]), points[:, 2]
    outside = np.hypot(r - np.clip(r, 0, 0.7), z - np.clip(z, -0.8, 0.8))
    depth = np.minimum(0.7 - r, 0.8 - np.abs(z))
    np.testing.assert_allclose(model(points), np.where(depth > 0, -depth, outside), atol=1e-12)
    np.testing.assert_allclose(model(points), sdf.cylinder(0.7, 1.6)(points), atol=1e-14)


# ---------------------------------------------------------------------------- revolve
def test_revolved_circle_is_the_torus():
    model = sdf.revolve(sdf.circle(0.3, center=(0.0, 0.1)), offset=1.0)
    assert model.exact
    np.testing.assert_allclose(model.bounds, ((-1.3, -1.3, -0.2), (1.3, 1.3, 0.4)), atol=1e-15)
    points = RNG.uniform(-1.6, 1.6, size=(5000, 3))
    closed = np.hypot(np.hypot(points[:, 0], points[:, 1]) - 1.0, points[:, 2] - 0.1) - 0.3
    np.testing.assert_allclose(model(points), closed, atol=1e-13)


def test_revolved_polygon_profile_is_exact_against_a_surface_cloud():
    profile = np.array([(0.5, -0.5), (1.2, -0.5), (1.2, -0.2), (0.8, 0.0), (0.8, 0.5), (0.5, 0.5)])
    model = sdf.revolve(sdf.polygon(profile))
    assert model.exact
    boundary = np.vstack(
        [a + np.linspace(0, 1, int(300 * np.linalg.norm(b - a)))[:, None] * (b - a) for a, b in zip(profile, np.roll(profile, -1, axis=0))]
    )
    angles = np.linspace(0, 2 * np.pi, 700, endpoint=False)
    surface = np.column_stack(
        [np.outer(boundary[:, 0], np.cos(angles)).ravel(), np.outer(boundary[:, 0], np.sin(angles)).ravel(), np.repeat(boundary[:, 1], len(angles))]
    )
    picks = surface[RNG.integers(0, len(surface), 3000)]
    points = np.vstack([around2(model, 800), picks + RNG.normal(scale=0.05, size=picks.shape)])

    def inside(p):
        return winding(np.column_stack([np.hypot(p[:, 0], p[:, 1]), p[:, 2]]), profile)

    check_cloud(model, surface, inside, points, spacing=0.012)


def test_revolving_a_profile_that_reaches_the_axis_is_a_flagged_lower_bound():
    # The rectangle [0, 1] x [-0.5, 0.5] revolved is the cylinder of radius 1, height 1; its
    # edge on the axis is not a surface, so inside values are too small there.
    model = sdf.revolve(sdf.rectangle((1.0, 1.0), center=(0.5, 0.0)))
    assert not model.exact
    points = RNG.uniform(-1.5, 1.5, size=(20_000, 3))
    values, true = model(points), sdf.cylinder(1.0, 1.0)(points)
    np.testing.assert_array_equal(values < 0, true < 0)
    assert np.all(np.abs(values) <= np.abs(true) + 1e-12)
    np.testing.assert_allclose(values[true > 0], true[true > 0], atol=1e-12)
    q = points + RNG.normal(scale=0.1, size=points.shape)
    assert np.all(np.abs(model(q) - values) <= np.linalg.norm(q - points, axis=1) + 1e-12)


# ---------------------------------------------------------------------------- protocol
MODELS = {
    "circle": sdf.circle(0.8, center=(0.1, 0.2)),
    "rectangle": sdf.rectangle((1.5, 0.7), center=(0.2, 0.0)),
    "rounded_rectangle": sdf.rounded_rectangle((1.5, 0.7), 0.2),
    "polygon": sdf.polygon(L_SHAPE - 1.0),
    "extrude_polygon": sdf.extrude(sdf.polygon(L_SHAPE - 1.0), 1.0),
    "extrude_rectangle": sdf.extrude(sdf.rectangle((1.5, 0.7)), 0.6),
    "revolve_circle": sdf.revolve(sdf.circle(0.3), offset=0.9),
    "revolve_polygon": sdf.revolve(sdf.polygon(L_SHAPE * 0.4), offset=0.3),
}


@pytest.mark.parametrize("name", sorted(MODELS))
def test_gradients_match_finite_differences_and_project_lands_on_the_zero_set(name):
    model = MODELS[name]
    assert model.analytic_gradient
    points = around2(model, 1500)
    gradient = model.gradient(points)
    step = 1e-6
    fd = np.column_stack(
        [(model(points + step * e) - model(points - step * e)) / (2 * step) for e in np.eye(model.dim)]
    )
    smooth = np.abs(np.linalg.norm(fd, axis=1) - 1) < 1e-4
    assert smooth.mean() > 0.97
    np.testing.assert_allclose(gradient[smooth], fd[smooth], atol=2e-5)
    np.testing.assert_allclose(np.linalg.norm(gradient, axis=1), 1.0, atol=1e-9)
    close = points[np.abs(model(points)) < 0.3]
    assert np.abs(model(model.project(close))).max() < 1e-9


@pytest.mark.parametrize("name", sorted(MODELS))
def test_bounds_contain_the_negative_region_and_grids_match_points(name):
    model = MODELS[name]
    points = around2(model, 40_000, margin=0.5)
    inside = points[model(points) < 0]
    assert len(inside) > 100
    assert np.all(inside >= np.array(model.bounds[0]) - 1e-12) and np.all(inside <= np.array(model.bounds[1]) + 1e-12)
    axes = [np.linspace(lo - 0.3, hi + 0.3, n) for lo, hi, n in zip(*model.bounds, (19, 17, 13))]
    grid = model.values_on_axes(*axes, dtype=np.float64)
    mesh = np.meshgrid(*reversed(axes), indexing="ij")
    coords = np.column_stack([m.ravel() for m in reversed(mesh)])
    np.testing.assert_allclose(grid.ravel(), model(coords), atol=1e-12)
    single = model.values_on_axes(*axes)
    assert single.dtype == np.float32
    np.testing.assert_allclose(single, grid, atol=2e-6)
    shaped = [a.astype(np.float32).reshape([-1 if i == axis else 1 for i in range(model.dim)][::-1]) for axis, a in enumerate(axes)]
    assert model._values(*shaped).dtype == np.float32
    assert all(np.asarray(g).dtype == np.float32 for g in model._values_and_gradient(*shaped)[1])


def test_repr_shows_the_tree():
    model = sdf.extrude(sdf.circle(1.0), 2.0)
    assert repr(model) == "extrude(height=2)\n└─ circle(radius=1, center=(0, 0))"
    ring = sdf.revolve(sdf.rectangle((0.2, 0.5), center=(1, 0)), offset=0.5)
    assert repr(ring) == "revolve(offset=0.5)\n└─ rectangle(size=(0.2, 0.5), center=(1, 0))"


def test_a_profile_on_the_other_side_of_the_axis_revolves_like_its_mirror():
    # The profile and its mirror image about the axis are one region (it was refused before).
    left = sdf.revolve(sdf.circle(1.0, center=(-3, 0)))
    right = sdf.revolve(sdf.circle(1.0, center=(3, 0)))
    points = np.random.default_rng(4).uniform(-5, 5, (500, 3))
    np.testing.assert_allclose(left(points), right(points), atol=1e-12)
