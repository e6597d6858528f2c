"""Parts thinner than an element that leave cells below the quality targets are left out, a
little at a time and within a volume budget, and named (fepre.distmesh.thin_trim)."""

from __future__ import annotations

import re
import subprocess
import sys
import warnings

import numpy as np
import pytest

import fepre
from fepre import sdf
from fepre.distmesh.thin_trim import TOTAL_SHARE, Trimmed, trim_thin_zones, trimmed_message
from fepre.distmesh.topology import check_topology

#: a gyroid lattice cut by a box: where a wall meets a face of the box at a grazing angle it
#: leaves slivers 0.005-0.007 thick, which hold three cells of 19.3 deg at h = 0.05
LATTICE = sdf.box(1.0) & sdf.gyroid(period=1.0, thickness=0.2)


def _mesh(model, h, **options):
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        mesh = fepre.distmesh(model, h, **options)
    return mesh, [str(w.message) for w in caught if issubclass(w.category, fepre.ResolutionWarning)]


@pytest.mark.slow  # 39 s of the default run on 2 cores
def test_the_slivers_a_box_leaves_of_a_lattice_wall_go_and_every_cell_meets_the_targets():
    kept, _ = _mesh(LATTICE, 0.05, thin_parts="keep")
    trimmed, said = _mesh(LATTICE, 0.05)
    assert kept["min_dihedral_angle"].min() < 25.0  # the slivers' cells (19.3-21.2 deg)
    assert trimmed["min_dihedral_angle"].min() >= 25.0
    assert trimmed["max_dihedral_angle"].max() <= 150.0 and trimmed["radius_ratio"].min() >= 0.25
    # a few cells of the slivers, not the walls: the volume moves by less than 0.01% (beside a
    # piece of the lattice's corner that a neck 0.012 thick joins, dropped when trimmed)
    dropped = trimmed.field_data["distmesh_dropped_cells"][0]
    assert 0 < kept.n_cells - trimmed.n_cells - dropped <= 12
    assert trimmed.field_data["distmesh_trimmed_cells"][0] >= 1 and kept.field_data["distmesh_trimmed_cells"][0] == 0
    assert 0 < trimmed.field_data["distmesh_trimmed_volume"][0] < 1e-4
    assert trimmed["volume"].sum() + trimmed.field_data["distmesh_dropped_volume"][0] == pytest.approx(
        kept["volume"].sum(), rel=1e-4)
    named = [text for text in said if "left out so that" in text]
    assert len(named) == 1
    count, places = (int(v) for v in re.search(r"(\d+) cell\(s\) in (\d+) place", named[0]).groups())
    assert 1 <= places <= count <= 12
    for match in re.finditer(r"near \(([^)]*)\), ([\d.e-]+) thick", named[0]):
        centre = np.array([float(v) for v in match.group(1).split(",")])
        assert np.abs(centre).max() > 0.45  # on a face of the box
        assert float(match.group(2)) < 0.05
    assert "thin_parts='keep'" in named[0] and "--keep-thin" in named[0]
    assert not any("short of the quality targets" in text for text in said)
    # one pass on the mesh with the slivers: a sound solid without them, within the budget
    points, tets = np.asarray(kept.points, float), np.asarray(kept.cells_dict[10]).astype(np.int64)
    moved, left, cut = trim_thin_zones(points, tets, LATTICE, 0.05)
    assert 1 <= cut.cells <= 12 and len(left) == len(tets) - cut.cells
    assert 0 < cut.volume < 1e-4 * kept["volume"].sum()
    report = check_topology(left, len(points))
    assert report.overused_faces == report.nonmanifold_edges == report.pinched_vertices == 0


