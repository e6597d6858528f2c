"""Cells in labelled regions (a region mesh) through the quality stage's moves that add or
remove cells: edge splits, cavity splits, boundary edge flips and edge collapses change one
region's cells only, and the new cells carry its label."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.spatial import Delaunay

from fepre import sdf
from fepre.distmesh.boundary_flips import boundary_edge_round
from fepre.distmesh.cavity_split import cavity_split
from fepre.distmesh.cell_labels import refined_labels
from fepre.distmesh.edge_collapse import collapse_round
from fepre.distmesh.surface_guard import SurfaceGuard
from fepre.distmesh.surface_refine import split_edges
from fepre.distmesh.tet_shape import ShapeTargets, signed_volume
from fepre.distmesh.tet_topology import edge_keys, face_keys, face_neighbours, faces_on_boundary

R = 1 / np.sqrt(3)


def _four_cells():
    """Four cells inscribed in the unit sphere around a vertex near the centre."""
    points = np.array([[0.0, 0.0, 0.0], [R, R, R], [R, -R, -R], [-R, R, -R], [-R, -R, R]])
    tets = np.array([[0, 1, 2, 3], [0, 1, 4, 2], [0, 1, 3, 4], [0, 2, 4, 3]])
    return points, tets


def test_an_edge_between_two_locked_vertices_is_not_split():
    points, tets = _four_cells()
    ball = sdf.sphere(1.0)
    locked = np.zeros(5, dtype=bool)
    locked[[1, 2]] = True
    assert split_edges(points, tets, ball, 0.5, np.array([[1, 2]]), locked)[2] == 0
    assert split_edges(points, tets, ball, 0.5, np.array([[1, 3]]), locked)[2] == 1
    assert split_edges(points, tets, ball, 0.5, np.array([[1, 2]]))[2] == 1


def test_a_cavity_split_keeps_out_of_locked_edges_and_faces():
    points, tets = _four_cells()
    ball = sdf.sphere(1.0)
    done = cavity_split(points, tets, ball, 0.5, (1, 2))[2]
    assert done
    locked = np.zeros(5, dtype=bool)
    locked[[1, 2]] = True
    assert not cavity_split(points, tets, ball, 0.5, (1, 2), locked=locked)[2]


def test_split_cells_keep_their_labels():
    # a labelled Delaunay mesh of a ball, two labels split by the plane x = 0.1; every edge not
    # between two nodes of a face between labels is split where it can be: each new cell lies in
    # one old cell and takes its label, so the volume of each label is what it was
    rng = np.random.default_rng(3)
    points = rng.uniform(-1, 1, (300, 3))
    points = points[np.linalg.norm(points, axis=1) < 0.95]
    tets = Delaunay(points).simplices
    flip = signed_volume(points[tets]) < 0
    tets[flip] = tets[flip][:, [1, 0, 2, 3]]
    labels = (points[tets].mean(axis=1)[:, 0] > 0.1).astype(np.int64)
    faces = tets[:, [[1, 2, 3], [0, 2, 3], [0, 1, 3], [0, 1, 2]]].reshape(-1, 3)
    keys = face_keys(faces, len(points))
    owner = np.repeat(labels, 4)
    order = np.argsort(keys, kind="stable")
    twin = keys[order][1:] == keys[order][:-1]
    between = twin & (owner[order][1:] != owner[order][:-1])
    locked = np.zeros(len(points), dtype=bool)
    locked[faces[order[1:][between]].ravel()] = True
    edges = np.unique(np.sort(tets[:, [0, 1]], axis=1), axis=0)
    new_points, new_tets, splits = split_edges(points, tets, sdf.sphere(10.0), 1.0, edges, locked)
    assert splits > 20
    new_labels = refined_labels(new_points, tets, labels, new_tets)
    volume = signed_volume(points[tets])
    new_volume = signed_volume(new_points[new_tets])
    for k in (0, 1):
        assert new_volume[new_labels == k].sum() == pytest.approx(volume[labels == k].sum(), rel=1e-12)


def _cap():
    """Two cells on a flat face, one of them on a cap (the boundary_edge_round example)."""
    half = sdf.plane((0, 0, 1))
    p = np.array([[-1, 0, 0], [1, 0, 0], [0, -0.05, 0], [0, 1, 0], [0, 0.2, -1.0]], float)
    tets = np.array([[0, 1, 2, 4], [1, 0, 3, 4]])
    faces = np.array([[0, 2, 1], [0, 1, 3]])
    on = np.array([True, True, True, True, False])
    keys = np.sort(face_keys(faces, 5))
    edges = np.unique(edge_keys(np.array([[0, 1], [1, 2], [0, 2], [1, 3], [0, 3]]), 5))
    return half, p, tets, on, keys, edges


@pytest.mark.parametrize("labels, flips", [([4, 4], 1), ([4, 5], 0)])
def test_a_boundary_edge_is_flipped_only_within_one_label(labels, flips):
    half, p, tets, on, keys, edges = _cap()
    targets = ShapeTargets()
    q = targets.score(p[tets])
    result = boundary_edge_round(p, tets, q, 33.0, on, keys, edges, targets=targets,
                                 guard=SurfaceGuard(half, 1.0, p, on), labels=np.array(labels))
    assert result[2] == flips
    assert len(result[6]) == len(result[0])
    if flips:
        assert (result[6] == 4).all()


def _crowded_ball():
    """The collapse_round example: cube corners on the unit sphere, its centre, and a ninth
    surface vertex (9) crowding corner 1."""
    corners = np.array([[1, 1, 1], [1, -1, -1], [-1, 1, -1], [-1, -1, 1], [-1, -1, -1], [1, 1, -1],
                        [1, -1, 1], [-1, 1, 1]]) / np.sqrt(3)
    near = corners[0] + [0.08, -0.06, 0.0]
    points = np.vstack([[0.0, 0.0, 0.0], corners, near / np.linalg.norm(near)])
    tets = Delaunay(points).simplices
    flipped = signed_volume(points[tets]) < 0
    tets[flipped] = tets[flipped][:, [1, 0, 2, 3]]
    return points, tets


@pytest.mark.parametrize("split", [False, True])
def test_a_vertex_is_collapsed_only_within_one_label(split):
    points, tets = _crowded_ball()
    # labels: one for every cell, or a second one for the cells at vertex 9 on one side
    labels = np.zeros(len(tets), dtype=np.int64)
    if split:
        at_nine = np.flatnonzero((tets == 9).any(axis=1))
        labels[at_nine[0]] = 1
    on = np.ones(10, dtype=bool)
    on[0] = False
    free, removable = on.copy(), on.copy()
    targets, ball = ShapeTargets(), sdf.sphere(1.0)
    q = targets.score(points[tets])
    faces = faces_on_boundary(tets, face_neighbours(tets, 10))
    keys = np.sort(face_keys(faces, 10))
    edges = np.unique(edge_keys(faces[:, [0, 1, 1, 2, 2, 0]].reshape(-1, 2), 10))
    result = collapse_round(points, tets, q, 33.0, on, free, removable, keys, edges, targets=targets,
                            guard=SurfaceGuard(ball, 4.0, points, on), labels=labels)
    assert result[2] == (0 if split else 1)
    assert len(result[6]) == len(result[0])
