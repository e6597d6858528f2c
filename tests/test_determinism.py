"""Same input and seed, bit-identical mesh: on corpus parts, with every Delaunay backend, and for
repeated calls in one process (gmsh's tetrahedralize drew on the C library's ``rand``, so every
call gave another triangulation of co-spherical points)."""

from __future__ import annotations

import warnings

import numpy as np
import pytest

import fepre
from fepre import corpus, sdf
from fepre.distmesh.delaunay import tetrahedralize

PARTS = [p for p in corpus.parts(seed=1, per_category=1) if p.category not in ("lattice",)][:8]


def _mesh(model, h, **options):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        mesh = fepre.distmesh(model, h, **options)
    return np.asarray(mesh.points).copy(), mesh.cells_dict[10].copy()


def test_gmsh_triangulates_a_lattice_the_same_way_every_time():
    pytest.importorskip("gmsh")
    lattice = np.stack(np.meshgrid(*[np.arange(6.0)] * 3, indexing="ij"), -1).reshape(-1, 3)
    first = tetrahedralize(lattice, "gmsh")
    for _ in range(3):
        np.testing.assert_array_equal(tetrahedralize(lattice, "gmsh"), first)


@pytest.mark.slow
@pytest.mark.parametrize("backend", ["gmsh", "scipy"])
def test_a_finned_plate_meshes_identically_three_times_in_one_process(backend):
    """Before: three different meshes (hashes 7d6ec0148a, 2b0d8d5e09, 5bf3e8f434) with gmsh."""
    if backend == "gmsh":
        pytest.importorskip("gmsh")
    fin = sdf.box((8, 8, 2)) | sdf.box((0.5, 8, 6)).translate((2, 0, 3))
    points, cells = _mesh(fin, 1.0, delaunay=backend)
    for _ in range(2):
        again_points, again_cells = _mesh(fin, 1.0, delaunay=backend)
        np.testing.assert_array_equal(again_points, points)
        np.testing.assert_array_equal(again_cells, cells)


@pytest.mark.slow
@pytest.mark.parametrize("backend", ["gmsh", "scipy"])
def test_corpus_parts_mesh_identically_with_each_backend(backend):
    if backend == "gmsh":
        pytest.importorskip("gmsh")
    for part in PARTS:
        first = _mesh(part.model, part.h, delaunay=backend)
        second = _mesh(part.model, part.h, delaunay=backend)
        assert np.array_equal(first[0], second[0]) and np.array_equal(first[1], second[1]), part.name
