"""The seeded random-part corpus and its independent validator (issue 12).

The quick subset (one part per category) runs by default; ``fepre bench corpus`` runs the whole
corpus with pytetwild beside it.
"""

from __future__ import annotations

import numpy as np
import pytest

import fepre
from fepre import corpus, quality, sdf
from fepre.corpus.run import judge, mesh_part
from fepre.corpus.validate import cell_measures, check_mesh, monte_carlo_volume

REGULAR = np.array([[1, 1, 1], [1, -1, -1], [-1, 1, -1], [-1, -1, 1]], float)
CORNER = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]], float)


def test_validator_measures_match_the_textbook_values():
    regular = cell_measures(REGULAR, np.array([[0, 1, 2, 3]]))
    assert regular["min_dihedral"][0] == pytest.approx(np.degrees(np.arccos(1 / 3)))
    assert regular["max_dihedral"][0] == pytest.approx(np.degrees(np.arccos(1 / 3)))
    assert regular["radius_ratio"][0] == pytest.approx(1.0)
    assert regular["volume"][0] == pytest.approx(-8 / 3)  # this corner order is negatively oriented
    corner = cell_measures(CORNER, np.array([[0, 1, 2, 3]]))
    # the corner tetrahedron: right angles at the origin's edges, arccos(1/sqrt 3) at the others
    assert corner["max_dihedral"][0] == pytest.approx(90.0)
    assert corner["min_dihedral"][0] == pytest.approx(np.degrees(np.arccos(1 / np.sqrt(3))))
    inradius = (1 / 6) / ((3 * 0.5 + np.sqrt(3) / 2) / 3)
    assert corner["radius_ratio"][0] == pytest.approx(3 * inradius / (np.sqrt(3) / 2))


def test_validator_agrees_with_fepre_quality_on_a_mesh():
    model = sdf.box((3, 2, 2)) - sdf.sphere(0.8)
    mesh = fepre.distmesh(model, 0.4)
    points, tets = np.asarray(mesh.points), mesh.cells_dict[10]
    ours, theirs = cell_measures(points, tets), quality.tet_quality(points, tets)
    np.testing.assert_allclose(ours["min_dihedral"], theirs["min_dihedral_angle"], atol=1e-9)
    np.testing.assert_allclose(ours["max_dihedral"], theirs["max_dihedral_angle"], atol=1e-9)
    np.testing.assert_allclose(ours["radius_ratio"], theirs["radius_ratio"], atol=1e-9)
    check = check_mesh(points, tets, model, 0.4)
    assert check.valid, check.problems
    assert check.components == 1


def test_validator_finds_each_kind_of_invalid_mesh():
    model = sdf.box((10, 10, 10))  # far from these points: boundary distance is not the point here
    h = 1e6
    two = np.array([[0, 1, 2, 3], [0, 2, 1, 4]])
    points = np.vstack([CORNER, [[0.2, 0.2, -1.0]]])
    assert check_mesh(points, two, model, h).valid
    flipped = check_mesh(points, two[:, [0, 2, 1, 3]], model, h)
    assert any("negative volume" in p for p in flipped.problems)
    tripled = check_mesh(np.vstack([points, [[0.2, 0.2, -2.0]]]), np.vstack([two, [[0, 2, 1, 5]]]), model, h)
    assert any("more than two cells" in p for p in tripled.problems)
    # two tetrahedra meeting at one vertex: a pinched boundary vertex
    bow = np.vstack([CORNER, -CORNER[1:]])
    pinched = check_mesh(bow, np.array([[0, 1, 2, 3], [0, 5, 4, 6]]), model, h)
    assert any("pinched" in p for p in pinched.problems), pinched.problems
    assert pinched.components == 2
    off = check_mesh(CORNER, np.array([[0, 1, 2, 3]]), sdf.sphere(5.0), 1.0)
    assert any("from the zero set" in p for p in off.problems)