def test_a_zone_whose_removal_cuts_the_mesh_in_two_is_found():
    # a bar's cells across the plane x = 3.5 are a zone that would leave the bar in two pieces
    # (a rib's root thinner than an element: the rib floated free); a zone at the end does not
    from scipy.spatial import Delaunay

    from fepre.distmesh.pieces import mesh_pieces
    from fepre.distmesh.thin_trim import _cutting

    grid = np.stack(np.meshgrid(np.arange(8.0), np.arange(2.0), np.arange(2.0), indexing="ij"), -1).reshape(-1, 3)
    points = grid + np.random.default_rng(1).uniform(-0.1, 0.1, grid.shape)
    tets = Delaunay(points).simplices
    x = points[tets][:, :, 0]
    across = np.flatnonzero((x.min(axis=1) < 3.5) & (x.max(axis=1) > 3.5))
    end = np.flatnonzero(x.min(axis=1) > 6.5)[:1]
    removed = np.zeros(len(tets), bool)
    removed[across] = removed[end] = True
    assert len(mesh_pieces(tets[~removed], len(points))[1]) == 2
    assert _cutting(tets, len(points), removed, [across, end]).tolist() == [True, False]
    removed[across] = False
    assert _cutting(tets, len(points), removed, [end]).tolist() == [False]


def test_a_piece_a_zone_cuts_off_goes_with_it_when_thin_throughout_and_small():
    # the bar cut across x = 5.5: the piece beyond is a hook's lip held by a zone when every cell
    # of it is thin, and stays when one is not, when it holds a fixed point or is over the cap
    from scipy.spatial import Delaunay

    from fepre.distmesh.thin_trim import _thin_fragments

    grid = np.stack(np.meshgrid(np.arange(8.0), np.arange(2.0), np.arange(2.0), indexing="ij"), -1).reshape(-1, 3)
    points = grid + np.random.default_rng(1).uniform(-0.1, 0.1, grid.shape)
    tets = Delaunay(points).simplices
    x = points[tets][:, :, 0]
    removed = (x.min(axis=1) < 5.5) & (x.max(axis=1) > 5.5)
    beyond = x.min(axis=1) > 5.5
    volumes = np.abs(np.einsum("ij,ij->i", points[tets[:, 1]] - points[tets[:, 0]],
                               np.cross(points[tets[:, 2]] - points[tets[:, 0]], points[tets[:, 3]] - points[tets[:, 0]]))) / 6
    free = np.zeros(len(points), dtype=bool)

    def thin(cells):
        return np.ones(len(cells), dtype=bool)

    def thick_somewhere(cells):
        return np.arange(len(cells)) > 0

    lip = volumes[beyond].sum()
    assert np.array_equal(_thin_fragments(tets, len(points), removed, thin, volumes, lip, lip, free), beyond)
    assert not _thin_fragments(tets, len(points), removed, thick_somewhere, volumes, lip, lip, free).any()
    assert not _thin_fragments(tets, len(points), removed, thin, volumes, 0.99 * lip, lip, free).any()
    assert not _thin_fragments(tets, len(points), removed, thin, volumes, lip, 0.99 * lip, free).any()
    held = free.copy()
    held[np.argmax(points[:, 0])] = True
    assert not _thin_fragments(tets, len(points), removed, thin, volumes, lip, lip, held).any()
    end = x.min(axis=1) > 6.5  # nothing cut off
    assert not _thin_fragments(tets, len(points), end, thin, volumes, lip, lip, free).any()


@pytest.mark.slow
def test_a_thin_rib_on_a_plate_stays_joined_to_it(tmp_path):
    """A 0.8 rib 20 high on a plate cut by a 10 deg chamfer, tessellated by gmsh (a new user's
    part), at D/25: the trim gave up the rib's root and the rib floated free (316 of 5095 cells)."""
    import math

    from fepre.distmesh.pieces import mesh_pieces
    from fepre.parts import occ_surface
    import pyvista as pv

    def build(occ):
        plate, rib = occ.addBox(0, 0, 0, 50, 30, 6), occ.addBox(5, 14.6, 6, 35, 0.8, 20)
        part, _ = occ.fuse([(3, plate)], [(3, rib)])
        wedge = occ.addBox(0, -1, 0, 30, 32, 30)
        occ.rotate([(3, wedge)], 0, 0, 0, 0, 1, 0, math.radians(10))
        occ.translate([(3, wedge)], 40, 0, 6)
        occ.cut(part, [(3, wedge)])

    path = tmp_path / "rib.stl"  # single precision, as a CAD system writes it
    pv.PolyData.from_regular_faces(*occ_surface(build, 6.0, curvature=6)).save(path)
    model = sdf.mesh(path)
    h = float(np.linalg.norm([50.0, 30.0, 26.0])) / 25
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        mesh = fepre.distmesh(model, h)
    tets = mesh.cells.reshape(-1, 5)[:, 1:]
    assert len(mesh_pieces(tets, mesh.n_points)[1]) == 1
    assert mesh.bounds[5] == pytest.approx(26.0, abs=1e-6)  # the rib's top is there


