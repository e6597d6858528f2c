"""3D primitives of fepre.sdf: exact distances, bounds, Lipschitz bounds, gradients, projection.

Distances are checked against closed forms written independently of the implementation
(nearest points by clamping) and, for shapes without a simple closed form, against the distance
to a dense point cloud on the surface (scipy cKDTree): the exact distance never exceeds the
cloud distance and falls short of it by at most the cloud's spacing.
"""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.spatial import ConvexHull, cKDTree

from fepre import sdf

RNG = np.random.default_rng(20261122)


@pytest.fixture(autouse=True)
def _reseed():
    """Every test sees the same random points, whatever ran before it."""
    RNG.bit_generator.state = np.random.default_rng(20261122).bit_generator.state


def around(model, count=4000, margin=0.3, rng=RNG):
    """Random points in the model's bounds grown by ``margin`` times their size."""
    lo, hi = np.array(model.bounds[0]), np.array(model.bounds[1])
    pad = margin * (hi - lo)
    return rng.uniform(lo - pad, hi + pad, size=(count, 3))


def near(surface, count=3000, scale=0.06, rng=RNG):
    """Points close to surface samples (both sides), i.e. near faces, edges and corners."""
    picks = surface[rng.integers(0, len(surface), count)]
    return picks + rng.normal(scale=scale, size=picks.shape)


def check_against_cloud(model, surface, inside, points, spacing):
    """Model values vs the signed distance to the point cloud ``surface``.

    Keep ``points`` near the surface: a k-d tree query far from a dense surface cloud visits
    (distance / spacing)**2 points.
    """
    cloud, _ = cKDTree(surface).query(points)
    values = model(points)
    assert np.all(np.abs(values) <= cloud + 1e-9), "a value exceeds the distance to a surface point"
    assert np.all(cloud - np.abs(values) <= spacing), "a value falls short of the distance"
    sure = cloud > spacing
    np.testing.assert_array_equal(values[sure] < 0, inside(points[sure]))


# ---------------------------------------------------------------------------- closed forms
def box_reference(points, lo, hi):
    nearest = np.clip(points, lo, hi)
    outside = np.linalg.norm(points - nearest, axis=1)
    depth = np.minimum(points - lo, hi - points).min(axis=1)
    return np.where(depth > 0, -depth, outside)


def cylinder_reference(points, radius, height, center):
    d = points - center
    r = np.hypot(d[:, 0], d[:, 1])
    z = d[:, 2]
    nr, nz = np.clip(r, 0, radius), np.clip(z, -height / 2, height / 2)
    outside = np.hypot(r - nr, z - nz)
    depth = np.minimum(radius - r, height / 2 - np.abs(z))
    return np.where(depth > 0, -depth, outside)


def segment_distance(points, a, b):
    e = b - a
    t = np.clip((points - a) @ e / (e @ e), 0, 1)
    return np.linalg.norm(points - (a + t[:, None] * e), axis=1)


@given(
    size=st.tuples(*[st.floats(0.05, 5.0)] * 3),
    center=st.tuples(*[st.floats(-3.0, 3.0)] * 3),
    seed=st.integers(0, 2**16),
)
@settings(max_examples=40, deadline=None)
def test_box_is_exact_everywhere_including_edges_and_corners(size, center, seed):
    rng = np.random.default_rng(seed)
    size, center = np.array(size), np.array(center)
    model = sdf.box(size, center)
    lo, hi = center - size / 2, center + size / 2
    corners = np.array(np.meshgrid(*zip(lo, hi), indexing="ij")).reshape(3, -1).T
    points = np.vstack(
        [
            around(model, 500, rng=rng),
            np.repeat(corners, 40, axis=0) + rng.normal(scale=0.1 * size.min(), size=(320, 3)),
            rng.uniform(lo, hi, size=(200, 3)),
        ]
    )
    np.testing.assert_allclose(model(points), box_reference(points, lo, hi), rtol=0, atol=1e-12)


def test_box_scalar_size_is_a_cube_and_corner_distance_is_euclidean():
    cube = sdf.box(2.0, center=(1, 1, 1))
    assert cube.bounds == ((0.0, 0.0, 0.0), (2.0, 2.0, 2.0))
    assert cube([3.0, 4.0, 2.0 + 12.0]) == pytest.approx(np.sqrt(1 + 4 + 144))
    assert cube([1.0, 1.0, 1.0]) == pytest.approx(-1.0)


