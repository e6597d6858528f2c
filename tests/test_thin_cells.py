"""Cells short of the quality targets in parts about one element thick are named, with the
thickness there and the h that resolves them (fepre.distmesh.thin_cells)."""

from __future__ import annotations

import re

import numpy as np
import pytest

from fepre import sdf
from fepre.distmesh.thin_cells import THIN_SHARE, ThinCells, thin_bad_cells, thin_cells_message

#: a flat cap spanning a slab 0.2 thick (|z| <= 0.1): two nodes on each face, edges about 1
CAP = np.array([[0.0, 0.0, -0.1], [1.0, 0.0, -0.1], [0.5, 1.0, 0.1], [0.5, -1.0, 0.1]])
REGULAR = np.array([[1, 1, 1], [-1, 1, -1], [1, -1, -1], [-1, -1, 1.0]]) * 0.35


def test_a_cap_across_a_slab_is_thin_and_measured_to_the_slab_thickness():
    slab = sdf.box((6.0, 6.0, 0.2))
    found = thin_bad_cells(slab, CAP, np.array([[0, 1, 2, 3]]), h=1.0)
    assert found.bad == 1 and len(found.centres) == 1
    assert found.thickness[0] == pytest.approx(0.2, rel=1e-3)
    assert found.size[0] == 1.0
    assert np.allclose(found.centres[0], CAP.mean(axis=0))  # the deepest of its samples


def test_a_flat_cell_whose_centroid_lies_just_outside_is_measured_from_inside_it():
    # three nodes on the inner face of a spherical shell 0.2 thick, one on its outer face: the
    # cell spans the shell but its centroid lies 0.063 inside the hole (before: not measured)
    shell = sdf.sphere(1.2) - sdf.sphere(1.0)
    cell = np.array([[0.5, 0.0, 0.866025], [-0.25, 0.433013, 0.866025], [-0.25, -0.433013, 0.866025],
                     [0.410424, 0.0, 1.127631]])
    assert shell(cell.mean(axis=0)[None])[0] == pytest.approx(0.063, abs=1e-3)
    found = thin_bad_cells(shell, cell, np.array([[0, 1, 2, 3]]), h=1.0)
    assert found.bad == 1 and len(found.centres) == 1
    assert shell(found.centres)[0] < 0
    assert found.thickness[0] == pytest.approx(0.2, rel=1e-2)


def test_the_local_size_decides_what_is_thin():
    slab = sdf.box((6.0, 6.0, 0.2))
    tets = np.array([[0, 1, 2, 3]])
    # 0.2 thick: thin against elements of 1, not against elements of 0.1 (two across)
    assert len(thin_bad_cells(slab, CAP, tets, h=1.0, local_size=lambda x: np.full(len(x), 1.0)).centres) == 1
    assert len(thin_bad_cells(slab, CAP, tets, h=1.0, local_size=lambda x: np.full(len(x), 0.1)).centres) == 0


def test_a_bad_cell_deep_in_thick_material_is_not_thin():
    block = sdf.box((8.0, 8.0, 8.0))
    found = thin_bad_cells(block, CAP, np.array([[0, 1, 2, 3]]), h=1.0)
    assert found.bad == 1 and len(found.centres) == 0


def test_good_cells_and_cells_outside_are_not_counted():
    slab = sdf.box((6.0, 6.0, 0.2))
    good = thin_bad_cells(sdf.box((4.0, 4.0, 4.0)), REGULAR, np.array([[0, 1, 2, 3]]), h=1.0)
    assert good.bad == 0 and len(good.centres) == 0
    outside = thin_bad_cells(slab, CAP + [0, 0, 5.0], np.array([[0, 1, 2, 3]]), h=1.0)
    assert outside.bad == 1 and len(outside.centres) == 0


def test_the_message_names_places_thickness_and_the_h_that_resolves_them():
    centres = np.array([[0.0, 0, 0], [0.1, 0, 0], [0.2, 0, 0], [10.0, 0, 0], [10.1, 0, 0]])
    found = ThinCells(bad=7, centres=centres, thickness=np.array([0.3, 0.4, 0.5, 0.2, 0.2]), size=np.full(5, 0.5))
    message = thin_cells_message(found, 0.5, offset=(100.0, 0, 0))
    assert message.startswith(f"5 of the 7 cell(s) short of the quality targets lie where the model is less than {THIN_SHARE:g} elements thick")
    places = re.findall(r"(\d+) near \(([^)]*)\), ([\d.]+) thick", message)
    assert [(int(n), float(t)) for n, _, t in places] == [(3, 0.4), (2, 0.2)]  # most cells first, median thickness
    assert [float(v) for v in places[0][1].split(",")] == pytest.approx([100.1, 0, 0])  # in the user's frame
    assert "h=(0.1, 0.5)" in message and "h <= 0.1" in message  # half the thinnest place shown
    graded = thin_cells_message(found, None)
    assert "smaller hmin (about 0.1)" in graded
    assert thin_cells_message(ThinCells(3, np.zeros((0, 3)), np.zeros(0), np.zeros(0)), 0.5) is None



