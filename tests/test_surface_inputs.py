"""fepre.isosurface on bad input: clear errors or an empty surface with a warning."""

from __future__ import annotations

import numpy as np
import pytest
import pyvista as pv

import fepre
from fepre import sdf
from fepre.surface import METHODS


def small_grid(values=None):
    grid = pv.ImageData(dimensions=(6, 6, 6), spacing=(0.5,) * 3, origin=(-1.25,) * 3)
    grid.point_data["sdf"] = np.linalg.norm(grid.points, axis=1) - 1.0 if values is None else values
    return grid


@pytest.mark.parametrize("method", METHODS)
def test_level_outside_the_samples_gives_an_empty_surface_and_a_warning(method):
    with pytest.warns(UserWarning, match=r"surface is empty: level 10 .*range"):
        surface = fepre.isosurface(small_grid(), method=method, level=10.0)
    assert isinstance(surface, pv.PolyData) and surface.n_points == 0 and surface.n_cells == 0


@pytest.mark.parametrize("method", METHODS)
def test_nan_samples_are_refused(method):
    values = np.linalg.norm(small_grid().points, axis=1) - 1.0
    values[17] = np.nan
    with pytest.raises(ValueError, match="contain NaN .*point 17"):
        fepre.isosurface(small_grid(values), method=method)


def test_grid_without_sdf_needs_scalars():
    grid = small_grid()
    grid.point_data["distance"] = grid.point_data.pop("sdf")
    with pytest.raises(ValueError, match="no point array 'sdf'; pass scalars=.*'distance'"):
        fepre.isosurface(grid)
    assert fepre.isosurface(grid, scalars="distance", method="marching_cubes").n_cells > 0
    with pytest.raises(ValueError, match="scalars='other' is not a point array"):
        fepre.isosurface(grid, scalars="other")


@pytest.mark.parametrize(
    "kwargs, error, message",
    [
        ({"method": "dual_marching_cubes"}, ValueError, "method must be one of"),
        ({"level": float("nan")}, ValueError, "level must be finite"),
        ({"level": "0"}, TypeError, "level must be a real number"),
        ({"spacing": 0.0}, ValueError, "spacing must be > 0"),
        ({"spacing": 10.0}, ValueError, "larger than the model"),
        ({"shape": (0, 10, 10)}, ValueError, "at least 2 nodes"),
        ({"bounds": ((1, 1, 1), (0, 2, 2))}, ValueError, "min < max"),
        ({"workers": -1}, ValueError, "workers must be"),
    ],
)
def test_bad_arguments_for_a_model_source(kwargs, error, message):
    with pytest.raises(error, match=message):
        fepre.isosurface(sdf.sphere(1.0), **kwargs)


def test_grid_options_are_refused_for_a_grid_source():
    with pytest.raises(ValueError, match="spacing applies only when source is a model"):
        fepre.isosurface(small_grid(), spacing=0.1)


def test_source_type_is_checked():
    with pytest.raises(TypeError, match="source must be a fepre.sdf.SDF or a pyvista.ImageData"):
        fepre.isosurface(np.zeros((4, 4, 4)))


def test_surface_reaching_the_grid_boundary_is_open_not_broken():
    # user bounds that cut the ball: the surface is open at the cut but every method still works
    for method in METHODS:
        cut = ((-1.5, -1.5, 0.0), (1.5, 1.5, 1.5))
        surface = fepre.isosurface(sdf.sphere(1.0), shape=20, bounds=cut, method=method)
        check = fepre.check_surface(surface)
        assert surface.n_cells > 0 and not check.watertight and check.oriented


def test_surface_carries_its_grid_for_later_checks():
    surface = fepre.isosurface(sdf.sphere(1.0), spacing=0.25, method="surface_nets")
    assert surface.field_data["surface_method"][0] == "surface_nets"
    np.testing.assert_allclose(surface.field_data["surface_spacing"], 0.25)
    assert tuple(surface.field_data["surface_grid_dimensions"]) == (13, 13, 13)


def test_model_giving_nan_is_refused():
    class Broken(sdf.SDF):
        def __init__(self):
            super().__init__(bounds=((-1, -1, -1), (1, 1, 1)), exact=False)

        def _values(self, x, y, z):
            with np.errstate(invalid="ignore"):
                return np.sqrt(x * x + y * y + z * z - 0.25)  # NaN inside radius 0.5

    with pytest.raises(ValueError, match="samples contain NaN"):
        fepre.isosurface(Broken(), spacing=0.1, method="marching_cubes")
