"""Regions that stand apart across a gap narrower than the mesh can keep open: found before any
meshing (``fepre.regions.clearance``), against the gaps' exact widths and areas."""

from __future__ import annotations

import re
import subprocess
import sys

import numpy as np
import pytest

import fepre
from fepre import sdf
from fepre.regions.clearance import narrow_clearances
from fepre.regions.partition import RegionSet


def _gaps(named: dict, lower, upper, h: float):
    part = None
    for model in named.values():
        part = model if part is None else part | model
    return narrow_clearances(RegionSet(tuple(named), tuple(named.values())), part, lower, upper, h)


def _boxes(gap: float):
    """Two 10 x 8 x 6 boxes facing each other across ``gap`` (their 8 x 6 faces)."""
    return {"a": sdf.box((10, 8, 6), (5, 4, 3)), "b": sdf.box((10, 8, 6), (15 + gap, 4, 3))}


@pytest.mark.parametrize("gap", [0.05, 0.4, 0.6])
def test_a_gap_narrower_than_three_quarters_h_is_found(gap):
    found = _gaps(_boxes(gap), (-1, -1, -1), (21 + gap, 9, 7), 1.0)
    assert len(found) == 1
    assert (found[0].first, found[0].second) == ("a", "b")
    assert found[0].width == pytest.approx(gap, abs=1e-9)
    assert found[0].area == pytest.approx(48.0)  # the 8 x 6 faces, in grid cells of h/2
    assert 10.0 < found[0].place[0] < 10.0 + gap + 1e-9


def test_junctions_and_a_fitting_pin_are_not_gaps():
    plate = sdf.box((20, 20, 2), (0, 0, 1))
    on_plate = {"plate": plate, "pin": sdf.cylinder(2, 10).translate((0, 0, 7))}  # standing on it: faces at 90 degrees
    assert _gaps(on_plate, (-11, -11, -1), (11, 11, 13), 1.0) == []
    bored = plate - sdf.cylinder(4, 10)
    fitting = {"plate": bored, "pin": sdf.cylinder(4, 2).translate((0, 0, 1))}  # touching all round
    assert _gaps(fitting, (-11, -11, -1), (11, 11, 3), 1.0) == []
    loose = {"plate": bored, "pin": sdf.cylinder(3.9, 2).translate((0, 0, 1))}
    (found,) = _gaps(loose, (-11, -11, -1), (11, 11, 3), 1.0)
    assert found.width == pytest.approx(0.1, abs=1e-6)
    assert found.area == pytest.approx(2 * np.pi * 3.95 * 2, rel=0.25)


def test_distmesh_refuses_a_narrow_gap_before_meshing(monkeypatch):
    from fepre.regions import constraint

    def never(*args, **kwargs):
        raise AssertionError("the interfaces were laid: meshing started")

    monkeypatch.setattr(constraint, "interface_nodes", never)
    regions = _boxes(0.3)
    with pytest.raises(ValueError, match=r"'a' and 'b' 0\.3 apart over an area of about 48") as caught:
        fepre.distmesh(regions["a"] | regions["b"], 1.0, regions=regions, progress=False)
    assert "give h below 0.4 (the narrowest gap / 0.75)" in str(caught.value)


def test_a_graded_mesh_refuses_a_narrow_gap_before_its_size_fields(monkeypatch):
    import fepre.sizing

    def never(*args, **kwargs):
        raise AssertionError("a size field was built: the check came after it")

    monkeypatch.setattr(fepre.sizing, "size_field", never)
    regions = _boxes(0.3)
    with pytest.raises(ValueError, match=r"'a' and 'b' 0\.3 apart"):
        fepre.distmesh(regions["a"] | regions["b"], (0.5, 2.0), regions=regions, progress=False)


def test_a_gap_the_mesh_keeps_open_meshes_as_two_pieces():
    regions = _boxes(0.8)
    mesh = fepre.distmesh(regions["a"] | regions["b"], 1.0, regions=regions, progress=False)
    assert len(np.unique(mesh.connectivity()["RegionId"])) == 2
    assert np.bincount(mesh["region_id"], mesh["volume"]) == pytest.approx([480.0, 480.0], rel=1e-9)


def test_a_narrow_gap_is_found_far_from_the_origin():
    shift = np.array([1e4, -1e4, 1e4])
    regions = {name: model.translate(tuple(shift)) for name, model in _boxes(0.2).items()}
    with pytest.raises(ValueError, match=r"'a' and 'b' 0\.2 apart"):
        fepre.distmesh(regions["a"] | regions["b"], 1.0, regions=regions, progress=False)


def _write_two_boxes(path, gap: float) -> None:
    import gmsh

    gmsh.initialize(interruptible=False)
    try:
        gmsh.option.setNumber("General.Terminal", 0)
        gmsh.model.occ.addBox(0, 0, 0, 20, 10, 4)
        gmsh.model.occ.addBox(0, 0, 4 + gap, 20, 10, 4)
        gmsh.model.occ.synchronize()
        gmsh.write(str(path))
    finally:
        gmsh.finalize()


@pytest.mark.slow  # 5 s of the default run on 2 cores
def test_the_cli_names_the_solids_a_clearance_parts(tmp_path):
    _write_two_boxes(tmp_path / "stack.step", 0.1)
    command = [sys.executable, "-m", "fepre", "mesh", str(tmp_path / "stack.step"), "--solids", "--h", "1.5",
               "-o", str(tmp_path / "stack.inp")]
    done = subprocess.run(command, capture_output=True, text=True, cwd=tmp_path)
    assert done.returncode != 0
    found = re.search(r"'solid_1' and 'solid_2' 0\.1 apart over an area of about (\d+)", done.stderr)
    assert found and float(found.group(1)) == pytest.approx(200.0, rel=0.05), done.stderr  # the 20 x 10 faces
    # what meshing without regions does to a clearance (a new user's lap joint came out welded)
    assert "mesh the part without regions (CLI: without --solids; its cells then fill the gaps and join the solids " \
           "there)" in done.stderr
    assert not (tmp_path / "stack.inp").exists()


def test_a_gap_outside_the_part_is_no_concern():
    # two boxes 0.2 apart cut a part of two balls, one in each, that does not reach the gap
    regions = _boxes(0.2)
    balls = sdf.sphere(3.0, center=(5.0, 4.0, 3.0)) | sdf.sphere(3.0, center=(15.2, 4.0, 3.0))
    found = narrow_clearances(RegionSet(("a", "b"), (regions["a"], regions["b"])), balls, (-1, -1, -1), (21.2, 9, 7), 1.0)
    assert found == []
    mesh = fepre.distmesh(balls, 1.0, regions=regions, progress=False)
    assert np.bincount(mesh["region_id"], mesh["volume"]) == pytest.approx([36 * np.pi] * 2, rel=0.05)
