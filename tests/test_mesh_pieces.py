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