@pytest.mark.slow  # 4 s of the default run on 2 cores
def test_a_part_that_is_thin_all_over_is_kept_with_its_flat_cells():
    """A plate thinner than h everywhere: every cell is flat and the plate is one zone, far over
    the volume a zone may hold, so nothing goes."""
    plate = sdf.box((3.0, 3.0, 0.15))
    kept, _ = _mesh(plate, 0.5, thin_parts="keep")
    trimmed, said = _mesh(plate, 0.5)
    assert trimmed["min_dihedral_angle"].min() < 25.0
    assert trimmed.n_cells == kept.n_cells
    assert np.array_equal(trimmed.cells, kept.cells)
    assert not any("left out so that" in text for text in said)


def test_a_mesh_that_meets_the_targets_is_returned_as_it_is():
    mesh = fepre.distmesh(sdf.box((2.0, 2.0, 0.5)), 0.25, thin_parts="keep")
    points, tets = np.asarray(mesh.points, float), np.asarray(mesh.cells_dict[10]).astype(np.int64)
    moved, kept, cut = trim_thin_zones(points, tets, sdf.box((2.0, 2.0, 0.5)), 0.25)
    assert cut.cells == 0 and kept is tets and moved is points


def test_the_message_names_flat_places_and_the_thinnest_measured_one():
    found = Trimmed(5, 0.002, np.array([[1.0, 2.0, 3.0], [4.0, 5.0, 6.0], [7.0, 8.0, 9.0]]),
                    np.array([0.0, 0.3, 0.1]), np.array([1.0, 1.0, 1.0]))
    text = trimmed_message(found, 1.0, 1.0)
    assert "5 cell(s) in 3 place(s)" in text and "(0.2% of the mesh)" in text
    assert text.index("0.1 thick") < text.index("0.3 thick")  # thinnest first
    assert "h=(0.05, 1)" in text  # two elements across the thinnest measured place
    flat = trimmed_message(Trimmed(1, 1e-4, np.zeros((1, 3)), np.zeros(1), np.ones(1)), 1.0, 1.0)
    assert "flat on the surface" in flat and "h=(" not in flat
    # no material of the model in them (a new user's shaft at D/50: cells across its groove's
    # mouth, 1.3 outside the part, were "thinner than an element ... left out")
    assert flat.startswith("1 flat cell(s) on the surface in 1 place(s) were removed") and "thinner" not in flat
    assert "with no material of the model in it" in flat
    assert trimmed_message(Trimmed.none(), 1.0, 1.0) is None
    assert TOTAL_SHARE == pytest.approx(0.01)


@pytest.mark.slow  # 4 s of the default run on 2 cores
def test_thin_parts_is_checked_and_the_cli_flag_keeps_them(tmp_path):
    with pytest.raises(ValueError, match="thin_parts"):
        fepre.distmesh(sdf.sphere(1.0), 0.5, thin_parts="drop")
    model = tmp_path / "part.py"
    model.write_text("from fepre import sdf\nmodel = sdf.sphere(1.0)\n")
    run = subprocess.run([sys.executable, "-m", "fepre", "mesh", str(model), "--h", "0.5", "--keep-thin", "-o",
                          str(tmp_path / "out.vtu"), "--quiet"], capture_output=True, text=True)
    assert run.returncode == 0, run.stderr
    assert (tmp_path / "out.vtu").exists()
