"""A quadratic VTU keeps the mesh's flag arrays at its midside nodes, and its set names in field
data do not reuse the names of its point and cell arrays."""

from __future__ import annotations

import warnings

import numpy as np
import pytest
import pyvista as pv

import fepre
from fepre import sdf
from fepre.export.grid import set_names


@pytest.fixture(scope="module")
def cube():
    model = sdf.box(1.0)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", fepre.ConvergenceWarning)
        return model, fepre.distmesh(model, h=0.35, progress=False)


def _on_cube_edge(points: np.ndarray) -> np.ndarray:
    return np.count_nonzero(np.isclose(np.abs(points), 0.5, atol=1e-9), axis=1) >= 2


def test_quadratic_vtu_keeps_boundary_and_feature_at_the_midside_nodes(tmp_path, cube):
    model, mesh = cube
    grid = fepre.export(mesh, tmp_path / "q.vtu", order=2, model=model)
    back = pv.read(tmp_path / "q.vtu")
    n = mesh.n_points
    for written in (grid, back):
        assert {"boundary", "feature"} <= set(written.point_data.keys())
        boundary, feature = np.asarray(written["boundary"]), np.asarray(written["feature"])
        assert np.array_equal(boundary[:n], mesh["boundary"]) and np.array_equal(feature[:n], mesh["feature"])
        # a midside node is on the boundary where its edge is an edge of a boundary face
        assert np.array_equal(boundary[n:] == 1, np.asarray(written["boundary_id"])[n:] >= 0)
        # ... and on a feature curve where its edge follows one: here the cube's edges
        assert np.array_equal(feature[n:] == 1, _on_cube_edge(written.points[n:]))
        assert feature[n:].max() == 1  # corners (2) are corner nodes only


def test_vtu_field_data_names_are_not_array_names(tmp_path, cube):
    """The region "volume" and the boundary set "boundary" shared their names with the cell array
    ``volume`` and the point array ``boundary``; the sets still read back under their own names."""
    model, mesh = cube
    for order in (1, 2):
        path = tmp_path / f"part{order}.vtu"
        fepre.export(mesh, path, order=order, model=model, boundaries={"top": sdf.plane((0, 0, 1), (0, 0, 0.5))})
        back = pv.read(path)
        arrays = set(back.point_data.keys()) | set(back.cell_data.keys())
        assert not arrays & set(back.field_data.keys()), order
        assert set_names(back) == (["volume"], ["top", "boundary"])