@given(
    radius=st.floats(0.05, 3.0),
    height=st.floats(0.05, 3.0),
    center=st.tuples(*[st.floats(-2.0, 2.0)] * 3),
    seed=st.integers(0, 2**16),
)
@settings(max_examples=40, deadline=None)
def test_cylinder_is_exact_including_rims(radius, height, center, seed):
    rng = np.random.default_rng(seed)
    center = np.array(center)
    model = sdf.cylinder(radius, height, center)
    angle = rng.uniform(0, 2 * np.pi, 400)
    rims = center + np.column_stack(
        [radius * np.cos(angle), radius * np.sin(angle), height / 2 * rng.choice([-1, 1], 400)]
    )
    points = np.vstack([around(model, 800, rng=rng), rims + rng.normal(scale=0.1 * min(radius, height), size=rims.shape)])
    np.testing.assert_allclose(model(points), cylinder_reference(points, radius, height, center), atol=1e-12)


def test_cylinder_is_centred_on_center_in_z():
    rod = sdf.cylinder(radius=0.5, height=2.0, center=(1, 2, 3))
    assert rod.bounds == ((0.5, 1.5, 2.0), (1.5, 2.5, 4.0))
    assert rod([1.0, 2.0, 4.5]) == pytest.approx(0.5)


def test_sphere_matches_the_closed_form():
    model = sdf.sphere(0.7, center=(0.1, -0.3, 0.2))
    points = around(model)
    reference = np.linalg.norm(points - [0.1, -0.3, 0.2], axis=1) - 0.7
    np.testing.assert_allclose(model(points), reference, atol=1e-14)


@given(
    a=st.tuples(*[st.floats(-2.0, 2.0)] * 3),
    b=st.tuples(*[st.floats(-2.0, 2.0)] * 3),
    radius=st.floats(0.05, 1.0),
)
@settings(max_examples=30, deadline=None)
def test_capsule_is_the_distance_to_its_segment_minus_radius(a, b, radius):
    a, b = np.array(a), np.array(b)
    if np.linalg.norm(b - a) < 1e-3:
        return
    model = sdf.capsule(a, b, radius)
    points = around(model, 600)
    np.testing.assert_allclose(model(points), segment_distance(points, a, b) - radius, atol=1e-12)


def test_capsule_surface_cloud():
    a, b, radius = np.array([0.0, 0.0, 0.0]), np.array([1.0, 0.5, 0.2]), 0.3
    model = sdf.capsule(a, b, radius)
    axis = (b - a) / np.linalg.norm(b - a)
    u = np.cross(axis, [0, 0, 1.0])
    u /= np.linalg.norm(u)
    v = np.cross(axis, u)
    t, phi = np.meshgrid(np.linspace(0, 1, 200), np.linspace(0, 2 * np.pi, 300, endpoint=False), indexing="ij")
    side = a + t.reshape(-1, 1) * (b - a) + radius * (np.cos(phi).reshape(-1, 1) * u + np.sin(phi).reshape(-1, 1) * v)
    directions = RNG.normal(size=(60_000, 3))
    directions /= np.linalg.norm(directions, axis=1)[:, None]
    ends = np.where(((directions @ axis) < 0)[:, None], a + radius * directions, b + radius * directions)
    surface = np.vstack([side, ends])
    points = np.vstack([around(model, 500), near(surface)])
    inside = lambda p: segment_distance(p, a, b) < radius  # noqa: E731
    check_against_cloud(model, surface, inside, points, spacing=0.01)


def segment_distance_2d(points, a, b):
    a, b = np.asarray(a, float), np.asarray(b, float)
    e = b - a
    t = np.clip((points - a) @ e / (e @ e), 0, 1)
    return np.linalg.norm(points - (a + t[:, None] * e), axis=1)


