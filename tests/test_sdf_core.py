"""The SDF protocol: point validation, blocked/threaded evaluation, axis sampling, projection."""

from __future__ import annotations

import numpy as np
import pytest

import fepre
from fepre import sdf
from fepre.sdf.core import SDF


class NoGradientSphere(SDF):
    """A sphere without an analytic gradient, to exercise central differences."""

    def __init__(self, radius: float) -> None:
        self.radius = radius
        super().__init__(bounds=((-radius,) * 3, (radius,) * 3), exact=True)

    def _values(self, x, y, z):
        return np.sqrt(x * x + y * y + z * z) - self.radius


@pytest.fixture
def rng():
    return np.random.default_rng(1234)


def test_single_point_returns_float_and_array_returns_float64():
    ball = sdf.sphere(2.0, center=(1.0, 0.0, 0.0))
    value = ball([1.0, 0.0, 3.0])
    assert isinstance(value, float) and value == pytest.approx(1.0)
    values = ball(np.array([[1, 0, 0], [4, 0, 0]], dtype=np.int32))
    assert values.dtype == np.float64 and values.tolist() == pytest.approx([-2.0, 1.0])


@pytest.mark.parametrize(
    "points, error, fragment",
    [
        (np.zeros((5, 2)), ValueError, "(N, 3)"),
        (np.zeros((3, 7)), ValueError, "transposed"),
        (np.zeros((2, 3, 3)), ValueError, "(N, 3)"),
        ([[0, 0, 0], [1, 2]], ValueError, "rectangular"),
        (["a", "b", "c"], TypeError, "real numbers"),
        (np.array([[np.nan, 0, 0]]), ValueError, "finite"),
        (np.zeros(3, dtype=complex), TypeError, "real numbers"),
    ],
)
def test_bad_points_are_refused_with_the_parameter_named(points, error, fragment):
    with pytest.raises(error, match="points") as info:
        sdf.sphere()(points)
    assert fragment in str(info.value)


def test_blocked_threaded_evaluation_equals_direct(rng, monkeypatch):
    points = rng.uniform(-2, 2, size=(100_003, 3))
    ball = sdf.sphere(1.3, center=(0.1, -0.2, 0.3))
    direct = np.linalg.norm(points - [0.1, -0.2, 0.3], axis=1) - 1.3
    monkeypatch.setattr(fepre.config, "chunk_points", 4096)
    threaded = ball(points)
    monkeypatch.setattr(fepre.config, "workers", 1)
    serial = ball(points)
    np.testing.assert_array_equal(threaded, serial)
    np.testing.assert_allclose(threaded, direct, rtol=0, atol=1e-14)


def test_values_on_axes_is_vtk_order_and_matches_point_evaluation(monkeypatch):
    x = np.linspace(-1.2, 1.1, 23)
    y = np.linspace(-1.0, 1.3, 17)
    z = np.linspace(-0.9, 1.0, 11)
    ball = sdf.sphere(0.8, center=(0.1, 0.2, -0.1))
    monkeypatch.setattr(fepre.config, "chunk_points", 40)  # force several blocks per plane
    grid = ball.values_on_axes(x, y, z, dtype=np.float64)
    assert grid.shape == (11, 17, 23) and grid.flags.c_contiguous
    zz, yy, xx = np.meshgrid(z, y, x, indexing="ij")
    points = np.column_stack([xx.ravel(), yy.ravel(), zz.ravel()])  # x fastest: VTK order
    np.testing.assert_allclose(grid.ravel(), ball(points), atol=1e-14)
    single = ball.values_on_axes(x, y, z, dtype="float32", workers=1)
    assert single.dtype == np.float32
    np.testing.assert_allclose(single, grid, atol=1e-6)


def test_subclass_redefining_values_is_sampled_through_it():
    # Sphere samples grids in place (_values_into); a subclass that redefines _values must be
    # sampled with its own values, not its parent's in-place formula.
    class Shifted(type(sdf.sphere())):
        def _values(self, x, y, z):
            return super()._values(x, y, z) + 0.25

    shape = Shifted(1.0, np.zeros(3))
    axis = np.linspace(-1.5, 1.5, 9)
    grid = shape.values_on_axes(axis, axis, axis, dtype=np.float64)
    zz, yy, xx = np.meshgrid(axis, axis, axis, indexing="ij")
    expected = np.sqrt(xx**2 + yy**2 + zz**2) - 0.75
    np.testing.assert_allclose(grid, expected, atol=1e-12)
    np.testing.assert_allclose((shape | sdf.sphere(0.1, center=(5, 5, 5))).values_on_axes(axis, axis, axis, dtype=np.float64), expected, atol=1e-12)


def test_scratch_arrays_are_reused_within_an_arena_only():
    from fepre.sdf.core import ScratchArenas, give_scratch, take_scratch

    first = take_scratch((4, 5), np.dtype(np.float32))
    give_scratch(first)
    assert take_scratch((4, 5), np.dtype(np.float32)) is not first  # no arena: plain np.empty

    def reuse():
        a = take_scratch((8, 8), np.dtype(np.float64))
        give_scratch(a)
        b = take_scratch((2, 3, 5), np.dtype(np.float64))  # any shape that fits
        assert b.flags.c_contiguous and b.shape == (2, 3, 5) and np.shares_memory(a, b)
        give_scratch(b)
        c = take_scratch((100,), np.dtype(np.float64))  # too large: a new array
        assert not np.shares_memory(a, c)

    ScratchArenas().run(reuse)


