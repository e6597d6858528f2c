"""Closed cavities inside a mesh where its model is material are found and named; a hollow
part's own void is not (fepre.distmesh.cavities)."""

from __future__ import annotations

import warnings

import numpy as np
import pytest

import fepre
from fepre import sdf
from fepre.distmesh.cavities import cavities_message, unmodelled_cavities
from fepre.distmesh.topology import boundary_faces


def test_a_missing_inner_cell_is_a_cavity_and_a_hollow_part_has_none():
    hollow = sdf.sphere(1.0) - sdf.sphere(0.5)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        mesh = fepre.distmesh(hollow, 0.25)
    assert not any("cavit" in str(w.message) or "of the model's outside" in str(w.message) for w in caught)
    points, tets = np.asarray(mesh.points), mesh.cells_dict[10]
    assert unmodelled_cavities(points, boundary_faces(tets), hollow, 0.25) == []
    # two cells deep in the shell (no face on its surfaces), taken out: two cavities of 4 faces
    depth = -hollow(points[tets].mean(axis=1))
    inner = np.flatnonzero(depth > 0.2)
    first = inner[0]
    apart = inner[~np.isin(tets[inner], tets[first]).any(axis=1)][0]
    found = unmodelled_cavities(points, boundary_faces(np.delete(tets, [first, apart], axis=0)), hollow, 0.25)
    assert sorted(faces for _, faces, _ in found) == [4, 4]
    volumes = np.abs(fepre.quality.signed_volumes(points, tets[[first, apart]]))
    assert sorted(volume for _, _, volume in found) == pytest.approx(sorted(volumes), rel=1e-9)
    text = cavities_message(found)
    assert text.startswith("the mesh has 2 closed cavities where the model is material (4 faces, volume")



def test_a_void_whose_middle_is_in_the_material_is_the_model_s_own():
    """A block with a closed ring-shaped void (a torus): the middle of the void's walls lies in
    the material, as for a gyroid's labyrinths closed in a shell (fepre bench quality's gyroid
    block was told it had 2 cavities 'where the model is material'); its faces look into the
    model's own void, so nothing is said."""
    ringed = sdf.box(4.0) - sdf.torus(1.0, 0.35)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        mesh = fepre.distmesh(ringed, 0.25)
    assert not any("cavit" in str(w.message) for w in caught)
    points, tets = np.asarray(mesh.points), mesh.cells_dict[10]
    assert ringed(np.zeros((1, 3)))[0] < 0  # the void's middle is material
    assert unmodelled_cavities(points, boundary_faces(tets), ringed, 0.25) == []


@pytest.mark.slow  # 4 s of the default run on 2 cores
def test_a_void_of_the_model_s_outside_sealed_by_the_mesh_is_named():
    # a new user's two cubes sharing an edge, at h = 0.2: the mesh held the four faces of a cell
    # missing in the wedge beside the edge, outside the model, and nothing said so
    import pyvista as pv

    cubes = pv.Box(bounds=(0, 1, 0, 1, 0, 1)).triangulate() + pv.Box(bounds=(1, 2, 1, 2, 0, 1)).triangulate()
    model = sdf.mesh(cubes)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        mesh = fepre.distmesh(model, 0.2)
    messages = [str(w.message) for w in caught if "of the model's outside" in str(w.message)]
    assert len(messages) == 1 and "1 void of the model's outside (4 faces" in messages[0]
    from fepre.distmesh.cavities import sealed_pockets

    points, tets = np.asarray(mesh.points), np.asarray(mesh.cells_dict[10])
    found = sealed_pockets(points, boundary_faces(tets), model, 0.2, (0, 0, 0), (2, 2, 1))
    assert len(found) == 1
    middle, faces, volume = found[0]
    assert faces == 4 and float(model(middle[None])[0]) > 0  # outside both cubes
    assert np.hypot(middle[0] - 1.0, middle[1] - 1.0) < 0.2  # beside the shared edge


def test_a_flat_void_of_four_coplanar_nodes_is_glued_shut():
    # four nodes on the circle where a sphere meets a capsule lie in one plane: the final mesh
    # dropped their flat cell and kept its four faces as a void of 4e-15, named as a cavity
    from fepre.distmesh.cavities import inner_voids
    from fepre.distmesh.topology import check_topology

    model = sdf.sphere(2) | sdf.capsule((0, 0, 0), (5, 0, 0), 0.6)
    for slivers in (False, True):
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            mesh = fepre.distmesh(model, 1.0, slivers=slivers)
        assert not any("cavit" in str(w.message) for w in caught)
        points, tets = np.asarray(mesh.points), np.asarray(mesh.cells_dict[10]).astype(np.int64)
        assert inner_voids(points, boundary_faces(tets), 1.0) == []
        assert check_topology(tets, len(points)).ok and mesh["volume"].min() > 0
