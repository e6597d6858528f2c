"""Booleans, transforms and deformations against hand formulas and brute force."""

from __future__ import annotations

import itertools

import numpy as np
import pytest

from fepre import sdf
from fepre.sdf.transforms import Affine


@pytest.fixture
def rng():
    return np.random.default_rng(7)


def ball(p, centre, radius):
    return np.linalg.norm(p - np.asarray(centre), axis=1) - radius


def box_distance(p, half):
    q = np.abs(p) - half
    return np.linalg.norm(np.maximum(q, 0), axis=1) + np.minimum(q.max(axis=1), 0)


A = sdf.sphere(1.0)
B = sdf.sphere(0.8, center=(1.2, 0.0, 0.0))
C = sdf.box((1.0, 1.0, 1.0), center=(0.0, 0.9, 0.0))


# ---------------------------------------------------------------------- booleans
def test_sharp_booleans_match_min_and_max(rng):
    p = rng.uniform(-2.5, 2.5, (2000, 3))
    a, b, c = A(p), B(p), C(p)
    np.testing.assert_allclose((A | B | C)(p), np.minimum(np.minimum(a, b), c))
    np.testing.assert_allclose((A & B)(p), np.maximum(a, b))
    np.testing.assert_allclose((A - B - C)(p), np.maximum(a, -np.minimum(b, c)))
    np.testing.assert_allclose((-A)(p), -a)
    np.testing.assert_allclose(sdf.difference(A, B, C)(p), (A - B - C)(p))


def test_smooth_union_matches_the_polynomial_blend(rng):
    p = rng.uniform(-2.5, 2.5, (2000, 3))
    a, b, k = A(p), B(p), 0.4
    h = np.clip(0.5 + 0.5 * (b - a) / k, 0, 1)
    expected = b * (1 - h) + a * h - k * h * (1 - h)
    np.testing.assert_allclose(sdf.union(A, B, k=k)(p), expected, atol=1e-15)
    # The blend lies between min(a, b) - k/4 and min(a, b).
    assert np.all(expected <= np.minimum(a, b) + 1e-15)
    assert np.all(expected >= np.minimum(a, b) - k / 4 - 1e-15)
    np.testing.assert_allclose(sdf.intersection(A, B, k=k)(p), -sdf.union(-A, -B, k=k)(p), atol=1e-15)
    np.testing.assert_allclose(sdf.difference(A, B, k=k)(p), sdf.intersection(A, -B, k=k)(p), atol=1e-15)


@pytest.mark.parametrize("k", [0.2, 0.6])
def test_smooth_booleans_move_coplanar_faces_by_a_quarter_of_k(k):
    # What the docstrings of union, intersection and difference state: where a == b the smooth
    # minimum is min - k/4, so faces the operands share in one plane move by exactly k/4.
    bar = sdf.box((2, 1, 1), center=(1, 0.5, 0.5))
    post = sdf.box((1, 2, 1), center=(0.5, 1, 0.5))
    joined = sdf.union(bar, post, k=k)
    face = np.array([[0.0, 0.5, 0.5], [0.5, 0.0, 0.5], [0.5, 0.5, 1.0]])  # shared faces, overlap
    normal = np.array([[-1.0, 0, 0], [0, -1.0, 0], [0, 0, 1.0]])
    np.testing.assert_allclose(joined(face), -k / 4, atol=1e-12)
    np.testing.assert_allclose(joined(face + k / 4 * normal), 0.0, atol=1e-12)
    common = sdf.intersection(sdf.box(2), sdf.box((2, 3, 3)), k=k)  # the x faces shared
    np.testing.assert_allclose(common([[1 - k / 4, 0, 0]]), 0.0, atol=1e-12)
    cut = sdf.difference(sdf.box(2), sdf.box((3, 3, 1), center=(0, 0, 1.5)), k=k)  # on the top
    np.testing.assert_allclose(cut([[0.3, 0.3, 1 - k / 4]]), 0.0, atol=1e-12)


def test_boolean_bounds():
    assert (A | B).bounds == ((-1.0, -1.0, -1.0), (2.0, 1.0, 1.0))
    np.testing.assert_allclose((A & B).bounds, ((0.4, -0.8, -0.8), (1.0, 0.8, 0.8)))
    assert (A - B).bounds == A.bounds
    assert (-A).bounds is None and (A | -B).bounds is None
    smooth = sdf.union(A, B, k=0.4)
    np.testing.assert_allclose(smooth.bounds, ((-1.1, -1.1, -1.1), (2.1, 1.1, 1.1)))


