"""The compiled per-cell kernels against independent array computations."""

import numpy as np
import pytest

from fepre._cell_kernels import face_uses, packed_face_keys, quality_arrays, volume_edge_ratios
from fepre.quality import dihedral_angles, signed_volumes, tet_quality


def _cells(seed: int, count: int = 2000):
    rng = np.random.default_rng(seed)
    points = rng.normal(size=(4 * count, 3))
    tets = np.arange(4 * count).reshape(-1, 4)
    # flat cells (four coplanar points), a repeated corner, a needle
    points[:4] = [[0, 0, 0], [1, 0, 0], [0, 1, 0], [1, 1, 0]]
    points[4:8] = [[0, 0, 0], [0, 0, 0], [0, 1, 0], [0, 0, 1]]
    points[8:12] = [[0, 0, 0], [1e-9, 0, 0], [0, 1e-9, 0], [0, 0, 5]]
    return points, tets


def _circumradius(corners):
    """Radius of the sphere through the four corners, from the linear system of its centre."""
    a = 2.0 * (corners[:, 1:] - corners[:, :1])
    b = (corners[:, 1:] ** 2).sum(axis=2) - (corners[:, :1] ** 2).sum(axis=2)
    centre = np.linalg.solve(a, b[..., None])[..., 0]
    return np.linalg.norm(centre - corners[:, 0], axis=1)


@pytest.mark.parametrize("seed", [0, 1])
def test_quality_arrays_match_independent_formulas(seed):
    points, tets = _cells(seed)
    quality = tet_quality(points, tets)
    dihedral = dihedral_angles(points, tets)
    np.testing.assert_allclose(quality["min_dihedral_angle"], dihedral.min(axis=1), atol=1e-9)
    np.testing.assert_allclose(quality["max_dihedral_angle"], dihedral.max(axis=1), atol=1e-9)
    volume = signed_volumes(points, tets)
    np.testing.assert_allclose(quality["volume"], volume, rtol=1e-12, atol=1e-15)
    corners = points[tets]
    regular = np.abs(volume) > 1e-6
    faces = corners[:, [[1, 2, 3], [0, 3, 2], [0, 1, 3], [0, 2, 1]]]
    areas = 0.5 * np.linalg.norm(np.cross(faces[:, :, 1] - faces[:, :, 0], faces[:, :, 2] - faces[:, :, 0]), axis=2)
    inradius = 3.0 * np.abs(volume) / areas.sum(axis=1)
    expected = np.sign(volume[regular]) * 3.0 * inradius[regular] / _circumradius(corners[regular])
    np.testing.assert_allclose(quality["radius_ratio"][regular], expected, rtol=1e-8)
    edges = corners[:, [1, 2, 3, 2, 3, 3]] - corners[:, [0, 0, 0, 1, 1, 2]]
    l_rms = np.sqrt((edges**2).sum(axis=2).mean(axis=1))
    np.testing.assert_allclose(quality["volume_edge_ratio"], 6 * np.sqrt(2) * volume / l_rms**3, rtol=1e-10, atol=1e-15)
    np.testing.assert_allclose(volume_edge_ratios(points, tets), quality["volume_edge_ratio"], rtol=1e-12, atol=1e-15)
    # the flat cell and the cell with a repeated corner: zero volume and ratios, finite angles
    assert quality["volume"][:2].tolist() == [0.0, 0.0] and quality["radius_ratio"][:2].tolist() == [0.0, 0.0]
    assert np.isfinite(quality_arrays(points, tets)).all()


def test_regular_tetrahedron_scores_one():
    p = np.array([[1, 1, 1], [1, -1, -1], [-1, 1, -1], [-1, -1, 1]], float)
    q = tet_quality(p, [[0, 2, 1, 3]])
    assert q["radius_ratio"][0] == pytest.approx(1.0, abs=1e-12)
    assert q["volume_edge_ratio"][0] == pytest.approx(1.0, abs=1e-12)
    assert q["min_dihedral_angle"][0] == pytest.approx(np.degrees(np.arccos(1 / 3)), abs=1e-9)
    assert tet_quality(p, np.zeros((0, 4), int))["volume"].shape == (0,)


