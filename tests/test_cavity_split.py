"""A boundary chord across a valley of a thin wall: its split needs a cavity, not its ring."""

from __future__ import annotations

import doctest

import numpy as np

from fepre import sdf
from fepre.distmesh import cavity_split as cavity_module
from fepre.distmesh.cavity_split import cavity_split
from fepre.distmesh.bad_cell_splits import split_bad_cells
from fepre.distmesh.surface_refine import split_edges
from fepre.distmesh.tet_shape import ShapeTargets, signed_volume
from fepre.distmesh.tet_topology import face_neighbours, faces_on_boundary, open_boundary_reason

#: The valley: a ball of radius RADIUS cut out of the half space below z = 0.2, its lowest point
#: DEPTH under the chord's midpoint (the chord's ends on the ball, at x = -1 and 1).
DEPTH = 0.35
RADIUS = (1.0 + DEPTH**2) / (2.0 * DEPTH)
CENTRE = np.array([0.0, 0.0, RADIUS - DEPTH])


def _valley(bottom: float = -1.0):
    """A bowl model and five nodes: the chord u-v (2 long) on the bowl, a and b on the bowl 0.45
    to either side of it (so the one cell on the chord is flat, its two boundary faces caps of
    124 deg on the chord, and its other nodes lie above the chord's projected midpoint), c at
    ``bottom`` below them; three cells filling their convex hull."""
    model = sdf.difference(sdf.plane((0, 0, 1), (0, 0, 0.2)), sdf.sphere(RADIUS, CENTRE))
    side = CENTRE[2] - np.sqrt(RADIUS**2 - 0.45**2)
    points = np.array([[-1.0, 0, 0], [1.0, 0, 0], [0, -0.45, side], [0, 0.45, side], [0, 0, bottom]])
    tets = np.array([[0, 1, 2, 3], [0, 2, 3, 4], [1, 2, 3, 4]])
    flip = signed_volume(points[tets]) < 0
    tets[flip] = tets[flip][:, [1, 0, 2, 3]]
    return model, points, tets


def test_the_model_and_the_mesh_are_what_the_case_needs():
    model, points, tets = _valley()
    assert np.allclose(model(points[:4]), 0.0, atol=1e-12)  # u, v, a, b on the bowl
    assert model(np.array([[0.0, 0, 0]]))[0] > 0.3  # the chord's midpoint 0.35 outside
    faces = faces_on_boundary(tets, face_neighbours(tets, 5))
    assert open_boundary_reason(faces, 5) == ""
    assert (signed_volume(points[tets]) > 0).all()


def test_a_plain_split_of_the_chord_is_refused():
    model, points, tets = _valley()
    assert split_edges(points, tets, model, 1.0, np.array([[0, 1]]))[2] == 0


def test_the_cavity_split_puts_the_vertex_in_the_valley_and_keeps_a_valid_solid():
    model, points, tets = _valley()
    new_points, new_tets, done = cavity_split(points, tets, model, 1.0, (0, 1))
    assert done
    vertex = new_points[-1]
    assert np.allclose(vertex, [0.0, 0.0, -DEPTH], atol=1e-6)  # the valley's bottom
    assert abs(model(vertex[None])[0]) < 1e-6
    volumes = signed_volume(new_points[new_tets])
    assert (volumes > 0).all()
    # the solid lost exactly the two cells between the old chord faces and the new vertex
    lost = sum(abs(signed_volume(np.array([points[0], points[1], points[k], vertex])[None])[0]) for k in (2, 3))
    assert np.isclose(volumes.sum(), signed_volume(points[tets]).sum() - lost, rtol=1e-12)
    faces = faces_on_boundary(new_tets, face_neighbours(new_tets, 6))
    assert open_boundary_reason(faces, 6) == ""
    # the 2.0 chord is gone: four boundary faces through the new vertex, edges of 1.13 at most
    assert not (np.isin(faces, [0]).any(axis=1) & np.isin(faces, [1]).any(axis=1)).any()
    through = faces[(faces == 5).any(axis=1)]
    assert through.shape[0] == 4
    edges = np.concatenate([through[:, [0, 1]], through[:, [1, 2]], through[:, [2, 0]]])
    lengths = np.linalg.norm(new_points[edges[:, 0]] - new_points[edges[:, 1]], axis=1)
    assert np.isclose(lengths, np.hypot(1.0, DEPTH)).sum() == 4 and lengths.max() < 1.14
    # the flat cell on the chord (all four nodes on the bowl) is gone and every cell is better
    targets = ShapeTargets()
    assert targets.score(new_points[new_tets]).min() > targets.score(points[tets]).min() + 10.0


def test_the_insertion_round_splits_the_bad_cells_chord_into_a_cavity():
    # the flat cell's first choice is the caps' common chord, whose plain split is refused: the
    # round used to split the next edge (the 0.9 inner edge a-b), which leaves the chord
    model, points, tets = _valley()
    targets = ShapeTargets()
    assert targets.score(points[tets]).min() < targets.min_dihedral
    new_points, new_tets, splits = split_bad_cells(points, tets, model, 1.0)
    assert splits == 1
    assert np.allclose(new_points[-1], [0.0, 0.0, -DEPTH], atol=1e-6)
    assert (signed_volume(new_points[new_tets]) > 0).all()
    assert targets.score(new_points[new_tets]).min() > 20.0


def test_a_cavity_that_would_cross_the_boundary_is_refused():
    # the bottom node c 0.3 under the chord: the valley's bottom (0.35) lies outside the mesh,
    # so the cavity would have to take the bottom faces
    model, points, tets = _valley(-0.3)
    assert (signed_volume(points[tets]) > 0).all()
    new_points, new_tets, done = cavity_split(points, tets, model, 1.0, (0, 1))
    assert not done and new_points is points and new_tets is tets


def test_the_docstring_example_runs():
    result = doctest.testmod(cavity_module)
    assert result.failed == 0 and result.attempted > 0