def test_the_advice_resolves_the_thinnest_place_even_when_it_is_not_shown():
    # lucy.ply (pyvista's vtk-data) at D/50: 30 places; the three with most cells were 23-45 thick,
    # one further down 2.8; an hmin of half the three shown left 32 cells in parts under 1.5
    # elements across (7.6 deg), so the advice is half the thinnest of all places
    centres = np.array([[0.0, 0, 0], [0.1, 0, 0], [10.0, 0, 0], [10.1, 0, 0], [20.0, 0, 0], [20.1, 0, 0],
                        [30.0, 0, 0]])
    found = ThinCells(bad=9, centres=centres, thickness=np.array([0.4, 0.4, 0.5, 0.5, 0.6, 0.6, 0.1]),
                      size=np.full(7, 0.5))
    message = thin_cells_message(found, 0.5)
    assert "and 1 more place(s), the thinnest 1 near (30, 0, 0), 0.1 thick" in message
    assert "h=(0.05, 0.5)" in message and "h <= 0.05" in message

@pytest.mark.slow
def test_fingers_one_element_thick_meet_the_targets():
    # a ball with a finger 1.2 across, meshed at h = 1: one layer of cells with every node on its
    # surface. Until session 57 a cell there stayed at 23.9 deg, named ("less than 1.5 elements
    # thick") with an h that met the targets; with session 58's installs (a fresh environment's
    # numerics) the stage mends it and fingers 0.9 to 1.5 across. The line itself is tested on
    # its own above (test_the_message_names_places_thickness_and_the_h_that_resolves_them).
    import warnings

    import fepre

    for radius in (0.45, 0.6, 0.75):
        part = sdf.sphere(2.0) | sdf.capsule((0, 0, 0), (5, 0, 0), radius)
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            mesh = fepre.distmesh(part, h=1.0)
        assert mesh.cell_data["min_dihedral_angle"].min() >= 25.0
        assert mesh.cell_data["max_dihedral_angle"].max() <= 150.0 and mesh.cell_data["radius_ratio"].min() >= 0.25
        assert not [w for w in caught if "short of the quality targets" in str(w.message)]


def test_a_region_mesh_measures_each_cell_in_its_own_region(monkeypatch):
    # a flat cell in a sheet of one material 0.2 thick inside a thick block: thin for its region,
    # not for the part (the MNI brain's grey matter: 40 of its 87 bad cells at h = 5 were named
    # only once each region was measured in its own model)
    from fepre.distmesh import thin_cells
    from fepre.distmesh.thin_cells import combined

    block, sheet = sdf.box(8.0), sdf.box((6.0, 6.0, 0.2))
    cells = np.array([[0, 1, 2, 3], [4, 5, 6, 7]])
    points = np.concatenate([CAP, CAP + [0, 0, 3.0]])  # the second in the block's thick part
    in_sheet = np.array([True, False])
    assert len(thin_bad_cells(block, points, cells, h=1.0).centres) == 0
    found = combined([thin_bad_cells(sheet, points, cells[in_sheet], h=1.0),
                      thin_bad_cells(block - sheet, points, cells[~in_sheet], h=1.0)])
    assert found.bad == 2 and len(found.centres) == 1 and found.thickness[0] == pytest.approx(0.2, rel=1e-3)
    # and fepre.distmesh hands each region's cells and model to the measure
    import fepre

    seen = []
    original = thin_cells.thin_bad_cells
    monkeypatch.setattr(thin_cells, "thin_bad_cells", lambda model, *a, **k: seen.append(model) or original(model, *a, **k))
    ball = sdf.sphere(0.3)
    fepre.distmesh(sdf.box(1.0), 0.1, regions={"matrix": sdf.box(1.0) - ball, "ball": ball}, progress=False)
    assert len(seen) == 2 and seen[1] is not None
    assert seen[1](np.zeros((1, 3)))[0] == pytest.approx(-0.3)  # the ball's own model