def test_nary_union_is_flat_and_evaluates_each_child_once(rng):
    calls = []

    class Counting(type(A)):
        def _values(self, *coords):
            calls.append(self)
            return super()._values(*coords)

    shapes = [Counting(0.3, np.array([float(i), 0.0, 0.0])) for i in range(5)]
    model = shapes[0] | shapes[1] | shapes[2] | shapes[3] | shapes[4]
    assert len(model.children) == 5 and sum(1 for _ in model.walk()) == 6
    model(rng.uniform(-1, 5, (100, 3)))
    assert len(calls) == 5
    assert len(sdf.union(*shapes).children) == 5
    assert len((A - B - C).children) == 3


def test_union_of_disjoint_exact_shapes_is_exact(rng):
    far = sdf.sphere(0.5, center=(3.0, 0.0, 0.0))
    both = A | far
    assert both.exact and not (A | B).exact and not (A & B).exact
    p = rng.uniform(-2, 4, (1000, 3))
    np.testing.assert_allclose(both(p), np.minimum(ball(p, (0, 0, 0), 1), ball(p, (3, 0, 0), 0.5)))
    assert (-A).exact and (-(-A)) is A


def test_boolean_gradients_match_finite_differences(rng):
    p = rng.uniform(-2, 2, (500, 3))
    for model in (A | B | C, A & B, A - B - C, sdf.union(A, B, k=0.3), sdf.difference(A, C, k=0.2), -A):
        _assert_gradient_matches_differences(model, p)


def _assert_gradient_matches_differences(model, p, step=1e-6, atol=1e-5):
    gradient = model.gradient(p)
    numeric = np.stack(
        [(model(p + step * e) - model(p - step * e)) / (2 * step) for e in np.eye(3)], axis=1
    )
    close = np.all(np.abs(gradient - numeric) < atol, axis=1)
    # Only points within a step of a crease may disagree.
    assert close.mean() > 0.995, repr(model)


# ---------------------------------------------------------------------- transforms
def test_transforms_match_hand_formulas(rng):
    p = rng.uniform(-3, 3, (1000, 3))
    np.testing.assert_allclose(A.translate((1, 2, 3))(p), ball(p, (1, 2, 3), 1.0))
    np.testing.assert_allclose(B.rotate(90)(p), ball(p, (0, 1.2, 0), 0.8), atol=1e-12)
    np.testing.assert_allclose(B.rotate(180, axis=(0, 1, 0), center=(1, 0, 0))(p), ball(p, (0.8, 0, 0), 0.8), atol=1e-12)
    np.testing.assert_allclose(A.scale(2)(p), ball(p, (0, 0, 0), 2.0), atol=1e-12)
    np.testing.assert_allclose(B.mirror((1, 0, 0))(p), ball(p, (-1.2, 0, 0), 0.8))
    np.testing.assert_allclose(B.mirror((1, 0, 0), point=(1, 0, 0))(p), ball(p, (0.8, 0, 0), 0.8), atol=1e-12)
    # Non-uniform scale: value = min|s| * f(p / s).
    stretched = A.scale((2, 1, 0.5))
    np.testing.assert_allclose(stretched(p), 0.5 * ball(p / [2, 1, 0.5], (0, 0, 0), 1.0))
    assert stretched.bounds == ((-2.0, -1.0, -0.5), (2.0, 1.0, 0.5)) and not stretched.exact


def test_general_affine_uses_the_smallest_singular_value(rng):
    matrix = np.array([[1.0, 0.5, 0, 0.2], [0, 1.5, 0, 0], [0.3, 0, 0.8, -1], [0, 0, 0, 1]])
    model = C.transform(matrix)
    p = rng.uniform(-3, 3, (1000, 3))
    inverse = np.linalg.inv(matrix)
    local = p @ inverse[:3, :3].T + inverse[:3, 3]
    sigma = np.linalg.svd(matrix[:3, :3], compute_uv=False).min()
    np.testing.assert_allclose(model(p), sigma * C(local), atol=1e-12)
    corners = np.array(list(itertools.product(*zip(*C.bounds)))) @ matrix[:3, :3].T + matrix[:3, 3]
    np.testing.assert_allclose(model.bounds, (corners.min(0), corners.max(0)))
    np.testing.assert_allclose(model(p), C.transform(matrix[:3, :3]).translate(matrix[:3, 3])(p), atol=1e-12)


