"""The quality stage's second series of insertions: inner vertices crowding another collapsed,
chords off the surface split first; a flap removed with its apex; and Delaunay's repeated points."""

from __future__ import annotations

import numpy as np
from scipy.spatial import Delaunay

from fepre import sdf
from fepre.quality import dihedral_angles
from fepre.distmesh import delaunay
from fepre.distmesh.bad_cell_splits import split_candidates
from fepre.distmesh.edge_collapse import collapse_round
from fepre.distmesh.surface_guard import SurfaceGuard
from fepre.distmesh.tet_shape import ShapeTargets, signed_volume
from fepre.distmesh.tet_topology import edge_keys, face_keys, face_neighbours, faces_on_boundary


def _crowded_ball():
    """The unit ball as the Delaunay cells of 150 surface points (a Fibonacci spiral) and 40
    inner ones at least 0.25 apart, with one more 0.05 from inner vertex 150 (the crowder,
    the last)."""
    k = np.arange(150) + 0.5
    polar, azimuth = np.arccos(1 - 2 * k / 150), np.pi * (1 + 5**0.5) * k
    surface = np.stack([np.sin(polar) * np.cos(azimuth), np.sin(polar) * np.sin(azimuth), np.cos(polar)], 1)
    rng, inner = np.random.default_rng(5), []
    while len(inner) < 40:
        p = rng.uniform(-0.7, 0.7, 3)
        if np.linalg.norm(p) < 0.7 and all(np.linalg.norm(p - q) > 0.25 for q in inner):
            inner.append(p)
    points = np.vstack([surface, inner, inner[0] + np.array([0.03, 0.03, 0.025])])
    return points, _oriented_delaunay(points)


def _oriented_delaunay(points):
    tets = Delaunay(points).simplices
    flipped = signed_volume(points[tets]) < 0
    tets[flipped] = tets[flipped][:, [1, 0, 2, 3]]
    return tets


def _collapse(points, tets, inner: bool, surface_points: int = 150):
    """One round of collapses on the ball: the first ``surface_points`` points are its surface."""
    n = len(points)
    on_boundary = np.arange(n) < surface_points
    targets = ShapeTargets()
    quality = targets.score(points[tets])
    faces = faces_on_boundary(tets, face_neighbours(tets, n))
    keys = np.sort(face_keys(faces, n))
    edges = np.unique(edge_keys(faces[:, [0, 1, 1, 2, 2, 0]].reshape(-1, 2), n))
    movable, removable = np.ones(n, bool), np.ones(n, bool)
    guard = SurfaceGuard(sdf.sphere(1.0), 0.3, points, on_boundary)
    return keys, collapse_round(points, tets, quality, 25.0, on_boundary.copy(), movable, removable, keys, edges,
                                targets=targets, guard=guard, inner=inner)


def test_an_inner_vertex_crowding_another_is_collapsed_into_it():
    points, tets = _crowded_ball()
    crowded = (tets == 150).any(axis=1) & (tets == 190).any(axis=1)
    assert ShapeTargets().score(points[tets[crowded]]).max() < 25.0  # every cell on the short edge is bad
    keys, (new_tets, _, done, _, _, _) = _collapse(points, tets, inner=False)
    assert done == 0  # boundary edges only: the pair stays
    keys, (new_tets, new_quality, done, new_keys, _, _) = _collapse(points, tets, inner=True)
    assert done >= 1
    left = set(np.unique(new_tets).tolist())
    assert len({150, 190} & left) == 1  # one of the pair went into the other
    assert set(range(150)) <= left  # no boundary vertex went
    volumes = signed_volume(points[new_tets])
    assert (volumes > 0).all() and np.isclose(volumes.sum(), signed_volume(points[tets]).sum())
    np.testing.assert_allclose(new_quality, ShapeTargets().score(points[new_tets]))
    assert np.array_equal(new_keys, keys)  # the boundary is unchanged
    faces = faces_on_boundary(new_tets, face_neighbours(new_tets, len(points)))
    assert np.array_equal(np.sort(face_keys(faces, len(points))), keys)


def test_a_chord_off_the_surface_is_split_first():
    # an octahedron as four cells around its axis; marked, the equator edge (2, 3) goes first
    ring = [[1, 0, 0], [0, 1, 0], [-1, 0, 0], [0, -1, 0]]
    points = np.array([[0, 0, 1.0], [0, 0, -1.0]] + ring, dtype=float)
    tets = np.array([[0, 1, 2 + i, 2 + (i + 1) % 4] for i in range(4)])
    tets[signed_volume(points[tets]) < 0] = tets[signed_volume(points[tets]) < 0][:, [0, 1, 3, 2]]
    off = np.zeros((4, 6))
    cell = int(np.flatnonzero((np.sort(tets, axis=1)[:, 2:] == [2, 3]).all(axis=1))[0])
    local = [sorted(tets[cell][list(e)]) for e in ((0, 1), (0, 2), (0, 3), (1, 2), (1, 3), (2, 3))]
    off[cell, local.index([2, 3])] = 0.3
    candidates = split_candidates(points, tets, np.array([cell, *np.setdiff1d(np.arange(4), [cell])]),
                                  len(points), off)
    assert candidates[0].tolist() == [2, 3]
    assert candidates[1].tolist() == [0, 1]  # the other wedges' inner edge, as without marks


