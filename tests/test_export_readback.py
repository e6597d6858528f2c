"""What fepre writes reads back: a VTU holds the tetrahedra with every fepre array and the named
sets; an .inp reads back through PyVista (fepre's reader, not VTK's AVS UCD one) with its sets."""

from __future__ import annotations

import subprocess
import sys
import warnings

import meshio
import numpy as np
import pytest
import pyvista as pv

import fepre
from fepre import sdf
from fepre.cli import main
from fepre.export import boundary_faces, tag_boundaries
from fepre.export.inp_reader import read_inp

PART = sdf.box((2.0, 1.0, 1.0)) - sdf.cylinder(radius=0.25, height=2.0)
BOUNDARIES = {"fixed": sdf.plane((-1, 0, 0), (-1, 0, 0)), "hole": sdf.cylinder(radius=0.25, height=2.0)}
REGIONS = {"left": sdf.plane((1, 0, 0), (0, 0, 0))}


@pytest.fixture(scope="module")
def bracket():
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", fepre.ConvergenceWarning)
        return fepre.distmesh(PART, h=0.2)


def face_areas(faces) -> np.ndarray:
    """Summed area of the faces of each set."""
    p = np.asarray(faces.points)[faces.regular_faces]
    area = 0.5 * np.linalg.norm(np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0]), axis=1)
    return np.bincount(faces["boundary_id"], weights=area)


@pytest.mark.parametrize("order", [1, 2])
def test_vtu_holds_the_tetrahedra_with_every_array_and_the_sets(tmp_path, bracket, order):
    # The VTU used to hold 5,314 triangles beside the tetrahedra and none of the mesh's arrays.
    path = tmp_path / "bracket.vtu"
    fepre.export(bracket, path, order=order, boundaries=BOUNDARIES, regions=REGIONS, model=PART)
    back = pv.read(path)
    cell_type = pv.CellType.QUADRATIC_TETRA if order == 2 else pv.CellType.TETRA
    assert set(np.unique(back.celltypes)) == {cell_type} and back.n_cells == bracket.n_cells
    for name in bracket.cell_data.keys():
        assert np.array_equal(back.cell_data[name], bracket.cell_data[name]), name
    if order == 1:
        for name in bracket.point_data.keys():
            assert np.array_equal(back.point_data[name], bracket.point_data[name]), name
    else:  # float arrays interpolated to the midside nodes: sdf there is the mean of the edge's ends
        assert np.array_equal(back.point_data["sdf"][: bracket.n_points], bracket.point_data["sdf"])
    expected = tag_boundaries(bracket, BOUNDARIES)
    faces = boundary_faces(back)
    assert faces.field_data["boundary_names"].tolist() == ["fixed", "hole", "boundary"]
    assert np.allclose(face_areas(faces), face_areas(expected), rtol=1e-12)
    assert face_areas(faces)[0] == pytest.approx(1.0, abs=0.03)  # the x = -1 face (rounded edges)
    regions = np.bincount(back["region_id"])
    assert regions.sum() == bracket.n_cells and regions.min() > 0.3 * bracket.n_cells
    assert back.fepre.summary() is not None  # quality of the tetrahedra straight from the file
    # meshio reads it too (a string array in the file would make it exit)
    assert meshio.read(path).cells[0].type == ("tetra10" if order == 2 else "tetra")


@pytest.mark.parametrize("order", [1, 2])
def test_inp_reads_back_through_pyvista_with_its_sets(tmp_path, bracket, order):
    path = tmp_path / "bracket.inp"
    written = fepre.export(bracket, path, order=order, boundaries=BOUNDARIES, regions=REGIONS, model=PART)
    back = pv.read(path)  # VTK's AVS UCD reader returned 0 cells here
    assert back.n_cells == bracket.n_cells and back.n_points == written.n_points
    assert np.allclose(back.points, written.points, rtol=0, atol=1e-11)
    assert np.array_equal(back.cell_connectivity, written.cell_connectivity)
    assert back.field_data["region_names"].tolist() == ["left", "volume"]
    assert np.array_equal(back["region_id"], written["region_id"])
    def rows(table):  # the .inp groups faces by set
        table = np.asarray(table)
        return table[np.lexsort(table.T[::-1])]

    assert np.array_equal(rows(back.field_data["boundary_faces"]), rows(written.field_data["boundary_faces"]))
    assert np.array_equal(back["boundary_id"], written["boundary_id"])
    assert back.volume == pytest.approx(written.volume, rel=1e-10)