def test_chained_transforms_collapse_into_one_node(rng):
    chain = C.translate((1, 0, 0)).rotate(30, axis=(1, 1, 0)).scale((1, 2, 1.5)).mirror((0, 0, 1)).rotate(10)
    assert isinstance(chain, Affine) and chain.children == (C,)
    assert sum(1 for _ in chain.walk()) == 2
    assert repr(chain).count("\n") == 1 and "translate(1, 0, 0) → rotate(30" in repr(chain)
    # The same steps as separate nodes give the same values.
    one_by_one = C
    for make in (
        lambda s: s.translate((1, 0, 0)),
        lambda s: s.rotate(30, axis=(1, 1, 0)),
        lambda s: s.scale((1, 2, 1.5)),
        lambda s: s.mirror((0, 0, 1)),
        lambda s: s.rotate(10),
    ):
        step = make(sdf.sphere(1.0))
        one_by_one = Affine(one_by_one, step.matrix, step.steps)
    assert sum(1 for _ in one_by_one.walk()) == 6
    p = rng.uniform(-3, 3, (1000, 3))
    # Collapsed: smallest singular value of the product, never below the product of the factors.
    assert chain.factor >= np.prod([n.factor for n in one_by_one.walk() if isinstance(n, Affine)]) - 1e-12
    inverse = np.linalg.inv(chain.matrix)
    local = p @ inverse[:3, :3].T + inverse[:3, 3]
    np.testing.assert_allclose(chain(p), chain.factor * C(local), atol=1e-12)
    assert np.array_equal(np.sign(chain(p)), np.sign(one_by_one(p)))
    assert C.translate((1, 2, 3)).translate((-1, -2, -3)) is C


def test_rigid_transforms_keep_exact_distances(rng):
    half = np.array([0.5, 0.8, 0.3])
    moved = sdf.box(2 * half).rotate(37, axis=(1, 2, 3)).translate((0.5, -0.2, 1.0)).mirror((1, 1, 0))
    assert moved.exact and sdf.box(2 * half).scale(1.7).exact and not sdf.box(2 * half).scale((1, 2, 1)).exact
    p = rng.uniform(-3, 3, (2000, 3))
    inverse = np.linalg.inv(moved.matrix)
    local = p @ inverse[:3, :3].T + inverse[:3, 3]
    np.testing.assert_allclose(moved(p), box_distance(local, half), atol=1e-12)
    np.testing.assert_allclose(sdf.box(2 * half).scale(1.7)(p), 1.7 * box_distance(p / 1.7, half), atol=1e-12)


def test_transform_gradients_match_finite_differences(rng):
    p = rng.uniform(-2, 2, (500, 3))
    matrix = [[1, 0.4, 0, 0], [0, 1.2, 0.1, 0.5], [0.2, 0, 0.7, 0], [0, 0, 0, 1]]
    for model in (C.rotate(40, axis=(1, 0, 1)).translate((0.1, 0.2, 0.3)), C.scale((1, 2, 0.5)), (A - C).transform(matrix)):
        _assert_gradient_matches_differences(model, p)


def test_2d_shapes_transform_and_combine_before_extrusion(rng):
    square = sdf.rectangle((2.0, 1.0), center=(0.5, 0.0)).rotate(90, (0.5, 0.0))
    assert square.dim == 2 and square.exact
    p = rng.uniform(-2, 2, (500, 2))
    expected = sdf.rectangle((1.0, 2.0), center=(0.5, 0.0))(p)
    np.testing.assert_allclose(square(p), expected, atol=1e-12)
    np.testing.assert_allclose(square.bounds, ((0.0, -1.0), (1.0, 1.0)), atol=1e-12)
    profile = sdf.rectangle((2.0, 1.0)) - sdf.circle(0.3)
    solid = sdf.extrude(profile.translate((1.0, 0.0)), 1.0)
    assert float(solid([1.0, 0.0, 0.0])) == pytest.approx(0.3)


def test_project_lands_on_the_zero_set_of_composite_models(rng):
    models = [
        (A | B) - C,
        sdf.union(A, B, k=0.3).rotate(20, axis=(1, 0, 0)),
        (C & A).scale((1, 1.5, 0.8)),
        A.shell(0.2) - sdf.box((3, 3, 1)).translate((0, 0, 1)),
    ]
    for model in models:
        lo, hi = np.asarray(model.bounds[0]), np.asarray(model.bounds[1])
        start = lo - 0.3 + rng.random((300, 3)) * (hi - lo + 0.6)
        projected = model.project(start, iterations=100)
        # Newton converges linearly only next to creases, hence the many iterations.
        assert np.max(np.abs(model(projected))) < 1e-9, repr(model)


