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
