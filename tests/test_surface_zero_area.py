"""Zero-area triangles with collinear corners are flipped away, the surface unchanged (issue 12,
item 4: a written STL has no degenerate triangle)."""

import numpy as np
import pyvista as pv
import pytest

import fepre
from fepre import corpus
from fepre.surface.zero_area import collapse_coincident, flip_zero_area


def _octahedron_with_a_split_edge():
    """An octahedron whose edge 0-2 carries an extra vertex at its middle (index 6), on both sides."""
    points = np.array([[1, 0, 0], [-1, 0, 0], [0, 1, 0], [0, -1, 0], [0, 0, 1], [0, 0, -1], [0.5, 0.5, 0]], float)
    faces = np.array([
        [0, 6, 4], [6, 2, 4],          # the two faces on edge 0-2 above, split at 6
        [2, 1, 4], [1, 3, 4], [3, 0, 4],
        [6, 0, 5], [2, 6, 5],          # below, split at 6
        [1, 2, 5], [3, 1, 5], [0, 3, 5],
    ])
    return points, faces


def test_a_triangle_with_a_corner_on_its_longest_edge_is_flipped_and_the_surface_kept():
    points, faces = _octahedron_with_a_split_edge()
    # replace the split pair above by the triangle (0, 2, 4) and a zero-area one (0, 6, 2)
    bad = np.vstack([faces[2:5], faces[5:], [[0, 2, 4], [0, 6, 2]]])
    before = fepre.check_surface(pv.PolyData(points, np.hstack([np.full((len(bad), 1), 3), bad]).ravel()))
    assert before.degenerate_triangles == 1
    flipped = flip_zero_area(points, bad)
    after = fepre.check_surface(pv.PolyData(points, np.hstack([np.full((len(flipped), 1), 3), flipped]).ravel()))
    assert after.degenerate_triangles == 0
    assert (after.watertight, after.manifold, after.genus) == (True, True, 0)
    assert after.volume == pytest.approx(before.volume) and after.area == pytest.approx(before.area)
    # the flip gives back the split pair
    assert sorted(map(sorted, flipped[-2:].tolist())) == sorted(map(sorted, faces[:2].tolist()))


def test_dual_contouring_along_a_rotated_crease_has_no_zero_area_triangle():
    """A rotated box standing on another (corpus part tiny-0, seed 0) had two zero-area
    triangles along a crease at spacing 0.37 h, at any scale."""
    part = {p.name: p for p in corpus.parts(0, 1)}["tiny-0"]
    surface = fepre.isosurface(part.model, method="dual_contouring", spacing=0.37 * part.h)
    check = fepre.check_surface(surface)
    assert (check.watertight, check.manifold, check.degenerate_triangles) == (True, True, 0)


def test_a_zero_length_edge_is_collapsed_only_where_the_surface_stays_a_manifold():
    # an octahedron whose apex 4 is split into 4 and a copy 6: the top faces on the 3 side
    # take 6, and the two zero-area triangles (0, 4, 6) and (1, 6, 4) close the seam
    points = np.array([[1, 0, 0], [-1, 0, 0], [0, 1, 0], [0, -1, 0], [0, 0, 1], [0, 0, -1], [0, 0, 1]], float)
    faces = np.array([
        [0, 2, 4], [2, 1, 4], [1, 3, 6], [3, 0, 6], [0, 4, 6], [1, 6, 4],
        [2, 0, 5], [1, 2, 5], [3, 1, 5], [0, 3, 5],
    ])
    before = fepre.check_surface(pv.PolyData(points, np.hstack([np.full((len(faces), 1), 3), faces]).ravel()))
    assert before.watertight and before.degenerate_triangles == 2
    p, t = collapse_coincident(points, faces, 1e-9)
    after = fepre.check_surface(pv.PolyData(p, np.hstack([np.full((len(t), 1), 3), t]).ravel()))
    assert (len(p), len(t)) == (6, 8)
    assert (after.watertight, after.manifold, after.oriented, after.genus, after.degenerate_triangles) == (True, True, True, 0, 0)
    assert after.volume == pytest.approx(4 / 3)
    # a tetrahedron with two corners at one point would collapse to a double triangle: left alone
    pinched = np.array([[0, 1, 2], [1, 0, 3], [0, 2, 3], [1, 3, 2]])  # a tetrahedron
    same = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]], float)
    same[1] = same[0]
    assert collapse_coincident(same, pinched, 1e-9)[1].shape == (4, 3)


@pytest.mark.parametrize("name, factor", [("tiny-1", 0.5), ("far-0", 0.37)])
def test_dual_contouring_on_the_last_corpus_pairs_with_degenerate_triangles(name, factor):
    """Two pieces of one cell on one crease corner (tiny-1) and corners on a crease 7000 from
    the origin, off their line by rounding (far-0), gave one or two degenerate triangles."""
    part = {p.name: p for p in corpus.parts(0, 4, ["tiny", "far"])}[name]
    surface = fepre.isosurface(part.model, method="dual_contouring", spacing=factor * part.h)
    check = fepre.check_surface(surface)
    assert (check.watertight, check.manifold, check.degenerate_triangles) == (True, True, 0)
    assert surface.volume == pytest.approx(part.volume, rel=0.01)
