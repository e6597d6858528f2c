"""fepre.sample: grid geometry, values in VTK order, narrow band, memory limit, bad input."""

from __future__ import annotations

import numpy as np
import pytest

import fepre
from fepre import sdf
from fepre.surface import METHODS


def test_values_are_the_model_at_the_grid_points_in_vtk_order():
    model = sdf.torus(1.0, 0.4)
    grid = fepre.sample(model, spacing=0.1, dtype="float64")
    np.testing.assert_allclose(grid["sdf"], model(grid.points), atol=1e-12)
    assert grid.field_data["sdf_evaluated_fraction"][0] == 1.0


def test_default_bounds_pad_the_model_by_at_least_two_cells():
    model = sdf.box((2.0, 1.0, 0.5))
    grid = fepre.sample(model, spacing=0.1)
    lo, hi = (np.array(b) for b in model.bounds)
    box = np.array(grid.bounds).reshape(3, 2)
    assert np.all(lo - box[:, 0] >= 2 * 0.1 - 1e-12) and np.all(box[:, 1] - hi >= 2 * 0.1 - 1e-12)
    np.testing.assert_allclose(box.mean(axis=1), (lo + hi) / 2, atol=1e-12)  # centred
    assert grid.spacing == pytest.approx((0.1, 0.1, 0.1))
    shaped = fepre.sample(model, shape=(30, 20, 10))
    assert shaped.dimensions == (30, 20, 10)
    box = np.array(shaped.bounds).reshape(3, 2)
    assert np.all(lo - box[:, 0] >= 2 * np.array(shaped.spacing) - 1e-9)


def test_explicit_bounds_and_float32_default():
    grid = fepre.sample(sdf.sphere(1.0), shape=11, bounds=((-2, -2, -2), (2, 2, 2)))
    assert grid.bounds == pytest.approx((-2, 2, -2, 2, -2, 2))
    assert grid["sdf"].dtype == np.float32
    assert grid["sdf"][5 + 11 * 5 + 121 * 5] == pytest.approx(-1.0)


@pytest.mark.parametrize(
    "model, h", [(sdf.torus(1.0, 0.4), 0.02), (sdf.box((5, 5, 5)) - sdf.cylinder(radius=1, height=7), 0.04)]
)
def test_banded_surface_is_identical_to_dense(model, h):
    dense = fepre.sample(model, spacing=h)
    banded = fepre.sample(model, spacing=h, band=0.0)
    fraction = banded.field_data["sdf_evaluated_fraction"][0]
    assert 0 < fraction < 0.7  # small grids: 8^3 blocks are coarse; see fepre bench surface at 512^3
    band = banded.field_data["sdf_band"][0]
    assert band == pytest.approx(h * np.sqrt(3))  # widened to one cell diagonal
    d, b = np.asarray(dense["sdf"]), np.asarray(banded["sdf"])
    evaluated = np.abs(b) != np.float32(band)
    np.testing.assert_array_equal(d[evaluated], b[evaluated])
    assert np.all(np.sign(d) == np.sign(b)) and np.all(np.abs(d[~evaluated]) > band)
    for method in METHODS:
        one, other = fepre.isosurface(dense, method=method), fepre.isosurface(banded, method=method)
        np.testing.assert_array_equal(one.points, other.points)
        np.testing.assert_array_equal(one.regular_faces, other.regular_faces)


@pytest.mark.parametrize("workers", [1, 2])
def test_banded_grid_with_short_last_blocks_and_unequal_spacing_equals_dense(workers):
    # 121 x 89 x 73 nodes: no axis is a multiple of its block width, so the last block along
    # each axis and the last block row are short; the spacings give blocks of different widths.
    model = sdf.box((2.0, 1.2, 1.0)) - sdf.sphere(0.45, center=(0.4, 0.1, 0.5)) | sdf.torus(0.5, 0.15, center=(-0.6, 0, 0))
    bounds = ((-1.3, -0.8, -0.7), (1.3, 0.8, 0.7))
    dense = fepre.sample(model, shape=(121, 89, 73), bounds=bounds, workers=workers)
    banded = fepre.sample(model, shape=(121, 89, 73), bounds=bounds, band=0.0, workers=workers)
    assert banded.field_data["sdf_evaluated_fraction"][0] < 0.75
    d, b = np.asarray(dense["sdf"]), np.asarray(banded["sdf"])
    band = np.float32(banded.field_data["sdf_band"][0])
    evaluated = np.abs(b) != band
    np.testing.assert_array_equal(d[evaluated], b[evaluated])
    assert np.all(np.sign(d) == np.sign(b)) and np.all(np.abs(d[~evaluated]) > band)
    one, other = fepre.isosurface(dense, method="marching_cubes"), fepre.isosurface(banded, method="marching_cubes")
    np.testing.assert_array_equal(one.points, other.points)


def test_unbounded_model_needs_bounds():
    half_space = sdf.sphere(1.0) | sdf.complement(sdf.sphere(3.0))
    assert half_space.bounds is None
    with pytest.raises(ValueError, match="bounds is required"):
        fepre.sample(half_space, spacing=0.1)
    grid = fepre.sample(half_space, shape=8, bounds=((-1, -1, -1), (1, 1, 1)))
    assert grid.n_points == 512


def test_memory_limit_gives_the_size_and_the_fix(monkeypatch):
    monkeypatch.setattr(fepre.config, "max_grid_bytes", 1_000_000)
    with pytest.raises(ValueError, match=r"would need 3\.8 MiB .*larger spacing"):
        fepre.sample(sdf.sphere(1.0), shape=100)


@pytest.mark.parametrize(
    "kwargs, message",
    [
        ({"spacing": 0.0}, "spacing must be > 0"),
        ({"spacing": -0.1}, "spacing must be > 0"),
        ({"spacing": 5.0}, "larger than the model"),
        ({"shape": (10, 0, 10)}, "at least 2 nodes"),
        ({"shape": -4}, "at least 2 nodes"),
        ({"shape": 10.5}, "shape must be"),
        ({"shape": 10, "spacing": 0.1}, "not both"),
        ({"bounds": ((0, 0, 0), (1, -1, 1))}, "min < max"),
        ({"bounds": ((0, 0, 0), (0, 1, 1))}, "min < max"),
        ({"dtype": "int32"}, "dtype must be"),
        ({"band": -1.0}, "band must be >= 0"),
        ({"padding": -1.0}, "padding must be >= 0"),
        ({"workers": 0}, "workers must be"),
    ],
)
def test_bad_arguments_name_the_parameter(kwargs, message):
    with pytest.raises((ValueError, TypeError), match=message):
        fepre.sample(sdf.sphere(1.0), **kwargs)


def test_model_must_be_an_sdf():
    with pytest.raises(TypeError, match="model must be"):
        fepre.sample(np.zeros(3), spacing=0.1)


def test_a_banded_grid_far_from_the_origin_has_the_dense_grids_values():
    """Banded blocks were evaluated on float32 coordinates: 1e4 from the origin those keep three
    decimals, and the values near the surface were off by 1e-3 (a tenth of this grid's spacing)."""
    from fepre.sampling import sample

    part = sdf.sphere(0.3).translate((1e4, -2e4, 5e3))
    banded = np.asarray(sample(part, spacing=0.01, band=0.05).point_data["sdf"])
    dense = np.asarray(sample(part, spacing=0.01).point_data["sdf"])
    near = np.abs(dense) < 0.02
    assert near.sum() > 1000
    np.testing.assert_array_equal(banded[near], dense[near])