# ---------------------------------------------------------------------- deformations
def test_offset_shell_and_elongate_match_hand_formulas(rng):
    p = rng.uniform(-3, 3, (1000, 3))
    a = ball(p, (0, 0, 0), 1.0)
    np.testing.assert_allclose(A.offset(0.5)(p), a - 0.5)
    assert A.offset(0.5).bounds == ((-1.5,) * 3, (1.5,) * 3)
    np.testing.assert_allclose(A.shell(0.25)(p), np.maximum(a, -a - 0.25))
    assert A.shell(0.25).bounds == A.bounds
    # Elongating a sphere by h along x gives a capsule of half-length h.
    h = 0.7
    np.testing.assert_allclose(A.elongate((h, 0, 0))(p), sdf.capsule((-h, 0, 0), (h, 0, 0), 1.0)(p), atol=1e-12)
    assert A.elongate((h, 0, 0)).bounds == ((-1.7, -1.0, -1.0), (1.7, 1.0, 1.0))
    _assert_gradient_matches_differences(A.elongate((0.5, 0.2, 0)).shell(0.1).offset(0.05), p)


@pytest.mark.parametrize("kind", ["twist", "bend"])
def test_twist_and_bend_are_lipschitz_with_the_warped_zero_set(rng, kind):
    bar = sdf.box((2.0, 0.6, 0.3))
    rate = 40.0
    model = getattr(bar, kind)(rate)
    p = rng.uniform(-2, 2, (20000, 3))
    q = p + rng.normal(scale=0.2, size=p.shape)
    assert np.all(np.abs(model(p) - model(q)) <= np.linalg.norm(p - q, axis=1) * (1 + 1e-9) + 1e-12)
    # Inside the warp's cylinder the sign is the child's at the warped point.
    angle = np.deg2rad(rate) * (-p[:, 2] if kind == "twist" else p[:, 0])
    c, s = np.cos(angle), np.sin(angle)
    warped = np.column_stack([p[:, 0] * c - p[:, 1] * s, p[:, 0] * s + p[:, 1] * c, p[:, 2]])
    expected = bar(warped)
    lo, hi = np.asarray(model.bounds[0]), np.asarray(model.bounds[1])
    assert np.all((model(p) < 0) == (expected < 0))
    inside = model(p) < 0
    assert np.all(p[inside] >= lo) and np.all(p[inside] <= hi)
    assert model.lipschitz > 1


def test_twist_needs_a_bounded_3d_shape():
    with pytest.raises(ValueError, match="bounded"):
        sdf.plane().twist(10)
    with pytest.raises(ValueError, match="3D"):
        sdf.circle(1.0).twist(10)


@pytest.mark.parametrize("count", [(4, 3, 1), (3, 3, 3), (5, 1, 2)])
def test_repeat_is_a_lipschitz_lower_bound_with_the_union_zero_set(rng, count):
    spacing = np.array([1.0, 1.2, 0.9])
    child = sdf.sphere(0.4, center=(0.1, 0.0, 0.0))
    model = sdf.repeat(child, spacing, count)
    copies = [np.array(i) * spacing + [0.1, 0, 0] for i in itertools.product(*(range(n) for n in count))]
    p = rng.uniform(-1.5, np.array(count) * spacing + 0.5, (20000, 3))
    exact = np.min([ball(p, c, 0.4) for c in copies], axis=0)
    values = model(p)
    assert np.all((values < 0) == (exact < 0))
    assert np.all(np.abs(values) <= np.abs(exact) + 1e-12)
    q = p + rng.normal(scale=0.4, size=p.shape)
    assert np.all(np.abs(values - model(q)) <= np.linalg.norm(p - q, axis=1) * (1 + 1e-9) + 1e-12)
    np.testing.assert_allclose(model.bounds[1], (np.array(count) - 1) * spacing + [0.5, 0.4, 0.4])
    # Near the copies the value is the exact distance.
    near = np.abs(exact) < 0.3
    np.testing.assert_allclose(values[near], exact[near], atol=1e-12)


def test_repeat_of_overlapping_copies_is_their_union(rng):
    child = sdf.box((1.5, 0.5, 0.5))
    model = sdf.repeat(child, 1.0, (3, 1, 1))
    p = rng.uniform(-2, 4, (2000, 3))
    expected = np.min([child(p - [i, 0, 0]) for i in range(3)], axis=0)
    np.testing.assert_allclose(model(p), expected)


# ---------------------------------------------------------------------- repr
def test_repr_prints_the_tree():
    model = (sdf.box((2, 2, 2)) | sdf.sphere(0.8).translate((1, 1, 1))) - sdf.cylinder(0.5, 3)
    text = repr(model)
    assert text.splitlines()[0] == "difference()"
    assert "├─ union()" in text and "└─ transform[translate(1, 1, 1)]\n" in text and "└─ cylinder(" in text