def test_monte_carlo_volume_of_a_part_with_a_hole():
    part = sdf.box((2, 2, 2)) - sdf.cylinder(0.5, 3)
    volume, error = monte_carlo_volume(part, (-1, -1, -1), (1, 1, 1), 400_000, seed=3)
    exact = 8 - np.pi * 0.25 * 2
    assert abs(volume - exact) < 4 * error
    assert error < 0.01


def test_the_corpus_is_the_same_for_the_same_seed_and_covers_every_category():
    first, again, other = corpus.parts(5, 2), corpus.parts(5, 2), corpus.parts(6, 2)
    assert [p.category for p in first[::2]] == list(corpus.CATEGORIES)
    probe = np.random.default_rng(0).uniform(-6, 6, (200, 3))
    for a, b, c in zip(first, again, other):
        scale = a.h
        np.testing.assert_array_equal(a.model(probe * scale), b.model(probe * scale))
        assert a.volume == b.volume
    assert any(a.volume != c.volume for a, c in zip(first, other) if a.volume is not None)
    aligned = [p for p in first if p.category in corpus.ALIGNED and p.name.endswith("-1")]
    for part in aligned:  # round dimensions, no rotation: faces on the planes of a 0.25 grid
        lower, upper = (np.asarray(b) for b in part.model.bounds)
        np.testing.assert_allclose(np.round(lower * 4) / 4, lower, atol=1e-12)
        np.testing.assert_allclose(np.round(upper * 4) / 4, upper, atol=1e-12)


@pytest.mark.parametrize("bad, match", [({"per_category": 0}, "per_category"), ({"categories": ["nope"]}, "categories")])
def test_corpus_arguments_are_checked(bad, match):
    with pytest.raises(ValueError, match=match):
        corpus.parts(0, **{"per_category": 1, **bad})


def test_the_judge_names_every_missed_target():
    part = corpus.parts(0, 1, ["reentrant"])[0]
    check = corpus.MeshCheck(10, 20.0, 160.0, 0.1, 1.0, 2, 0.0, ["1 pinched boundary vertices"])
    failures = judge(part, check, -0.02, [])
    assert len(failures) == 6  # invalid, three shapes, volume, components
    thin = corpus.parts(0, 1, ["acute"])[0]
    good = corpus.MeshCheck(10, 30.0, 140.0, 0.3, 1.0, 1, 0.0, [])
    assert judge(thin, good, -0.05, []) == ["lost 5.0% of the volume without a ResolutionWarning"]
    assert judge(thin, good, -0.05, ["ResolutionWarning"]) == []


QUICK = corpus.parts(seed=0, per_category=1)


@pytest.mark.parametrize("part", QUICK, ids=[p.name for p in QUICK])
def test_quick_corpus_part_meshes_to_the_targets(part):
    result = mesh_part(part)
    assert result.error is None, result.error
    assert result.passed, result.failures
    if part.resolvable:
        assert "ConvergenceWarning" not in result.warnings


SURFACE_PARTS = [p for p in corpus.parts(seed=0, per_category=2) if p.category in ("touching", "coplanar", "reentrant", "narrow_gap", "thin_plate")]


@pytest.mark.parametrize("method", ["flying_edges", "marching_cubes", "marching_tetrahedra", "surface_nets", "dual_contouring"])
@pytest.mark.parametrize("spacing", [0.5, 0.3])
def test_corpus_surfaces_are_closed_manifold_with_the_parts_topology(method, spacing):
    """On spacings that do (0.5: the aligned parts' faces lie on grid planes) and do not align.
    Surface nets and dual contouring pinched on 9 of these 24 part-spacing pairs (one vertex per
    cell where rotated parts put two pieces of surface in a cell)."""
    for part in SURFACE_PARTS:
        check = fepre.check_surface(fepre.isosurface(part.model, method=method, spacing=spacing))
        found = (check.watertight, check.manifold, check.components, check.genus, check.degenerate_triangles)
        assert found == (True, True, 1, 0, 0), (part.name, found)


def test_the_corpus_is_reachable_as_fepre_corpus():
    import fepre as top

    assert top.corpus.parts is corpus.parts and "corpus" in dir(top)