@given(
    radius=st.floats(0.05, 3.0),
    height=st.floats(0.05, 3.0),
    center=st.tuples(*[st.floats(-2.0, 2.0)] * 3),
    seed=st.integers(0, 2**16),
)
@settings(max_examples=40, deadline=None)
def test_cone_matches_the_distance_to_its_meridian_triangle(radius, height, center, seed):
    # In the half-plane (r, h) the cone is the triangle (0, 0), (radius, 0), (0, height) whose
    # edge on the axis is not a surface: the distance is to the slant and base edges only.
    rng = np.random.default_rng(seed)
    model = sdf.cone(radius, height, center)
    d = around(model, 800, rng=rng) - center
    meridian = np.column_stack([np.hypot(d[:, 0], d[:, 1]), d[:, 2]])
    distance = np.minimum(
        segment_distance_2d(meridian, (0, height), (radius, 0)), segment_distance_2d(meridian, (0, 0), (radius, 0))
    )
    inside = (meridian[:, 1] > 0) & (meridian[:, 0] < radius * (1 - meridian[:, 1] / height))
    np.testing.assert_allclose(model(d + center), np.where(inside, -distance, distance), atol=1e-12)


@given(
    major=st.floats(0.2, 3.0),
    ratio=st.floats(0.01, 0.99),
    center=st.tuples(*[st.floats(-2.0, 2.0)] * 3),
    seed=st.integers(0, 2**16),
)
@settings(max_examples=30, deadline=None)
def test_torus_is_the_distance_to_its_core_circle_minus_the_tube_radius(major, ratio, center, seed):
    model = sdf.torus(major, major * ratio, center)
    d = around(model, 500, rng=np.random.default_rng(seed)) - center
    # Nearest point of the core circle: the radial projection onto radius ``major`` at z = 0.
    direction = d[:, :2] / np.linalg.norm(d[:, :2], axis=1)[:, None]
    core = np.column_stack([major * direction, np.zeros(len(d))])
    np.testing.assert_allclose(model(d + center), np.linalg.norm(d - core, axis=1) - major * ratio, atol=1e-12)


@given(radii=st.tuples(*[st.floats(0.05, 3.0)] * 3), seed=st.integers(0, 2**16))
@settings(max_examples=20, deadline=None)
def test_ellipsoid_bound_holds_for_random_radii(radii, seed):
    rng = np.random.default_rng(seed)
    radii = np.array(radii)
    model = sdf.ellipsoid(radii)
    surface = ellipsoid_surface(radii, 120)
    p = np.vstack([around(model, 1000, margin=1.0, rng=rng), surface[rng.integers(0, len(surface), 500)] * rng.uniform(0.5, 1.5, (500, 1))])
    q = p + rng.normal(scale=0.1 * radii.max(), size=p.shape)
    values = model(p)
    assert np.all(np.abs(values - model(q)) <= np.linalg.norm(p - q, axis=1) * (1 + 1e-12))
    cloud, _ = cKDTree(surface).query(p)  # never below the true distance
    assert np.all(np.abs(values) <= cloud + 1e-9)
    np.testing.assert_array_equal(values < 0, np.sum((p / radii) ** 2, axis=1) < 1)


def torus_surface(major, minor, n=1200, m=400):
    angles = dict(endpoint=False)
    theta, phi = np.meshgrid(np.linspace(0, 2 * np.pi, n, **angles), np.linspace(0, 2 * np.pi, m, **angles), indexing="ij")
    ring = major + minor * np.cos(phi)
    return np.column_stack([(ring * np.cos(theta)).ravel(), (ring * np.sin(theta)).ravel(), (minor * np.sin(phi)).ravel()])


def test_torus_matches_closed_form_and_surface_cloud():
    major, minor = 1.0, 0.3
    model = sdf.torus(major, minor, center=(0.2, 0.0, -0.1))
    surface = torus_surface(major, minor) + [0.2, 0.0, -0.1]
    points = np.vstack([around(model, 500), near(surface)])
    d = points - [0.2, 0.0, -0.1]
    closed = np.hypot(np.hypot(d[:, 0], d[:, 1]) - major, d[:, 2]) - minor
    np.testing.assert_allclose(model(points), closed, atol=1e-13)
    check_against_cloud(model, surface, lambda p: closed_inside(p, major, minor), points, spacing=0.01)


def closed_inside(points, major, minor):
    d = points - [0.2, 0.0, -0.1]
    return np.hypot(np.hypot(d[:, 0], d[:, 1]) - major, d[:, 2]) < minor


