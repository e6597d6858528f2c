"""Pieces of a mesh not joined through faces are named (fepre.distmesh.pieces)."""

from __future__ import annotations

import re
import warnings

import numpy as np
import pytest

import fepre
from fepre import sdf
from fepre.distmesh.pieces import mesh_pieces
from fepre.errors import ResolutionWarning


def test_pieces_of_two_blocks_and_a_lone_cell():
    tets = np.array([[0, 1, 2, 3], [1, 2, 3, 4], [10, 11, 12, 13], [11, 12, 13, 14], [12, 13, 14, 15], [20, 21, 22, 23]])
    labels, counts = mesh_pieces(tets, 24)
    assert counts.tolist() == [3, 2, 1]
    assert labels.tolist() == [1, 1, 0, 0, 0, 2]


def test_a_small_detached_piece_is_named_with_its_place():
    part = sdf.box((1, 1, 1)) | sdf.sphere(0.12, center=(0.9, 0, 0))
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        mesh = fepre.distmesh(part, h=0.1)
    labels, counts = mesh_pieces(mesh.cells_dict[10], mesh.n_points)
    assert len(counts) == 2 and counts[1] < 0.01 * counts.sum()
    messages = [str(w.message) for w in caught if issubclass(w.category, ResolutionWarning) and "pieces" in str(w.message)]
    assert len(messages) == 1 and "the mesh is in 2 pieces" in messages[0]
    x, y, z = map(float, re.search(r"cell\(s\) at \(([^)]*)\)", messages[0]).group(1).split(", "))
    assert np.hypot(x - 0.9, np.hypot(y, z)) < 0.05  # the ball's centre
    # the ball stands apart from the box (0.28 of a gap): no h joins it, and the line says so (a
    # new user's gyroid in a box, two corners of the lattice its own pieces, was told a smaller h
    # would join them; followed twice, it did not)
    assert "smaller h" not in messages[0]
    assert "no part of the model within an element joins them to the rest: the model's own pieces" in messages[0]


def test_one_piece_is_not_named():
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        fepre.distmesh(sdf.box((1, 1, 1)) - sdf.cylinder(0.2, 2.0), h=0.15)
    assert not [w for w in caught if "pieces" in str(w.message)]


def _blocks(*joints):
    """Two unit blocks 0.12 apart, with ``joints`` between them."""
    return sdf.union(sdf.box((1, 1, 1), center=(-0.56, 0, 0)), sdf.box((1, 1, 1), center=(0.56, 0, 0)), *joints)


def test_a_large_piece_cut_off_where_the_model_joins_it_is_named():
    # two blocks 0.12 apart joined by a plate 0.03 thick, at h = 0.15: the plate is lost and the
    # mesh is two pieces of about half the cells each, which the small-piece rule did not name
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        mesh = fepre.distmesh(_blocks(sdf.box((0.6, 0.3, 0.03))), h=0.15)
    labels, counts = mesh_pieces(mesh.cells_dict[10], mesh.n_points)
    assert len(counts) == 2 and counts[1] > 0.4 * counts.sum()
    messages = [str(w.message) for w in caught if "pieces" in str(w.message)]
    assert len(messages) == 1 and "(the model joins it to the rest)" in messages[0]
    assert "a smaller h (or hmin) keeps them joined" in messages[0]
    x = float(re.search(r"cell\(s\) at \(([^,]*),", messages[0]).group(1))
    assert abs(abs(x) - 0.56) < 0.05  # one of the blocks' centres


def test_separate_parts_of_comparable_size_are_not_named():
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        mesh = fepre.distmesh(_blocks(), h=0.15)
    assert len(mesh_pieces(mesh.cells_dict[10], mesh.n_points)[1]) == 2
    assert not [w for w in caught if "pieces" in str(w.message)]


def test_a_small_piece_cut_off_where_the_model_joins_it_is_dropped_and_named():
    # a 0.15 cube held by a plate 0.03 thick 0.12 off a unit block, at h = 0.15: the plate is
    # lost and the cube was written as a piece of 6 cells that nothing holds (libigl's armadillo at
    # D/25: a lone cell by a claw, written with exit 0); it is dropped, and its volume said
    part = sdf.union(sdf.box((1, 1, 1)), sdf.box((0.15, 0.15, 0.15), center=(0.695, 0, 0)),
                     sdf.box((0.16, 0.1, 0.03), center=(0.56, 0, 0)))
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        mesh = fepre.distmesh(part, h=0.15)
    assert len(mesh_pieces(mesh.cells_dict[10], mesh.n_points)[1]) == 1
    dropped, volume = mesh.field_data["distmesh_dropped_cells"][0], mesh.field_data["distmesh_dropped_volume"][0]
    assert 1 <= dropped <= 20 and volume == pytest.approx(0.15**3, rel=0.2)
    assert mesh.volume + volume == pytest.approx(1.0 + 0.15**3, rel=0.01)
    messages = [str(w.message) for w in caught if "were dropped" in str(w.message)]
    assert len(messages) == 1 and f"{dropped} cell(s)" in messages[0] and "a smaller h (or hmin) keeps them" in messages[0]
    x, y, z = map(float, re.search(r"cell\(s\) at \(([^)]*)\)", messages[0]).group(1).split(", "))
    assert abs(x - 0.695) < 0.05 and abs(y) < 0.05 and abs(z) < 0.05
    assert not [w for w in caught if "pieces not joined" in str(w.message)]
    kept = fepre.distmesh(part, h=0.15, thin_parts="keep")  # as it was: the piece kept, and named
    assert len(mesh_pieces(kept.cells_dict[10], kept.n_points)[1]) == 2
    assert kept.n_cells == mesh.n_cells + dropped and kept.field_data["distmesh_dropped_cells"][0] == 0