def test_packed_face_keys_ignore_vertex_order():
    rng = np.random.default_rng(3)
    tets = rng.integers(0, 1000, size=(500, 4))
    keys = packed_face_keys(tets, 1000)
    faces = np.sort(tets[:, [[1, 2, 3], [0, 3, 2], [0, 1, 3], [0, 2, 1]]].reshape(-1, 3), axis=1)
    assert (keys == (faces[:, 0] * 1000 + faces[:, 1]) * 1000 + faces[:, 2]).all()
    assert (packed_face_keys(tets[:, [3, 1, 2, 0]], 1000).reshape(-1, 4)[:, [3, 1, 2, 0]].ravel() == keys).all()


def test_face_uses_match_a_dictionary_of_faces():
    """Each face slot's use count and lowest other slot, against a dict of sorted triples, on
    a Delaunay triangulation (faces in one or two cells) plus a face in three and cells that
    repeat a face in all four slots."""
    from scipy.spatial import Delaunay

    rng = np.random.default_rng(5)
    points = rng.random((300, 3))
    tets = Delaunay(points).simplices.astype(np.int64)
    tets = np.concatenate([tets, tets[:1, [1, 0, 2, 3]], tets[5:7]])  # face in three, two whole cells twice
    mate, uses = face_uses(tets, len(points))
    slots: dict = {}
    for slot, face in enumerate(np.sort(tets[:, [[1, 2, 3], [0, 3, 2], [0, 1, 3], [0, 2, 1]]].reshape(-1, 3), axis=1)):
        slots.setdefault(tuple(face), []).append(slot)
    for group in slots.values():
        for slot in group:
            others = [other for other in group if other != slot]
            assert uses[slot] == len(group)
            assert mate[slot] == (min(others) if others else -1)
    assert max(len(group) for group in slots.values()) == 3
    assert face_uses(np.zeros((0, 4), np.int64), 0)[0].shape == (0,)


def test_shape_extremes_match_fepre_quality():
    """The quality stage's one-pass measures against fepre.quality's (independent formulas) on
    positive cells, and -1 for the flat, inverted and degenerate ones."""
    from fepre._cell_kernels import shape_extremes

    points, tets = _cells(2)
    corners = points[tets]
    smallest, largest, ratio = shape_extremes(corners, 1e-9)
    reference = tet_quality(points, tets)
    positive = signed_volumes(points, tets) > 1e-6
    assert positive.sum() > 900 and (~positive).sum() > 900
    assert np.allclose(smallest[positive], reference["min_dihedral_angle"][positive], atol=1e-9)
    assert np.allclose(largest[positive], reference["max_dihedral_angle"][positive], atol=1e-9)
    assert np.allclose(ratio[positive], reference["radius_ratio"][positive], atol=1e-12)
    invalid = signed_volumes(points, tets) <= 0
    assert (smallest[invalid] == -1).all() and (largest[invalid] == -1).all() and (ratio[invalid] == -1).all()
    assert smallest[:3].tolist() == [-1.0, -1.0, -1.0]  # flat, repeated corner, needle