def test_cone_surface_cloud_and_apex():
    radius, height = 1.0, 1.5
    model = sdf.cone(radius, height, center=(0.0, 0.0, 0.5))
    assert model.bounds == ((-1.0, -1.0, 0.5), (1.0, 1.0, 2.0))
    assert model([0.0, 0.0, 2.5]) == pytest.approx(0.5)  # above the apex
    assert model([0.0, 0.0, 0.0]) == pytest.approx(0.5)  # below the base centre
    # No repeated points (the apex, the base centre, the seam): they slow the k-d tree down.
    t, phi = np.meshgrid(np.linspace(0, 1, 300)[1:], np.linspace(0, 2 * np.pi, 500, endpoint=False), indexing="ij")
    t, phi = t.ravel(), phi.ravel()
    side = np.column_stack([radius * t * np.cos(phi), radius * t * np.sin(phi), height * (1 - t)])
    base = np.column_stack([radius * t * np.cos(phi), radius * t * np.sin(phi), 0 * t])
    surface = np.vstack([side, base, [[0, 0, height], [0, 0, 0]]]) + [0, 0, 0.5]

    def inside(p):
        z = p[:, 2] - 0.5
        return (z > 0) & (np.hypot(p[:, 0], p[:, 1]) < radius * (1 - z / height))

    points = np.vstack([around(model, 500), near(surface)])
    check_against_cloud(model, surface, inside, points, spacing=0.015)


def box_surface(lo, hi, n=150):
    """Dense points on the six faces of the box [lo, hi]."""
    s = np.linspace(0, 1, n)
    a, b = (g.ravel() for g in np.meshgrid(s, s, indexing="ij"))
    faces = []
    for axis in range(3):
        i, j = [k for k in range(3) if k != axis]
        for value in (lo[axis], hi[axis]):
            face = np.empty((a.size, 3))
            face[:, axis] = value
            face[:, i] = lo[i] + a * (hi[i] - lo[i])
            face[:, j] = lo[j] + b * (hi[j] - lo[j])
            faces.append(face)
    return np.vstack(faces)


def test_rounded_box_is_the_inner_box_distance_minus_radius_and_fits_its_bounds():
    size, radius = np.array([2.0, 1.0, 1.5]), 0.3
    model = sdf.rounded_box(size, radius, center=(0.5, 0, 0))
    assert model.bounds == ((-0.5, -0.5, -0.75), (1.5, 0.5, 0.75))
    inner_lo, inner_hi = np.array([0.5, 0, 0]) - size / 2 + radius, np.array([0.5, 0, 0]) + size / 2 - radius
    points = around(model)
    np.testing.assert_allclose(model(points), box_reference(points, inner_lo, inner_hi) - radius, atol=1e-12)
    # The surface: inner box surface points pushed out by radius along the outward direction.
    seeds = around(model, 150_000)
    seeds = seeds[box_reference(seeds, inner_lo, inner_hi) > 1e-6]
    foot = np.clip(seeds, inner_lo, inner_hi)
    direction = (seeds - foot) / np.linalg.norm(seeds - foot, axis=1)[:, None]
    surface = np.vstack([foot + radius * direction, box_surface(inner_lo - radius, inner_hi + radius, 120)])
    surface = surface[np.abs(box_reference(surface, inner_lo, inner_hi) - radius) < 1e-9]
    check_against_cloud(
        model, surface, lambda p: box_reference(p, inner_lo, inner_hi) < radius, near(surface), spacing=0.03
    )


def hull_distance(points, vertices):
    """Signed distance to the convex hull of ``vertices``: an independent reference.

    Inside: minus the distance to the nearest face plane. Outside: the distance to the nearest
    point of any face triangle (its plane where the foot lies inside it, else its edges).
    """
    hull = ConvexHull(vertices)
    heights = points @ hull.equations[:, :3].T + hull.equations[:, 3]
    squared = np.full(len(points), np.inf)
    for (a, b, c), height in zip(vertices[hull.simplices], heights.T):
        normal = np.cross(b - a, c - a)
        normal /= np.linalg.norm(normal)
        foot = points - np.outer((points - a) @ normal, normal)
        inside_face = np.ones(len(points), dtype=bool)
        for start, end in ((a, b), (b, c), (c, a)):
            inside_face &= np.cross(end - start, foot - start) @ normal >= 0
            squared = np.minimum(squared, segment_distance(points, start, end) ** 2)
        squared = np.where(inside_face, np.minimum(squared, height**2), squared)
    largest = heights.max(axis=1)
    return np.where(largest > 0, np.sqrt(squared), largest), hull