def test_values_on_axes_rejects_bad_axes():
    ball = sdf.sphere()
    with pytest.raises(ValueError, match="3 axis arrays"):
        ball.values_on_axes(np.zeros(3), np.zeros(3))
    with pytest.raises(ValueError, match="axis y"):
        ball.values_on_axes(np.zeros(3), np.zeros((2, 2)), np.zeros(3))
    with pytest.raises(TypeError, match="dtype"):
        ball.values_on_axes(np.zeros(3), np.zeros(3), np.zeros(3), dtype=int)
    with pytest.raises(ValueError, match="workers"):
        ball.values_on_axes(np.zeros(3), np.zeros(3), np.zeros(3), workers=0)


def test_central_difference_gradient_matches_analytic(rng):
    points = rng.uniform(-2, 2, size=(500, 3))
    analytic = sdf.sphere(0.7).gradient(points)
    numeric = NoGradientSphere(0.7).gradient(points)
    np.testing.assert_allclose(numeric, analytic, atol=1e-7)
    norms = np.linalg.norm(analytic, axis=1)
    np.testing.assert_allclose(norms, 1.0, atol=1e-12)


def test_project_lands_on_the_zero_set(rng):
    points = rng.uniform(-3, 3, size=(1000, 3))
    points = points[np.linalg.norm(points, axis=1) > 1e-3]
    for model in (sdf.sphere(1.5), NoGradientSphere(1.5)):
        projected = model.project(points)
        assert np.abs(model(projected)).max() < 1e-9
        # Newton on an exact distance moves along the ray through the centre
        cosine = np.einsum("ij,ij->i", projected, points) / (
            np.linalg.norm(projected, axis=1) * np.linalg.norm(points, axis=1)
        )
        np.testing.assert_allclose(cosine, 1.0, atol=1e-9)
    with pytest.raises(ValueError, match="iterations"):
        sdf.sphere().project(points, iterations=0)


def test_repr_prints_the_node_and_walk_visits_it():
    ball = sdf.sphere(2.0, center=(1, 2, 3))
    assert repr(ball) == "sphere(radius=2, center=(1, 2, 3))"
    assert list(ball.walk()) == [ball]


def test_package_exposes_errors_and_version():
    assert issubclass(fepre.MeshingError, RuntimeError)
    assert issubclass(fepre.ConvergenceWarning, UserWarning)
    assert fepre.__version__.count(".") >= 2
    with pytest.raises(AttributeError, match="no attribute 'nonsense'"):
        fepre.nonsense  # noqa: B018


def test_project_warns_when_points_stay_off_the_surface():
    # Sphere minus box: 5% of random points stall off the surface (0.3 away) near the cut's
    # edges; they were returned silently.
    import warnings

    import fepre

    part = sdf.sphere(1.0) - sdf.box(1.0, center=(0.8, 0, 0))
    points = np.random.default_rng(0).uniform(-1.5, 1.5, (5000, 3))
    with pytest.warns(fepre.ConvergenceWarning, match=r"project: \d+ of 5000 points are still off the zero set"):
        projected = part.project(points)
    off = np.abs(part(projected)) > 1e-12 * part.length_scale
    assert 0 < off.sum() < 0.1 * len(points)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        assert np.abs(sdf.sphere(1.0)(sdf.sphere(1.0).project(points))).max() < 1e-12
        part.project(points, warn=False)


@pytest.mark.parametrize(
    "model",
    [sdf.box((2, 2, 1)), sdf.cylinder(1.0, 2.0), sdf.box(1.0) & sdf.gyroid(1.0, 0.1),
     sdf.sphere(1.0) - sdf.box(0.5), sdf.torus(1.0, 0.2).translate((1, 0, 0))],
    ids=["box", "cylinder", "gyroid-infill", "difference", "torus"],
)
def test_no_points_give_no_values(model):
    """An empty (0, 3) array evaluates to empty results (the box's sign test reduced over an
    empty block and raised inside numpy)."""
    empty = np.zeros((0, 3))
    assert model(empty).shape == (0,)
    values, gradients = model.value_and_gradient(empty)
    assert values.shape == (0,) and gradients.shape == (0, 3)
    assert model.project(empty).shape == (0, 3)


def test_operator_methods_call_the_functions_their_modules_register():
    """core imports none of booleans, transforms, deform: they register with core.operation."""
    from fepre.sdf import core

    assert set(core._OPERATIONS) == {
        "union", "intersection", "difference", "complement", "translate", "rotate", "scale", "mirror",
        "transform", "offset", "shell", "elongate", "twist", "bend",
    }
    for name, function in core._OPERATIONS.items():
        assert function is getattr(sdf, name)
    a, b = sdf.sphere(1.0), sdf.box(1.0)
    points = np.random.default_rng(0).uniform(-1.5, 1.5, (200, 3))
    for made, expected in (
        (a | b, sdf.union(a, b)), (a & b, sdf.intersection(a, b)), (a - b, sdf.difference(a, b)),
        (-a, sdf.complement(a)), (a.translate((1, 0, 0)), sdf.translate(a, (1, 0, 0))),
        (a.shell(0.1), sdf.shell(a, 0.1)), (a.twist(10.0), sdf.twist(a, 10.0)),
    ):
        assert repr(made) == repr(expected)
        np.testing.assert_array_equal(made(points), expected(points))
