"""Boundary edges that cut across a concave crease: flipped onto the crease, or their cell removed."""

from __future__ import annotations

import numpy as np
import pytest

import fepre
from fepre import sdf
from fepre.distmesh.tet_topology import face_neighbours, faces_on_boundary
from fepre.features import features
from fepre.quality import signed_volumes


def _positive(points, tets):
    tets = np.array(tets)
    negative = signed_volumes(points, tets) < 0
    tets[negative] = tets[negative][:, [1, 0, 2, 3]]
    return tets


def test_a_cell_left_in_a_crease_corner_is_removed():
    from fepre.distmesh.crease_recovery import recover_creases

    # a notch's concave crease on the z axis; the cell 2 3 0 1 fills the corner's void between
    # a node of each face (2, 3) and two crease nodes (0, 1): both its faces at 2-3 are boundary
    notch = sdf.box(2.0) - sdf.box(2.0, center=(1, 1, 0))
    found = features(notch, h=0.5)
    points = np.array([[0, 0, -0.25], [0, 0, 0.25], [0, 0.3, 0], [0.3, 0, 0], [-0.4, -0.4, 0]], float)
    tets = _positive(points, [[0, 1, 2, 4], [0, 1, 3, 4], [2, 3, 0, 1]])
    before = signed_volumes(points, tets).sum()
    kept, changed = recover_creases(points, tets, notch, found, 0.5)
    assert changed == 1 and len(kept) == 2 and sorted(map(sorted, kept.tolist())) == [[0, 1, 2, 4], [0, 1, 3, 4]]
    assert signed_volumes(points, kept).sum() == pytest.approx(before - 0.3 * 0.3 * 0.5 / 6.0)
    # with the crease unknown (no features) nothing changes
    assert recover_creases(points, tets, notch, None, 0.5)[1] == 0


def _motor_plate():
    """A new user's part (session 52): a plate with a drafted hub, a bore, four bosses with holes
    and four pockets cut from below."""
    plate = sdf.box((120, 120, 12), center=(0, 0, 6))
    hub = sdf.cone(radius=32, height=96, center=(0, 0, 12)) & sdf.slab(normal=(0, 0, 1), thickness=12, center=(0, 0, 18))
    bosses = sdf.union(*[sdf.cylinder(radius=10, height=10, center=(40 * sx, 40 * sy, 17)) for sx in (-1, 1) for sy in (-1, 1)])
    holes = sdf.union(*[sdf.cylinder(radius=4, height=40, center=(40 * sx, 40 * sy, 10)) for sx in (-1, 1) for sy in (-1, 1)])
    pockets = sdf.union(*[sdf.box((15, 30, 12) if y == 0 else (30, 15, 12), center=(x, y, 0))
                          for x, y in ((40, 0), (-40, 0), (0, 40), (0, -40))])
    return (plate | hub | bosses) - sdf.cylinder(radius=20, height=60, center=(0, 0, 10)) - holes - pockets


@pytest.mark.slow  # 20 s of the default run on 2 cores
def test_graded_pocket_edges_are_kept_and_the_floor_set_is_exact():
    """The motor plate graded at h = (2, 10): the quality stage left cells in the corners of two
    pockets' edges (faces 0.39-0.48 off the surface, 0.16 h; the pockets' floor set 1796.7 for
    1800). They are removed: no boundary face strays 0.12 h off the surface, the floor is exact."""
    part = _motor_plate()
    mesh = fepre.distmesh(part, (2.0, 10.0))
    points, tets = np.asarray(mesh.points), np.asarray(mesh.cells.reshape(-1, 5)[:, 1:])
    faces = faces_on_boundary(tets, face_neighbours(tets, len(points)))
    corners = points[faces]
    edge = np.linalg.norm(corners - np.roll(corners, 1, axis=1), axis=2).mean(axis=1)
    assert np.max(np.abs(part(corners.mean(axis=1))) / edge) < 0.12
    sets = fepre.export.tag_boundaries(mesh, {"floors": sdf.plane((0, 0, -1), (0, 0, 6))})
    chosen = np.asarray(sets["boundary_id"]) == 0
    tri = np.asarray(sets.points)[np.asarray(sets.faces).reshape(-1, 4)[chosen, 1:]]
    area = 0.5 * np.linalg.norm(np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0]), axis=1).sum()
    assert area == pytest.approx(4 * 30 * 15, rel=1e-9)


def test_a_cell_is_removed_only_where_the_boundary_stays_a_manifold():
    # a lattice's Delaunay cells: a cell touching the boundary along an edge only (no face on
    # it) would leave that edge in four boundary faces; one with a face on it may go
    from scipy.spatial import Delaunay

    from fepre.distmesh.crease_recovery import _remove_soundly
    from fepre.distmesh.tet_topology import EDGE_OF_TET, edge_keys

    grid = np.stack(np.meshgrid(*[np.arange(3.0)] * 3, indexing="ij"), -1).reshape(-1, 3)
    points = grid + np.random.default_rng(1).uniform(-0.05, 0.05, grid.shape) * (grid % 2 == 1)
    tets = _positive(points, Delaunay(points).simplices)
    n = len(points)
    faces = faces_on_boundary(tets, face_neighbours(tets, n))
    surface_edges = np.unique(edge_keys(faces[:, [[0, 1], [1, 2], [2, 0]]].reshape(-1, 2), n))
    on_surface = np.isin(tets, np.unique(faces))
    face_count = np.array([sum(set(f) <= set(t) for f in faces.tolist()) for t in tets.tolist()])
    edge_only = [k for k, t in enumerate(tets) if face_count[k] == 0
                 and np.isin(edge_keys(t[EDGE_OF_TET], n), surface_edges).any()]
    with_face = [k for k in range(len(tets)) if face_count[k] == 1 and on_surface[k].sum() == 3]
    assert edge_only and with_face
    kept, removed = _remove_soundly(tets, np.array(edge_only[:1]), n)
    assert removed == 0 and len(kept) == len(tets)
    kept, removed = _remove_soundly(tets, np.array([with_face[0], edge_only[0]]), n)
    assert removed == 1 and len(kept) == len(tets) - 1