@pytest.mark.parametrize(
    "model",
    [sdf.tetrahedron(1.0, center=(0.0, -0.2, 0.1)), sdf.tetrahedron(2.5), sdf.octahedron(1.2, center=(0.1, 0.2, 0.3))],
    ids=repr,
)
def test_regular_polyhedra_match_the_hull_distance_and_a_face_cloud(model):
    vertices = model.vertices
    center = vertices.mean(axis=0)
    size = np.ptp(vertices, axis=0).max()
    points = np.vstack(
        [
            around(model, 20_000),
            center + RNG.normal(scale=0.4 * size, size=(5000, 3)),
            vertices[RNG.integers(0, len(vertices), 3000)] + RNG.normal(scale=0.1 * size, size=(3000, 3)),
        ]
    )
    reference, hull = hull_distance(points, vertices)
    np.testing.assert_allclose(model(points), reference, atol=1e-12)
    u, v = (g.ravel() for g in np.meshgrid(np.linspace(0, 1, 250), np.linspace(0, 1, 250), indexing="ij"))
    keep = u + v <= 1
    u, v = u[keep, None], v[keep, None]
    surface = np.vstack([vertices[a] + u * (vertices[b] - vertices[a]) + v * (vertices[c] - vertices[a]) for a, b, c in hull.simplices])

    def inside(p):
        return np.all(p @ hull.equations[:, :3].T + hull.equations[:, 3] < 0, axis=1)

    check_against_cloud(model, surface, inside, np.vstack([around(model, 500), near(surface)]), spacing=0.01 * size)


def test_regular_polyhedra_sizes():
    tet = sdf.tetrahedron(3.0)
    assert tet([0.0, 0.0, 0.0]) == pytest.approx(-1.0)  # inradius is a third of the circumradius
    assert tet([np.sqrt(3.0)] * 3) == pytest.approx(0.0, abs=1e-12)  # a vertex
    assert np.linalg.norm(tet.vertices[0] - tet.vertices[1]) == pytest.approx(3.0 * np.sqrt(8.0 / 3.0))
    octa = sdf.octahedron(2.0)
    assert octa([0.0, 0.0, 0.0]) == pytest.approx(-2.0 / np.sqrt(3.0))
    assert octa([3.0, 0.0, 0.0]) == pytest.approx(1.0)


def ellipsoid_surface(radii, n=400):
    theta, phi = np.meshgrid(np.linspace(0, np.pi, n)[1:-1], np.linspace(0, 2 * np.pi, 2 * n, endpoint=False), indexing="ij")
    sides = np.column_stack(
        [
            radii[0] * (np.sin(theta) * np.cos(phi)).ravel(),
            radii[1] * (np.sin(theta) * np.sin(phi)).ravel(),
            radii[2] * np.cos(theta).ravel(),
        ]
    )
    return np.vstack([sides, [[0, 0, radii[2]], [0, 0, -radii[2]]]])


def test_ellipsoid_is_a_lipschitz_lower_bound_with_the_right_sign():
    radii = np.array([1.5, 0.6, 0.3])
    model = sdf.ellipsoid(radii, center=(0.2, 0.0, 0.0))
    assert model.exact is False
    surface = ellipsoid_surface(radii) + [0.2, 0, 0]
    points = np.vstack([around(model, 1000, margin=2.0), near(surface)])
    cloud, _ = cKDTree(surface).query(points)
    values = model(points)
    assert np.all(np.abs(values) <= cloud + 1e-9)
    inside = np.sum(((points - [0.2, 0, 0]) / radii) ** 2, axis=1) < 1
    sure = cloud > 0.01
    np.testing.assert_array_equal(values[sure] < 0, inside[sure])
    # Not hopelessly loose: along the smallest axis and far away it is (nearly) exact.
    assert model([0.2, 0.0, 0.0]) == pytest.approx(-0.3)
    assert model([20.2, 0.0, 0.0]) == pytest.approx(18.5)