def test_repeated_points_are_triangulated_once_and_silently(capfd):
    points = np.random.default_rng(3).random((300, 3))
    points = np.vstack([points, points[[7, 42]], points[[7]]])
    tets = delaunay._gmsh(points, threads=1)
    out, err = capfd.readouterr()
    assert "duplicate" not in out + err
    alone = delaunay._gmsh(points[:300], threads=1)
    assert np.array_equal(np.sort(np.sort(tets, axis=1), axis=0), np.sort(np.sort(alone, axis=1), axis=0))


def test_collapses_keep_the_boundary_they_report():
    """Over seeded balls with surface points inside surface triangles near a corner (three
    surface neighbours each, one close), a round of collapses returns the boundary faces the
    cells really have. (On camelhead at (D/50, D/12) a collapse once reported a boundary face
    that two cells held, the stage refused its own result and DistMesh's 0.5 deg mesh came back;
    this invariant test does not rebuild that configuration, `_boundary_as_kept` guards it.)"""
    for seed in range(6):
        rng = np.random.default_rng(seed)
        points, tets = _crowded_ball()
        hull = faces_on_boundary(tets, face_neighbours(tets, len(points)))
        picked = hull[rng.choice(len(hull), 12, replace=False)]
        weights = np.array([0.8, 0.1, 0.1])  # inside a surface triangle, near its first corner
        near = np.einsum("k,ikj->ij", weights, points[picked])
        near /= np.linalg.norm(near, axis=1)[:, None]
        points = np.vstack([points[:150], near, points[150:]])
        tets = _oriented_delaunay(points)
        n = len(points)
        _, (new_tets, _, done, new_keys, _, _) = _collapse(points, tets, inner=False, surface_points=162)
        actual = np.sort(face_keys(faces_on_boundary(new_tets, face_neighbours(new_tets, n)), n))
        assert np.array_equal(actual, np.sort(new_keys)), seed
        assert done >= 6
        assert (signed_volume(points[new_tets]) > 0).all()


def _flapped_ball():
    """The ball of ``_crowded_ball`` without the crowder, and a flap on it: a cell on one boundary
    face whose fourth vertex (the last) lies on the sphere over the face's centroid, so the cell
    holds three boundary faces, lies flat on the surface and has no short edge."""
    points, _ = _crowded_ball()
    points = points[:-1]
    tets = _oriented_delaunay(points)
    faces = faces_on_boundary(tets, face_neighbours(tets, len(points)))
    sides = np.linalg.norm(points[faces] - points[np.roll(faces, 1, axis=1)], axis=2)
    face = faces[np.argmax(sides.min(axis=1) / sides.max(axis=1))]  # the roundest boundary face
    centre = points[face].mean(axis=0)
    apex = len(points)
    points = np.vstack([points, centre / np.linalg.norm(centre)])
    flap = np.array([[face[0], face[1], face[2], apex]])
    flap[signed_volume(points[flap]) < 0] = flap[signed_volume(points[flap]) < 0][:, [1, 0, 2, 3]]
    return points, np.vstack([tets, flap]), apex


def test_a_flap_on_the_surface_goes_with_its_apex_even_when_pinned():
    """A cell with three boundary faces (their common vertex in no other cell) flat on the surface:
    the spout tip of teapot.obj at D/50 kept such flaps (3.0-4.6 deg) where the surface folds over a
    part thinner than h; their edges were 0.5-0.8 of the cell's longest (no short edge) and the
    apex was pinned as a crease node (its folded faces' normals disagree). The round removes the
    apex with its cell and the face under it becomes a boundary face again."""
    points, tets, apex = _flapped_ball()
    n = len(points)
    targets = ShapeTargets()
    quality = targets.score(points[tets])
    flap = tets[-1]
    lengths = np.linalg.norm(points[flap[:, None]] - points[flap[None]], axis=2)
    assert lengths.max() / lengths[lengths > 0].min() < 2.0  # no short edge (relative > 0.5)
    around = np.isin(tets, flap).any(axis=1)  # the flap and the cells sharing a vertex with it
    before = dihedral_angles(points, tets[around])
    assert before.min() < 10.0 and before.max() > 160.0  # the flap: 9.5 and 163 deg
    on_boundary = np.arange(n) < 150
    on_boundary[apex] = True
    faces = faces_on_boundary(tets, face_neighbours(tets, n))
    assert np.count_nonzero((faces == apex).any(axis=1)) == 3
    keys = np.sort(face_keys(faces, n))
    edges = np.unique(edge_keys(faces[:, [0, 1, 1, 2, 2, 0]].reshape(-1, 2), n))
    movable, removable = np.ones(n, bool), np.ones(n, bool)
    movable[apex] = False  # pinned: crease_nodes flags a flap's apex
    guard = SurfaceGuard(sdf.sphere(1.0), 0.3, points, on_boundary)
    new_tets, _, done, new_keys, _, _ = collapse_round(
        points, tets, quality, 25.0, on_boundary, movable, removable, keys, edges, targets=targets, guard=guard)
    assert done >= 1 and not (new_tets == apex).any()
    after = dihedral_angles(points, new_tets[np.isin(new_tets, flap).any(axis=1)])
    assert after.min() > 30.0 and after.max() < 150.0
    assert len(new_keys) == len(keys) - 2  # three faces at the apex became the one under it
    assert np.isclose(signed_volume(points[new_tets]).sum(), signed_volume(points[tets[:-1]]).sum())
