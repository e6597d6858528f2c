"""A corrupt mesh file gives fepre's one-line message, not a dozen lines of VTK reader internals
(PyVista forwards VTK's errors to Python's logging, which prints them on stderr)."""

from __future__ import annotations

import logging
import os
import subprocess
import sys
from pathlib import Path

import pytest

from fepre import sdf
from fepre.cli import main

CORRUPT_STL = "solid x\nfacet normal 0 0 1\n outer loop\n vertex 0 0 0\n vertex garbage\nendsolid\n"
VTK_NOISE = ("vtkSTLReader", "ERROR:root", "Premature EOF", "REQUEST_DATA")


@pytest.fixture()
def corrupt(tmp_path):
    path = tmp_path / "corrupt.stl"
    path.write_text(CORRUPT_STL)
    return path


def _quiet(err: str) -> bool:
    return not any(noise in err for noise in VTK_NOISE)


def test_reading_a_corrupt_stl_prints_nothing_of_vtk(corrupt, capfd, caplog):
    with caplog.at_level(logging.DEBUG):
        with pytest.raises(sdf.MeshInputError, match="could not be read"):
            sdf.mesh(corrupt)
    captured = capfd.readouterr()
    assert _quiet(captured.err) and _quiet(captured.out), captured.err
    assert _quiet(caplog.text), caplog.text  # what stderr shows outside pytest


def test_fepre_mesh_of_a_corrupt_stl_prints_one_error_line(corrupt, tmp_path):
    root = str(Path(__file__).resolve().parents[1])
    env = {**os.environ, "PYTHONPATH": os.pathsep.join([root, os.environ.get("PYTHONPATH", "")])}
    result = subprocess.run([sys.executable, "-m", "fepre", "mesh", str(corrupt), "-o", str(tmp_path / "x.vtu"),
                             "--h", "0.1"], capture_output=True, text=True, env=env)
    assert result.returncode == 1
    err = result.stderr
    assert _quiet(err), err
    assert err.strip().splitlines() == [f"fepre mesh: error: mesh file {corrupt} could not be read "
                                        f"(the reader failed: not a valid .stl file?)"]


def test_fepre_info_of_a_corrupt_stl_prints_one_error_line(corrupt, capfd, caplog):
    with caplog.at_level(logging.DEBUG):
        assert main(["info", str(corrupt)]) == 1
    err = capfd.readouterr().err
    assert _quiet(err) and len(err.strip().splitlines()) == 1, err
    assert _quiet(caplog.text), caplog.text


def test_vtk_messages_are_restored_after_the_read(corrupt, caplog):
    """Only the read is silenced: VTK's errors reach Python's logging as before afterwards."""
    import pyvista as pv

    with pytest.raises(sdf.MeshInputError):
        sdf.mesh(corrupt)
    assert not logging.getLogger().filters
    with caplog.at_level(logging.DEBUG):
        pv.read(corrupt)
    assert "Premature EOF" in caplog.text


def test_an_empty_file_is_named_as_empty(tmp_path):
    path = tmp_path / "part.stl"
    path.write_bytes(b"")
    with pytest.raises(sdf.MeshInputError, match=r"part\.stl is empty \(0 bytes\); give an STL, OBJ, PLY"):
        sdf.mesh(path)


def test_an_obj_face_past_the_last_vertex_is_named(tmp_path):
    """VTK's OBJ reader keeps a face's index past the last vertex: read as it was, it ended in
    an IndexError deep in numpy."""
    path = tmp_path / "badindex.obj"
    path.write_text("v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\nf 1 2 3\nf 1 2 99\nf 1 3 4\nf 2 3 4\n")
    with pytest.raises(sdf.MeshInputError, match=r"badindex\.obj has 1 face corner\(s\) that refer to no vertex: it has "
                                                  r"4 vertices, and a face refers to vertex index 98 \(counting from 0\)"):
        sdf.mesh(path)


def test_a_binary_stl_cut_short_is_named_as_damaged(tmp_path):
    """A binary STL whose header counts 1000 triangles and holds 10 read as an open surface
    ("has no inside, volume -0.0376")."""
    import numpy as np
    import pyvista as pv

    whole = tmp_path / "whole.stl"
    pv.Sphere(theta_resolution=40, phi_resolution=27).triangulate().save(whole, binary=True)
    data = whole.read_bytes()
    count = int(np.frombuffer(data[80:84], dtype="<u4")[0])
    assert len(data) == 84 + 50 * count and count > 1000
    assert sdf.mesh(whole).repaired.closed  # the whole file reads
    cut = tmp_path / "cut.stl"
    cut.write_bytes(data[: 84 + 50 * 10])
    with pytest.raises(sdf.MeshInputError, match=rf"cut\.stl is a damaged binary STL: its header counts {count} "
                                                  rf"triangles \({84 + 50 * count} bytes\), but the file has 584 bytes "
                                                  r"\(10 triangles\)"):
        sdf.mesh(cut)


def test_an_ascii_stl_cut_short_and_an_empty_step_are_named_as_such(tmp_path):
    """A new user's ASCII STL cut mid-facet was only "not a valid .stl file?", and an empty STEP
    file was told to give "an STL, OBJ, PLY or other surface file"."""
    import pyvista as pv

    whole = tmp_path / "whole.stl"
    pv.Sphere(theta_resolution=12, phi_resolution=8).triangulate().save(whole, binary=False)
    text = whole.read_text()
    cut = tmp_path / "cut.stl"
    cut.write_text(text[: len(text) // 2])
    with pytest.raises(sdf.MeshInputError, match=r"cut\.stl could not be read .*an ASCII STL with no 'endsolid' line "
                                                  r"at its end: cut short"):
        sdf.mesh(cut)
    (tmp_path / "empty.step").write_bytes(b"")
    with pytest.raises(sdf.MeshInputError, match=r"empty\.step is empty \(0 bytes\); give a STEP or BREP file"):
        sdf.mesh(tmp_path / "empty.step")


def test_level_on_a_surface_mesh_file_is_refused(tmp_path, capsys):
    """``--level`` is an image's grey value: given with an STL, it was ignored without a word."""
    import pyvista as pv

    path = tmp_path / "ball.stl"
    pv.Sphere().save(path)
    assert main(["mesh", str(path), "--level", "3", "-o", str(tmp_path / "x.vtu"), "--h", "0.2"]) == 1
    assert "--level is the grey value of an image MODEL" in capsys.readouterr().err
    assert not (tmp_path / "x.vtu").exists()