# ---------------------------------------------------------------------------- all primitives
def all_primitives():
    return {
        "sphere": sdf.sphere(0.8, center=(0.1, 0.0, -0.2)),
        "box": sdf.box((1.0, 2.0, 0.5), center=(0.2, -0.1, 0.0)),
        "rounded_box": sdf.rounded_box((1.0, 2.0, 0.5), 0.2),
        "cylinder": sdf.cylinder(0.6, 1.5, center=(0.0, 0.3, 0.1)),
        "capsule": sdf.capsule((0, 0, 0), (1, 1, 0.5), 0.3),
        "cone": sdf.cone(0.8, 1.2, center=(0, 0, -0.5)),
        "torus": sdf.torus(1.0, 0.3),
        "ellipsoid": sdf.ellipsoid((1.2, 0.5, 0.4)),
        "plane": sdf.plane((1, 2, -1), (0.1, 0.2, 0.3)),
        "slab": sdf.slab((0, 1, 1), 0.4, (0, 0, 0.2)),
        "tetrahedron": sdf.tetrahedron(1.0),
        "octahedron": sdf.octahedron(0.9, center=(0, 0.1, 0)),
    }


PRIMITIVES = all_primitives()
EXACT = {name for name in PRIMITIVES if name != "ellipsoid"}


def sample_points(model, count=3000):
    if model.bounds is None:
        return RNG.uniform(-2, 2, size=(count, 3))
    return around(model, count)


@pytest.mark.parametrize("name", sorted(PRIMITIVES))
def test_exact_flag_lipschitz_and_bounds(name):
    model = PRIMITIVES[name]
    assert model.exact == (name in EXACT)
    p = sample_points(model, 20_000)
    q = p + RNG.normal(scale=0.2, size=p.shape)
    ratio = np.abs(model(p) - model(q)) / np.linalg.norm(p - q, axis=1)
    assert ratio.max() <= 1 + 1e-9
    if model.bounds is None:
        assert name in ("plane", "slab")
        return
    lo, hi = np.array(model.bounds[0]), np.array(model.bounds[1])
    grown = around(model, 60_000, margin=0.5)
    inside = grown[model(grown) < 0]
    assert np.all(inside >= lo - 1e-12) and np.all(inside <= hi + 1e-12)
    # The bounds are tight: the negative region reaches close to every face of the box.
    assert np.all(inside.min(axis=0) < lo + 0.15 * (hi - lo)) and np.all(inside.max(axis=0) > hi - 0.15 * (hi - lo))


@pytest.mark.parametrize("name", sorted(PRIMITIVES))
def test_grid_sampling_matches_point_evaluation_and_keeps_float32(name):
    model = PRIMITIVES[name]
    x, y, z = np.linspace(-1.3, 1.4, 21), np.linspace(-1.2, 1.1, 18), np.linspace(-1.0, 1.2, 15)
    grid = model.values_on_axes(x, y, z, dtype=np.float64)
    zz, yy, xx = np.meshgrid(z, y, x, indexing="ij")
    points = np.column_stack([xx.ravel(), yy.ravel(), zz.ravel()])
    np.testing.assert_allclose(grid.ravel(), model(points), atol=1e-12)
    single = model.values_on_axes(x, y, z)
    assert single.dtype == np.float32
    np.testing.assert_allclose(single, grid, atol=1e-5)
    # The arithmetic itself stays in float32 (no silent promotion by float64 constants).
    axes32 = [a.astype(np.float32) for a in (x[None, None, :], y[None, :, None], z[:, None, None])]
    assert model._values(*axes32).dtype == np.float32
    values, gradient = model._values_and_gradient(*axes32)
    assert values.dtype == np.float32 and all(np.asarray(g).dtype == np.float32 for g in gradient)


ANALYTIC = ["sphere", "box", "rounded_box", "cylinder", "capsule", "cone", "torus", "ellipsoid", "plane", "slab"]