def test_ideal_positions_match_the_array_form_bit_for_bit():
    """The relaxation's targets: the compiled pass against the array formulas it replaced (the
    same operations in the same order), on random, flat and degenerate cells; and each target
    makes its cell regular when moved there (a regular base stays regular)."""
    from fepre.distmesh.tet_shape import REGULAR_HEIGHT, ideal_vertex_positions

    points, tets = _cells(3)
    corners = points[tets]
    a, b, c, d = (corners[:, i].T for i in range(4))
    u, v, w = b - a, c - a, d - a
    bc, bd, cd = v - u, w - u, w - v
    length = [np.sqrt(e[0] * e[0] + e[1] * e[1] + e[2] * e[2]) for e in (u, v, w, bc, bd, cd)]
    lu, lv, lw, lbc, lbd, lcd = length
    mean_edge = ((lbc + lbd + lcd), (lv + lw + lcd), (lu + lw + lbd), (lu + lv + lbc))
    normals = (np.cross(bd.T, bc.T).T, np.cross(v.T, w.T).T, np.cross(w.T, u.T).T, np.cross(u.T, v.T).T)
    total = a + b + c + d
    expected = np.empty((4, 3, len(tets)))
    for i, corner in enumerate((a, b, c, d)):
        n = normals[i]
        norm = np.sqrt(n[0] * n[0] + n[1] * n[1] + n[2] * n[2])
        expected[i] = (total - corner) / 3.0 + (REGULAR_HEIGHT / 3.0) * mean_edge[i] / np.where(norm > 0, norm, 1.0) * n
    found = ideal_vertex_positions(points, tets)
    assert np.allclose(found, expected, rtol=0, atol=1e-12)
    assert np.isfinite(found).all()
    base = np.array([[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.5, np.sqrt(3) / 2, 0.0], [0.2, 0.3, 0.05]])
    apex = ideal_vertex_positions(base, np.array([[0, 1, 2, 3]]))[3, :, 0]
    regular = np.vstack([base[:3], apex])
    edges = np.linalg.norm(regular[:, None] - regular[None], axis=2)[np.triu_indices(4, 1)]
    assert np.allclose(edges, 1.0, atol=1e-12)


def test_the_counting_passes_give_the_same_groups_for_any_number_of_chunks():
    """The face and edge groupings count and fill per chunk of cells on every core: their
    output (a stable counting sort) must not depend on how many chunks there are."""
    from scipy.spatial import Delaunay

    from fepre._cell_kernels import _FACES, _bucket_by_lowest, _sorted_faces
    from fepre.distmesh._bar_kernels import _edges_by_lowest
    from fepre._cell_kernels import _EDGES as EDGES

    points = np.random.default_rng(5).random((3000, 3))
    tets = Delaunay(points).simplices.astype(np.int64)
    n = np.int64(len(points))
    lo, mid, hi = (np.empty(4 * len(tets), np.int32) for _ in range(3))
    _sorted_faces(tets, _FACES, lo, mid, hi)
    faces = [_bucket_by_lowest(lo, mid, hi, n, np.int64(chunks)) for chunks in (1, 2, 7, 64)]
    edges = [_edges_by_lowest(tets, np.asarray(EDGES, np.int64), n, np.int64(chunks)) for chunks in (1, 2, 7, 64)]
    for start, key, slots in faces[1:]:
        for found, expected in zip((start, key, slots), faces[0]):
            np.testing.assert_array_equal(found, expected)
    for start, other in edges[1:]:
        np.testing.assert_array_equal(start, edges[0][0])
        np.testing.assert_array_equal(other, edges[0][1])
    # the serial definition: slots in ascending order within each lowest vertex
    start, key, slots = faces[0]
    np.testing.assert_array_equal(slots, np.argsort(lo, kind="stable"))
    np.testing.assert_array_equal(start, np.concatenate([[0], np.cumsum(np.bincount(lo, minlength=len(points)))]))


def test_corner_volumes_match_the_array_form_bit_for_bit():
    from fepre._cell_kernels import corner_volumes
    from fepre.distmesh.tet_shape import signed_volume

    points, tets = _cells(4)
    np.testing.assert_array_equal(corner_volumes(points, tets), signed_volume(points[tets]))
    assert corner_volumes(points, tets)[:2].tolist() == [0.0, 0.0]  # flat, repeated corner
    unit = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1.0]])
    assert corner_volumes(unit, np.array([[0, 1, 2, 3], [0, 2, 1, 3]])).tolist() == [1 / 6, -1 / 6]


@pytest.mark.parametrize("points, cells", [(10, 7), (1000, 6000), (5, 0)])
def test_cells_by_vertex_is_the_stable_sort_of_the_cells_corners(points, cells):
    from fepre._cell_kernels import cells_by_vertex

    tets = np.random.default_rng(points).integers(0, points, size=(cells, 4))
    offsets, found = cells_by_vertex(tets, points + 2)  # two vertices in no cell
    flat = tets.ravel()
    assert np.array_equal(found, np.argsort(flat, kind="stable") // 4)
    assert np.array_equal(np.diff(offsets), np.bincount(flat, minlength=points + 2))
    assert offsets[0] == 0 and offsets[-1] == flat.size