# ---------------------------------------------------------------------- bad input
@pytest.mark.parametrize(
    "make, error, fragment",
    [
        (lambda: A | 3, TypeError, "union operand 1"),
        (lambda: A & "x", TypeError, "intersection operand 1"),
        (lambda: A - None, TypeError, "difference operand 1"),
        (lambda: 2 | A, TypeError, "union operand 0"),
        (lambda: A | sdf.circle(1.0), ValueError, "2D and 3D"),
        (lambda: sdf.union(A, B, k=-1), ValueError, "k must be >= 0"),
        (lambda: sdf.union(A, B, k=float("nan")), ValueError, "k must be finite"),
        (lambda: sdf.union(), ValueError, "at least one"),
        (lambda: A.translate((1, 2)), ValueError, "offset"),
        (lambda: A.translate((1, np.inf, 0)), ValueError, "offset must be finite"),
        (lambda: A.translate("abc"), TypeError, "offset"),
        (lambda: A.rotate(float("nan")), ValueError, "angle"),
        (lambda: A.rotate(30, axis=(0, 0, 0)), ValueError, "axis"),
        (lambda: A.rotate("30"), TypeError, "angle"),
        (lambda: A.scale(0), ValueError, "factor must be > 0"),
        (lambda: A.scale((1, -1, 1)), ValueError, "factor"),
        (lambda: A.scale((1, 2)), ValueError, "factor"),
        (lambda: A.mirror((0, 0, 0)), ValueError, "normal"),
        (lambda: A.transform(np.zeros((4, 4)) + np.diag([1, 1, 0, 1])), ValueError, "singular"),
        (lambda: A.transform(np.ones((3, 4))), ValueError, "matrix must be"),
        (lambda: A.transform([[1, 0, 0, 0], [0, 1, 0, 0], [0, 0, 1, 0], [0, 0, 1, 1]]), ValueError, "last row"),
        (lambda: A.transform(np.full((4, 4), np.nan)), ValueError, "finite"),
        (lambda: A.transform([[1, 0], [0, 1, 2]]), ValueError, "rectangular"),
        (lambda: A.offset(float("inf")), ValueError, "distance"),
        (lambda: A.shell(0), ValueError, "thickness must be > 0"),
        (lambda: A.shell(-0.1), ValueError, "thickness"),
        (lambda: A.elongate((-1, 0, 0)), ValueError, "h must be >= 0"),
        (lambda: A.twist(float("nan")), ValueError, "rate"),
        (lambda: sdf.repeat(A, 0, 3), ValueError, "spacing"),
        (lambda: sdf.repeat(A, 1, 0), ValueError, "count"),
        (lambda: sdf.repeat(A, 1, 2.5), TypeError, "count"),
        (lambda: sdf.repeat(A, 1, (2, 2)), ValueError, "count"),
        (lambda: sdf.repeat(-A, 1, 2), ValueError, "bounded"),
        (lambda: sdf.repeat("A", 1, 2), TypeError, "shape"),
        (lambda: sdf.rectangle((1, 1)).rotate(30, axis=(0, 0, 1), center=(0, 0)), ValueError, "axis"),
    ],
)
def test_bad_input_is_refused_with_the_parameter_named(make, error, fragment):
    with pytest.raises(error, match=fragment.replace("(", r"\(").replace(")", r"\)")):
        make()


def test_grid_tiles_skip_far_operands_without_changing_values(monkeypatch):
    import fepre
    from fepre.bench.sdf import fepre_model

    monkeypatch.setattr(fepre.config, "chunk_points", 4096)  # many small tiles: much skipping
    monkeypatch.setattr(fepre.sdf.core, "GRID_BLOCK_DEPTH", 4)
    models = [
        fepre_model(),
        sdf.sphere(0.5, center=(-1.2, 0, 0)) | sdf.box((0.6, 0.6, 0.6), center=(1.2, 0.3, 0)),
        sdf.union(*(sdf.sphere(0.3, center=(i - 1.5, 0.5 * i - 1, 0)) for i in range(4))) - sdf.box((0.5, 4, 0.5)),
        sdf.difference(sdf.box((3, 3, 3)), *(sdf.cylinder(0.2, 4, center=(i - 1, 0, 0)) for i in range(3))),
    ]
    xs, axis = np.linspace(-2, 2, 150), np.linspace(-2, 2, 40)
    z, y, x = np.meshgrid(axis, axis, xs, indexing="ij")
    points = np.column_stack([x.ravel(), y.ravel(), z.ravel()])
    for model in models:
        grid = model.values_on_axes(xs, axis, axis, dtype=np.float64, workers=2)
        np.testing.assert_allclose(grid.ravel(), model(points), rtol=0, atol=1e-14)