@pytest.mark.parametrize("name", sorted(PRIMITIVES))
def test_gradient_matches_finite_differences(name):
    model = PRIMITIVES[name]
    assert model.analytic_gradient == (name in ANALYTIC)
    points = sample_points(model, 2000)
    gradient = model.gradient(points)
    step = 1e-6
    fd = np.column_stack(
        [(model(points + step * e) - model(points - step * e)) / (2 * step) for e in np.eye(3)]
    )
    # Exclude the measure-zero kinks (medial axis) where differences straddle two branches.
    smooth = np.abs(np.linalg.norm(fd, axis=1) - np.linalg.norm(gradient, axis=1)) < 1e-4
    assert smooth.mean() > 0.97
    np.testing.assert_allclose(gradient[smooth], fd[smooth], atol=2e-5)
    if model.exact:
        # Unit length everywhere for analytic gradients; central differences (the polyhedra)
        # straddling a kink of the distance are shorter, so only the smooth points count there.
        checked = gradient if model.analytic_gradient else gradient[smooth]
        np.testing.assert_allclose(np.linalg.norm(checked, axis=1), 1.0, atol=1e-6)


@pytest.mark.parametrize("name", sorted(PRIMITIVES))
def test_project_lands_on_the_zero_set(name):
    model = PRIMITIVES[name]
    points = sample_points(model, 2000)
    values = model(points)
    points = points[np.abs(values) < 0.3]
    landed = model.project(points, iterations=20)
    assert np.abs(model(landed)).max() < 1e-8


def test_plane_and_slab_signs_and_normalisation():
    ground = sdf.plane(normal=(0, 0, 5), point=(0, 0, 1))
    assert ground([0.0, 0.0, 0.0]) == pytest.approx(-1.0) and ground([3.0, 2.0, 4.0]) == pytest.approx(3.0)
    tilted = sdf.plane(normal=(1, 1, 0))
    assert tilted([1.0, 1.0, 7.0]) == pytest.approx(np.sqrt(2.0))
    layer = sdf.slab(normal=(1, 0, 0), thickness=0.5, center=(2, 0, 0))
    assert layer([2.1, 9.0, -9.0]) == pytest.approx(-0.15) and layer([0.0, 0.0, 0.0]) == pytest.approx(1.75)
    assert ground.bounds is None and layer.bounds is None


# ---------------------------------------------------------------------------- repr and bad input
def test_repr_names_each_primitive_and_its_parameters():
    assert repr(sdf.box((1, 2, 3))) == "box(size=(1, 2, 3), center=(0, 0, 0))"
    assert repr(sdf.rounded_box(2, 0.25)) == "rounded_box(size=(2, 2, 2), center=(0, 0, 0), radius=0.25)"
    assert repr(sdf.cylinder(0.5, 2, center=(1, 0, 0))) == "cylinder(radius=0.5, height=2, center=(1, 0, 0))"
    assert repr(sdf.torus(2, 0.5)) == "torus(major_radius=2, minor_radius=0.5, center=(0, 0, 0))"
    assert repr(sdf.capsule((0, 0, 0), (1, 0, 0), 0.2)) == "capsule(a=(0, 0, 0), b=(1, 0, 0), radius=0.2)"
    assert repr(sdf.plane()) == "plane(normal=(0, 0, 1), point=(0, 0, 0))"
    assert repr(sdf.tetrahedron()) == "tetrahedron(radius=1, center=(0, 0, 0))"
    for name, model in PRIMITIVES.items():
        assert repr(model).startswith(name + "(")


