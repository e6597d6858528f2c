"""A part far from the origin gets the same surface as at the origin, moved (issue 12: parts placed
at 1e4). vtkFlyingEdges3D writes float32 points; at 1e4 they kept 3 decimals and triangles
collapsed (12 degenerate triangles on a corpus part)."""

import numpy as np
import pytest

import fepre
from fepre import sdf

OFFSET = np.array([1.0e4, -1.0e4, 5.0e3])


@pytest.mark.parametrize("method", ["flying_edges", "marching_cubes", "surface_nets"])
def test_a_far_part_has_the_surface_of_the_part_at_the_origin_moved(method):
    part = sdf.box((3.0, 2.0, 1.5)) - sdf.sphere(0.9)
    box = np.array([[-2.0, -1.5, -1.25], [2.0, 1.5, 1.25]])
    near = fepre.isosurface(part, method=method, spacing=0.13, bounds=box)
    far = fepre.isosurface(part.translate(tuple(OFFSET)), method=method, spacing=0.13, bounds=box + OFFSET)
    assert far.n_points == near.n_points and far.n_cells == near.n_cells
    # float32 samples: the crossings agree to their rounding (they were 1.3e-3 apart)
    np.testing.assert_allclose(np.asarray(far.points) - OFFSET, np.asarray(near.points), atol=1e-6)
    check = fepre.check_surface(far)
    assert (check.watertight, check.manifold, check.degenerate_triangles) == (True, True, 0)


def test_dual_contouring_of_a_far_part_whose_faces_lie_on_grid_nodes_has_no_zero_area_triangle():
    """A clevis at (250, -40, 12), spacing 0.02: its faces fall on grid nodes, whose values were
    the rounding of their coordinates (3e-14), not 0; a grid edge along a crease then "crossed"
    it and four dual vertices landed on one line: 14 zero-area triangles in the written STL."""
    block = sdf.box((3.0, 1.6, 1.2))
    slot = sdf.box((1.4, 0.6, 2.0), center=(0.9, 0, 0))
    hole = sdf.cylinder(0.25, 3.0, center=(1.0, 0, 0), axis="y")
    cut = sdf.box((1.0, 3.0, 1.0), center=(-1.6, 0, 0.7)).rotate(30, (0, 1, 0), center=(-1.5, 0, 0.6))
    clevis = (block - slot - hole - cut).translate((250.0, -40.0, 12.0))
    check = fepre.check_surface(fepre.isosurface(clevis, method="dual_contouring", spacing=0.02))
    assert (check.watertight, check.manifold, check.components, check.genus) == (True, True, 1, 2)
    assert check.degenerate_triangles == 0
