"""CAD files as models: STEP and BREP files written by gmsh's OpenCASCADE kernel, read back
by ``sdf.mesh`` (tessellated in a child process) and meshed, against OpenCASCADE's own volumes."""

from __future__ import annotations

import subprocess
import sys

import numpy as np
import pytest
import pyvista as pv

import fepre
from fepre import sdf
from fepre.sdf.meshmodel import MeshInputError


def write_cad(path, overlapping_boxes: bool = False) -> float:
    """A 40 x 20 x 10 plate with a bore of radius 5 (or two boxes overlapping by half) written by
    OpenCASCADE; returns the solid's exact volume."""
    import gmsh

    gmsh.initialize(interruptible=False)
    try:
        gmsh.option.setNumber("General.Terminal", 0)
        occ = gmsh.model.occ
        if overlapping_boxes:
            occ.addBox(0, 0, 0, 2, 1, 1)
            occ.addBox(1, 0, 0, 2, 1, 1)  # two solids in one file; their union is 3 x 1 x 1
            volume = 3.0
        else:
            plate = occ.addBox(0, 0, 0, 40, 20, 10)
            bore = occ.addCylinder(20, 10, -1, 0, 0, 12, 5)
            occ.cut([(3, plate)], [(3, bore)])
            volume = 40 * 20 * 10 - np.pi * 25 * 10
        occ.synchronize()
        gmsh.write(str(path))
    finally:
        gmsh.finalize()
    return volume


@pytest.mark.parametrize("name", ["plate.step", "plate.brep"])
def test_a_cad_file_is_its_solid(tmp_path, name):
    volume = write_cad(tmp_path / name)
    model = sdf.mesh(tmp_path / name)
    assert model.repaired.closed and not model.repaired.changed
    assert model.volume == pytest.approx(volume, rel=5e-4)  # the bore's chords: +0.02%
    assert np.allclose(model.bounds, ((0, 0, 0), (40, 20, 10)), atol=1e-6)
    assert model([[20.0, 10.0, 5.0]])[0] == pytest.approx(5.0, abs=0.01)      # on the bore's axis
    assert model([[2.0, 2.0, 5.0]])[0] == pytest.approx(-2.0, abs=1e-9)       # inside, by two faces


def test_an_assembly_s_solids_are_united(tmp_path):
    volume = write_cad(tmp_path / "boxes.step", overlapping_boxes=True)
    model = sdf.mesh(tmp_path / "boxes.step")
    assert model.volume == pytest.approx(volume, rel=1e-9)
    assert model.repaired.internal == 0  # fused by OpenCASCADE, not by the repair


def test_a_step_file_of_faces_without_a_solid_is_meshed_with_a_warning(tmp_path):
    """A box's six faces exported without its volume: meshed as the solid they close (as with
    --solids it is refused), but no longer silently (a new user's trial)."""
    import warnings

    import gmsh

    gmsh.initialize(interruptible=False)
    try:
        gmsh.option.setNumber("General.Terminal", 0)
        box = gmsh.model.occ.addBox(0, 0, 0, 10, 10, 10)
        gmsh.model.occ.synchronize()
        gmsh.model.occ.remove([(3, box)])
        gmsh.model.occ.synchronize()
        gmsh.write(str(tmp_path / "shell.step"))
    finally:
        gmsh.finalize()
    with pytest.warns(fepre.RepairWarning, match=r"shell\.step holds no solid: its faces were tessellated"):
        model = sdf.mesh(tmp_path / "shell.step")
    assert model.volume == pytest.approx(1000.0, rel=1e-9)
    with warnings.catch_warnings():
        warnings.simplefilter("error", fepre.RepairWarning)
        write_cad(tmp_path / "plate.step")
        sdf.mesh(tmp_path / "plate.step")  # a solid: nothing to say


def test_the_cli_meshes_a_step_file(tmp_path):
    volume = write_cad(tmp_path / "plate.step")
    out = tmp_path / "plate.vtu"
    done = subprocess.run([sys.executable, "-m", "fepre", "mesh", str(tmp_path / "plate.step"), "--h", "2",
                           "-o", str(out), "--quiet"], capture_output=True, text=True)
    assert done.returncode == 0, done.stderr
    grid = pv.read(out)
    assert grid.volume == pytest.approx(volume, rel=0.005)
    assert grid.cell_data["min_dihedral_angle"].min() >= 25.0


def test_a_broken_cad_file_names_the_file(tmp_path):
    path = tmp_path / "broken.step"
    path.write_text("ISO-10303-21;\nnot a step file\n")
    with pytest.raises(MeshInputError, match="broken.step") as caught:
        sdf.mesh(path)
    assert "OpenCASCADE" in str(caught.value)


def test_an_iges_file_is_refused_with_what_to_export(tmp_path):
    write_cad(tmp_path / "plate.iges")
    with pytest.raises(MeshInputError, match="plate.iges.*holds faces, not solids; export the part as STEP"):
        sdf.mesh(tmp_path / "plate.iges")


def test_a_bore_set_on_a_tessellated_step_part_takes_the_bore(tmp_path):
    # fepre tessellates a STEP file itself, so a bore's nodes lie on facets under the exact
    # cylinder, a few thousandths of h off it: the set "bore" took 18 of 370 faces (-94.7% of its
    # area) and warned. It now takes them at the tolerance that does, and says so.
    from fepre.export import BoundaryWarning, tag_boundaries

    write_cad(tmp_path / "plate.step")
    mesh = fepre.distmesh(sdf.mesh(tmp_path / "plate.step"), 1.5)
    bore = {"bore": sdf.cylinder(radius=5.0, height=100.0, center=(20.0, 10.0, 5.0))}
    with pytest.warns(BoundaryWarning, match=r"boundaries 'bore': the faces along its surface .* Taken with "
                                             r"boundary_tolerance="):
        faces = tag_boundaries(mesh, bore)
    area = float(faces.extract_cells(np.flatnonzero(faces["boundary_id"] == 0)).area)
    assert area == pytest.approx(2 * np.pi * 5.0 * 10.0, rel=0.01)