BAD = [
    (lambda: sdf.sphere(0), ValueError, "radius"),
    (lambda: sdf.sphere(float("nan")), ValueError, "radius"),
    (lambda: sdf.sphere("1"), TypeError, "radius"),
    (lambda: sdf.box((1, 2)), ValueError, "size"),
    (lambda: sdf.box((1, -2, 3)), ValueError, "size"),
    (lambda: sdf.box((1, 0, 3)), ValueError, "size"),
    (lambda: sdf.box((1, np.inf, 3)), ValueError, "size"),
    (lambda: sdf.box(1, center=(0, 0)), ValueError, "center"),
    (lambda: sdf.box(1, center=(0, 0, np.nan)), ValueError, "center"),
    (lambda: sdf.box([[1, 2], [3]]), ValueError, "size"),
    (lambda: sdf.rounded_box((1, 1, 1), 0.6), ValueError, "radius"),
    (lambda: sdf.rounded_box((1, 1, 1), 0), ValueError, "radius"),
    (lambda: sdf.cylinder(-1, 1), ValueError, "radius"),
    (lambda: sdf.cylinder(1, 0), ValueError, "height"),
    (lambda: sdf.cylinder(1, 1, center=(0, 0, 0, 0)), ValueError, "center"),
    (lambda: sdf.capsule((1, 2, 3), (1, 2, 3), 0.5), ValueError, "a and b"),
    (lambda: sdf.capsule((0, 0, 0), (0, 0, 1e-157), 1.0), ValueError, "a and b"),
    (lambda: sdf.capsule((1, 2), (1, 2, 3), 0.5), ValueError, "a must"),
    (lambda: sdf.capsule((0, 0, 0), (1, 2, 3), -0.5), ValueError, "radius"),
    (lambda: sdf.cone(0, 1), ValueError, "radius"),
    (lambda: sdf.cone(1, -1), ValueError, "height"),
    (lambda: sdf.torus(1, 1), ValueError, "minor_radius"),
    (lambda: sdf.torus(0, 0.5), ValueError, "major_radius"),
    (lambda: sdf.ellipsoid((1, 0, 1)), ValueError, "radii"),
    (lambda: sdf.ellipsoid((1, 1)), ValueError, "radii"),
    (lambda: sdf.plane((0, 0, 0)), ValueError, "normal"),
    (lambda: sdf.plane((0, 0, 1), point=(0, 0)), ValueError, "point"),
    (lambda: sdf.slab((0, 0, 0), 1), ValueError, "normal"),
    (lambda: sdf.slab((0, 0, 1), 0), ValueError, "thickness"),
    (lambda: sdf.tetrahedron(0), ValueError, "radius"),
    (lambda: sdf.octahedron(1, center=(0, 0)), ValueError, "center"),
    (lambda: sdf.octahedron(None), TypeError, "radius"),
]


@pytest.mark.parametrize("make, error, fragment", BAD)
def test_bad_parameters_are_refused_naming_the_parameter(make, error, fragment):
    with pytest.raises(error, match=fragment):
        make()


def test_docstring_examples_run():
    import doctest
    import importlib

    names = ["solids", "radial", "halfspaces", "polyhedra", "shapes2d", "polygon", "extrusions"]
    for name in names:
        result = doctest.testmod(importlib.import_module(f"fepre.sdf.{name}"))
        assert result.attempted > 0 and result.failed == 0, name


def test_cone_gradient_next_to_its_side_and_base_is_their_normal():
    """Issue 33: points within 1e-15 of a cone's side (seeds projected onto a drafted boss) got
    the direction of a round-off offset as gradient, (0.24, -0.97) in (r, z) for the side's
    (0.98, 0.20): a ray along it measured a wall 0.095 thick in a boss 10 across."""
    cone = sdf.cone(10.0, 50.0, center=(0.0, 0.0, 6.0))
    rng = np.random.default_rng(3)
    angle = rng.uniform(0, 2 * np.pi, 400)
    z = rng.uniform(6.5, 40.0, 400)
    radius = 10.0 * (1.0 - (z - 6.0) / 50.0) * (1.0 + rng.choice([-1, 0, 1], 400) * 1e-16)
    side = np.stack([radius * np.cos(angle), radius * np.sin(angle), z], axis=1)
    values, gradient = cone.value_and_gradient(side)
    assert np.abs(values).max() < 1e-13
    slant = np.hypot(10.0, 50.0)
    normal = np.stack([50.0 / slant * np.cos(angle), 50.0 / slant * np.sin(angle), np.full(400, 10.0 / slant)], axis=1)
    assert np.einsum("ij,ij->i", gradient, normal).min() > 1.0 - 1e-12
    base = np.stack([rng.uniform(-5, 5, 50), rng.uniform(-5, 5, 50), 6.0 + rng.choice([-1e-15, 0.0, 1e-15], 50)], axis=1)
    _, gradient = cone.value_and_gradient(base)
    assert np.allclose(gradient, [0.0, 0.0, -1.0], atol=1e-12)
    # away from the surface and at the rim the offset's direction stays the gradient
    _, gradient = cone.value_and_gradient(np.array([[13.0, 0.0, 3.0]]))  # nearest to the rim (10, 0, 6)
    assert np.allclose(gradient[0], [np.sqrt(0.5), 0.0, -np.sqrt(0.5)])
