"""Error messages show numbers as the user would write them, never numpy reprs such as
``np.float64(-5.0)`` (numpy 2 reprs scalars with their type)."""

from __future__ import annotations

import numpy as np
import pytest

import fepre
from fepre import sdf
from fepre.arguments import choice, positive_int, shown


def test_shown_prints_plain_numbers():
    assert shown(np.float64(-5.0)) == "-5.0"
    assert shown(np.int64(3)) == "3"
    assert shown((np.int64(4), 5)) == "(4, 5)"
    assert shown(np.array([1.5, 2.0])) == "[1.5, 2.0]"
    assert shown("x") == "'x'"


def _tiny_mesh():
    import pyvista as pv

    points = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1.0]])
    return pv.UnstructuredGrid({pv.CellType.TETRA: np.array([[0, 1, 2, 3]])}, points)


@pytest.mark.parametrize(
    "call, number",
    [
        (lambda: fepre.distmesh(sdf.sphere(1.0), h=np.float64(-5.0)), "-5.0"),
        (lambda: fepre.DistMeshOptions(deltat=np.float64(-1.0)), "-1.0"),
        (lambda: positive_int(np.int64(0), "count"), "0"),
        (lambda: choice(np.int64(3), "order", (1, 2)), "3"),
        (lambda: fepre.sample(sdf.sphere(1.0), spacing=np.float64(-0.5)), "-0.5"),
        (lambda: sdf.sphere(1.0).scale((np.float64(-1.0), 1.0, 1.0)), "(-1.0, 1.0, 1.0)"),
        (lambda: fepre.config.resolve_workers(np.int64(0)), "0"),
        (lambda: fepre.export(_tiny_mesh(), "unused.vtu", boundary_angle=np.float64(100.0)), "100.0"),
        (lambda: fepre.DistMeshOptions(deltat=np.float64(2.0)), "2.0"),
        (lambda: fepre.DistMeshOptions(seed=np.float64(1.5)), "1.5"),
        (lambda: fepre.distmesh(sdf.sphere(1.0), h=np.float64(5.0)), "5.0"),
        (lambda: fepre.improve(_tiny_mesh(), sdf.sphere(1.0), min_dihedral=np.float64(80.0)), "80.0"),
        (lambda: fepre.distmesh(sdf.gyroid(1.0, 0.2), h=0.1, periodic=(np.float64(-1.0), 1.0, 1.0)), "-1.0"),
    ],
)
def test_messages_print_plain_numbers(call, number):
    with pytest.raises((ValueError, TypeError)) as caught:
        call()
    message = str(caught.value)
    assert "np." not in message and number in message, message
