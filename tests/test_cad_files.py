"""CAD files as models: STEP and BREP files written by gmsh's OpenCASCADE kernel, read back
by ``sdf.mesh`` (tessellated in a child process) and meshed, against OpenCASCADE's own volumes."""

from __future__ import annotations

import re
import subprocess
import sys

import numpy as np
import pytest
import pyvista as pv

import fepre
from fepre import sdf
from fepre.sdf.meshmodel import MeshInputError
from test_cad_solids import _write_solids


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


@pytest.mark.slow  # 4 s of the default run on 2 cores
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


@pytest.mark.slow  # 7 s of the default run on 2 cores
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


def _write_bracket(path) -> None:
    """A new user's bracket: a 100 x 60 x 10 plate with four filleted corners, a boss, a 2.5 mm
    rib and two through holes (genus 2), written by OpenCASCADE."""
    import gmsh

    gmsh.initialize(interruptible=False)
    try:
        gmsh.option.setNumber("General.Terminal", 0)
        occ = gmsh.model.occ
        plate = occ.addBox(0, 0, 0, 100, 60, 10)
        occ.synchronize()
        boxes = {tag: gmsh.model.getBoundingBox(1, tag) for _, tag in gmsh.model.getEntities(1)}
        vertical = [tag for tag, (x0, y0, z0, x1, y1, z1) in boxes.items()
                    if z1 - z0 > 9 and x1 - x0 < 1e-3 and y1 - y0 < 1e-3]
        rounded = occ.fillet([plate], vertical, [6.0])
        fused, _ = occ.fuse(rounded, [(3, occ.addCylinder(30, 30, 10, 0, 0, 20, 12)), (3, occ.addBox(50, 28.75, 10, 40, 2.5, 15))])
        occ.cut(fused, [(3, occ.addCylinder(30, 30, -1, 0, 0, 32, 5)), (3, occ.addCylinder(80, 12, -1, 0, 0, 12, 4))])
        occ.synchronize()
        gmsh.write(str(path))
    finally:
        gmsh.finalize()


@pytest.mark.slow
def test_a_rib_punched_through_at_d_over_25_is_named(tmp_path):
    # The bracket's 2.5 mm rib at h = D/25 = 4.8168 came out with a hole through it (genus 2 -> 3,
    # about 170 of volume: under the lost-material floor of 2 h^3), and nothing was said.
    import re
    import warnings

    from fepre.distmesh.genus import surface_genus
    from fepre.distmesh.topology import boundary_faces

    _write_bracket(tmp_path / "bracket.step")
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        mesh = fepre.distmesh(sdf.mesh(tmp_path / "bracket.step"), 120.42 / 25)
    assert surface_genus(boundary_faces(mesh.cells_dict[10])) == 3
    [named] = [str(w.message) for w in caught if "genus" in str(w.message)]
    assert named.startswith("distmesh: the mesh's surface has genus 3 where the model's has 2")
    assert re.search(r"about 1\d\d near \(8\d\.\d+, 29\.\d+, 1\d(\.\d+)?\), 2\.5 thick", named)  # z = 15 is "15"


@pytest.mark.slow  # 4 s of the default run on 2 cores
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


@pytest.mark.slow  # 4 s of the default run on 2 cores
def test_a_perforated_plate_is_tessellated_by_its_holes_curvature_not_its_faces_edges(tmp_path):
    # a plate with 135 holes 3 across was 1.08M triangles and 27 s of tessellation, the holes'
    # fine edges carried into its two flat faces; its flat faces now take few triangles and the
    # holes keep their 64 segments per turn
    from fepre.sdf.meshmodel.cad_files import read_cad_surface

    def plate(occ):
        holes = [(3, occ.addCylinder(5 + 10 * i, 5 + 10 * j, -1, 0, 0, 4, 1.5)) for i in range(5) for j in range(5)]
        occ.cut([(3, occ.addBox(0, 0, 0, 50, 50, 2))], holes)

    path = tmp_path / "perforated.step"
    _write_solids(path, plate)
    surface = read_cad_surface(path)
    volume = 50 * 50 * 2 - 25 * np.pi * 1.5**2 * 2
    assert surface.volume == pytest.approx(volume, rel=2e-4)
    # the holes' walls, 64 segments per turn, are most of the 58k triangles; with the holes'
    # edges spread over the flat faces they were 316k
    assert surface.n_cells < 100_000


@pytest.mark.slow
def test_a_thin_walled_enclosure_refused_at_a_coarse_h_is_told_the_h_that_meshes_it(tmp_path):
    # a new user's enclosure (walls 2 thick, ribs 1.5, bosses) at D/25: the closed choice kept
    # cells over its open top, refused with "try a smaller h"; h = 4.5 and 4 failed the same way.
    # The refusal now measures the part where the cells outside are, and the graded h it names
    # meshes the enclosure to the targets
    def enclosure(occ):
        shell, _ = occ.cut([(3, occ.addBox(0, 0, 0, 100, 60, 40))], [(3, occ.addBox(2, 2, 2, 96, 56, 40))])
        parts = [(3, occ.addBox(33, 2, 2, 1.5, 56, 20)), (3, occ.addBox(66, 2, 2, 1.5, 56, 20))]
        bosses = []
        for x, y in [(10, 10), (90, 10), (10, 50), (90, 50)]:
            parts.append((3, occ.addCylinder(x, y, 2, 0, 0, 25, 4)))
            bosses.append((3, occ.addCylinder(x, y, 8, 0, 0, 25, 1.5)))
        body, _ = occ.fuse(shell, parts)
        occ.cut(body, bosses)

    path = tmp_path / "enclosure.step"
    _write_solids(path, enclosure)
    part = sdf.mesh(path)
    with pytest.raises(fepre.MeshingError) as refused:
        fepre.distmesh(part, h="D/25")
    found = re.search(r"the part is ([\d.]+) across there .*: try h <= [\d.]+ \(two elements across\), or h=\(([\d.]+), "
                      r"([\d.]+)\)", str(refused.value))
    assert found, str(refused.value)
    across, hmin, hmax = map(float, found.groups())
    assert 1.9 <= across <= 3.0  # the walls are 2 thick
    mesh = fepre.distmesh(part, h=(hmin, hmax))
    assert mesh["min_dihedral_angle"].min() >= 25.0