def test_pyvista_reads_inp_without_importing_fepre(tmp_path, bracket):
    # The reader is a `pyvista.readers.override` entry point: a plain PyVista session uses it.
    path = tmp_path / "bracket.inp"
    fepre.export(bracket, path, boundaries=BOUNDARIES)
    code = f"import pyvista as pv, sys; g = pv.read({str(path)!r}); print(g.n_cells, 'fepre' in sys.modules)"
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120)
    assert done.returncode == 0, done.stderr
    assert done.stdout.split() == [str(bracket.n_cells), "True"]


def test_inp_reader_reads_other_writers_layouts(tmp_path):
    # Continuation lines, element sets by GENERATE and by name, a surface on an element set,
    # nodes and elements numbered from 101 and out of order, and a material block skipped.
    text = """*HEADING
** written by hand
*NODE
104, 0, 0, 1
101, 0, 0, 0
102, 1, 0, 0
103, 0, 1, 0
105, 1, 1, 1
*ELEMENT, TYPE=C3D4, ELSET=ALLTETS
201, 101, 102, 103,
104
202, 102, 105, 103, 104
*ELSET, ELSET=FIRST, GENERATE
201, 201, 1
*ELSET, ELSET=BOTH
FIRST, 202
*SURFACE, NAME=BASE, TYPE=ELEMENT
FIRST, S1
*MATERIAL, NAME=STEEL
*ELASTIC
210000, 0.3
"""
    path = tmp_path / "hand.inp"
    path.write_text(text)
    grid = read_inp(path)
    assert grid.n_cells == 2 and grid.n_points == 5
    assert grid.field_data["region_names"].tolist() == ["ALLTETS", "FIRST", "BOTH"]
    assert grid["region_id"].tolist() == [0, 0]
    faces = boundary_faces(grid)
    assert faces.field_data["boundary_names"].tolist() == ["BASE"]
    assert faces.n_cells == 1 and faces.area == pytest.approx(0.5)
    assert np.allclose(faces.cell_normals[0], [0, 0, -1])  # S1 of a positive tetrahedron points out


@pytest.mark.parametrize(
    "text, message",
    [
        ("*NODE\n1, 0, 0, 0\n*ELEMENT, TYPE=C3D8\n1, 1, 1, 1, 1, 1, 1, 1, 1\n", "'C3D8' is not a tetrahedron"),
        ("*NODE\n1, 0, 0, 0\n*ELEMENT, TYPE=C3D4\n1, 1, 2, 3, 4\n", "names a node that no *NODE block defines"),
        ("*HEADING\nnothing\n", "no *NODE or no tetrahedral *ELEMENT"),
        ("*INCLUDE, INPUT=mesh.inp\n", "*INCLUDE of 'mesh.inp' is not followed"),
        ("*NODE\n1, 0, 0, x\n", "*NODE holds a value that is not a number"),
    ],
)
def test_inp_reader_rejects_what_it_cannot_read(tmp_path, text, message):
    path = tmp_path / "bad.inp"
    path.write_text(text)
    with pytest.raises(ValueError, match=message.replace("*", r"\*").replace("(", r"\(")):
        read_inp(path)


def test_info_names_the_sets_of_vtu_and_inp(tmp_path, bracket, capsys):
    for suffix in (".vtu", ".inp"):
        path = tmp_path / f"bracket{suffix}"
        fepre.export(bracket, path, boundaries=BOUNDARIES, regions=REGIONS)
        assert main(["info", str(path)]) == 0
        out = capsys.readouterr().out
        counts = np.bincount(tag_boundaries(bracket, BOUNDARIES)["boundary_id"])
        assert f"boundaries (faces): fixed ({counts[0]}), hole ({counts[1]}), boundary ({counts[2]})" in out
        assert "regions (cells): left (" in out and "named sets: none" not in out


def test_set_names_clashing_with_vtu_fields_are_refused(tmp_path, bracket):
    with pytest.raises(ValueError, match="set name 'boundary_faces' is reserved"):
        fepre.export(bracket, tmp_path / "x.vtu", boundaries={"boundary_faces": BOUNDARIES["fixed"]})
    assert not list(tmp_path.iterdir())
