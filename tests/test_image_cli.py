"""`fepre mesh` and `fepre surface` on image files: --level, --inside, --labels, and the errors.
(The meshes take 4-10 s on a loaded machine: slow; test_image_models and test_image_labels mesh
the same models in the default run.)"""

from __future__ import annotations

import math
import re

import numpy as np
import pytest
import pyvista as pv

from fepre import sdf
from fepre.cli import main
from fepre.sdf.imagemodel.phantoms import partial_volume

TORUS = sdf.torus(0.6, 0.3)
TORUS_VOLUME = 2 * math.pi**2 * 0.6 * 0.3**2
SPACING = 0.05


@pytest.fixture(scope="module")
def scan(tmp_path_factory):
    folder = tmp_path_factory.mktemp("images")
    grid = partial_volume(TORUS, (-1, -1, -0.4), (1, 1, 0.4), SPACING, scale=1000.0)
    grid.save(folder / "scan.vti")
    return folder / "scan.vti"


def test_surface_of_an_image(scan, capsys):
    out = scan.with_name("scan.stl")
    assert main(["surface", str(scan), "--level", "500", "-o", str(out)]) == 0
    assert "genus                 1" in capsys.readouterr().out
    surface = pv.read(out)
    assert surface.n_open_edges == 0
    assert np.abs(TORUS(np.asarray(surface.points, float))).max() <= 0.2 * SPACING  # measured 0.08 voxel
    assert surface.volume == pytest.approx(TORUS_VOLUME, rel=0.01)


@pytest.mark.slow
def test_mesh_of_an_image(scan, capsys):
    out = scan.with_name("scan.inp")
    assert main(["mesh", str(scan), "--level", "500", "--h", "0.15", "-o", str(out), "--quiet"]) == 0
    mesh = pv.read(out)
    nodes = mesh.extract_surface(algorithm="dataset_surface").points
    assert np.abs(TORUS(np.asarray(nodes, float))).max() <= 0.5 * SPACING
    # the chords at h cost the volume of a torus meshed at 0.15 3.6%; test_image_models compares
    # the image's mesh with the solid's at the same h
    assert mesh.volume == pytest.approx(TORUS_VOLUME, rel=0.05)
    # the pores' side: --inside below is the box minus the torus, cut by the voxels' box
    assert main(["surface", str(scan), "--level", "500", "--inside", "below", "-o", str(scan.with_name("pores.stl")),
                 "--no-check"]) == 0
    pores = pv.read(scan.with_name("pores.stl"))
    assert pores.volume == pytest.approx(2.0 * 2.0 * 0.8 - TORUS_VOLUME, rel=0.01)


@pytest.mark.parametrize(
    "arguments, message",
    [
        (["--h", "0.1"], "scan.vti is an image: pass --level"),
        (["--h", "0.1", "--level", "5000"], "level 5000.0 is outside the image's values (0.0 to 1000.0)"),
        (["--h", "0.1", "--level", "500", "--smoothing", "-1"], "smoothing must be"),
        (["--level", "500"], "no edge length: pass --h"),
        (["--h", "0.1", "--level", "500", "--voxel-size", "0.1"], "scan.vti carries its own"),
        (["--h", "0.1", "--level", "500", "--voxel-size", "0.1", "0"], "--voxel-size must be one positive number or three"),
    ],
)
def test_image_errors(scan, capsys, arguments, message):
    assert main(["mesh", str(scan), "-o", str(scan.with_name("x.inp")), *arguments]) == 1
    assert message in capsys.readouterr().err
    assert not scan.with_name("x.inp").exists()


def test_image_without_scalars(tmp_path, capsys):
    path = tmp_path / "empty.vti"
    pv.ImageData(dimensions=(5, 5, 5)).save(path)
    assert main(["surface", str(path), "--level", "1", "-o", str(tmp_path / "x.stl")]) == 1
    assert f"{path} has no scalar array" in capsys.readouterr().err


@pytest.mark.slow
def test_mesh_of_a_label_image(tmp_path, capsys):
    from fepre.sdf.imagemodel.phantoms import label_image

    grid = label_image([sdf.sphere(0.5), sdf.sphere(0.25)], (-0.6,) * 3, (0.6,) * 3, SPACING)
    grid.save(tmp_path / "labels.vti")
    out = tmp_path / "labels.inp"
    assert main(["mesh", str(tmp_path / "labels.vti"), "--labels", "--label", "1=shell", "--label", "2=core",
                 "--h", "0.15", "-o", str(out), "--material", "shell", "3000", "0.35", "--material", "core", "70000", "0.3",
                 "--quiet"]) == 0
    text = out.read_text()
    assert "ELSET=shell" in text and "ELSET=core" in text and text.count("*SOLID SECTION") == 2
    mesh = pv.read(out)
    assert mesh.volume == pytest.approx(4 / 3 * math.pi * 0.5**3, rel=0.05)


@pytest.mark.parametrize(
    "arguments, message",
    [
        (["--labels", "--level", "1"], "--level is for a grey image; a label image (--labels) has none"),
        (["--label", "1=x"], "--label names a region of a label image: add --labels"),
        (["--labels", "--label", "1:x"], "--label must be VALUE=NAME with an integer VALUE"),
        (["--labels"], "holds 1 label besides the background 0"),
        (["--labels", "--partial-volume"], "--partial-volume is for a grey image; a label image (--labels) has no"),
    ],
)
def test_label_errors(scan, tmp_path, capsys, arguments, message):
    one = tmp_path / "one.vti"
    grid = pv.ImageData(dimensions=(6, 6, 6))
    grid["labels"] = (np.arange(216) % 2).astype(np.int16)
    grid.save(one)
    assert main(["mesh", str(one), "--h", "0.1", "-o", str(tmp_path / "x.inp"), *arguments]) == 1
    assert message in capsys.readouterr().err


def test_inside_is_checked_against_the_kind_of_model(scan, capsys, tmp_path):
    # one --inside flag: closed/winding for surface mesh files, above/below for images
    assert main(["surface", str(scan), "--level", "500", "--inside", "winding", "-o", str(tmp_path / "a.stl")]) != 0
    err = capsys.readouterr().err
    assert "is an image: --inside takes 'above' or 'below'" in err and "'winding'" in err
    stl = tmp_path / "ball.stl"
    pv.Sphere(radius=1.0).save(stl)
    assert main(["surface", str(stl), "--inside", "below", "-o", str(tmp_path / "b.stl")]) != 0
    assert "--inside below applies to images only" in capsys.readouterr().err
    assert not (tmp_path / "a.stl").exists() and not (tmp_path / "b.stl").exists()


def test_a_tiff_stack_without_a_voxel_size_says_so_and_takes_one(tmp_path, capsys):
    tifffile = pytest.importorskip("tifffile")
    grid = partial_volume(TORUS, (-1, -1, -0.4), (1, 1, 0.4), 0.1, scale=1000.0)
    values = np.asarray(grid.point_data[grid.point_data.keys()[0]]).reshape(grid.dimensions, order="F")
    tifffile.imwrite(tmp_path / "scan.tif", np.transpose(values, (2, 1, 0)).astype(np.uint16))
    out = tmp_path / "scan.stl"
    assert main(["surface", str(tmp_path / "scan.tif"), "--level", "500", "-o", str(out)]) == 0
    assert "voxels of 1 x 1 x 1 (the file gives no voxel size: --voxel-size sets it)" in capsys.readouterr().err
    assert main(["surface", str(tmp_path / "scan.tif"), "--level", "500", "--voxel-size", "0.1",
                 "--origin", "-1", "-1", "-0.4", "-o", str(out)]) == 0
    assert "voxels of 0.1 x 0.1 x 0.1," in capsys.readouterr().err
    assert pv.read(out).volume == pytest.approx(TORUS_VOLUME, rel=0.03)


def test_partial_volume_from_the_command_line(scan, capsys, tmp_path):
    # the torus at 20 voxels across its tube: its surface holds the shares' volume, and the
    # header line says what was found
    out = tmp_path / "pv.stl"
    assert main(["surface", str(scan), "--level", "500", "--partial-volume", "-o", str(out), "--no-check"]) == 0
    err = capsys.readouterr().err
    assert "partial volumes (background 0, material 1000): volume 1.066" in err and "the surface moved +0.0" in err
    assert pv.read(out).volume == pytest.approx(TORUS_VOLUME, rel=0.002)


@pytest.mark.parametrize("flags, named", [(["--smoothing", "1"], "--smoothing"), (["--partial-volume"], "--partial-volume"),
                                          (["--origin", "0", "0", "0"], "--origin")])
def test_image_flags_on_a_surface_mesh_file_are_refused(tmp_path, capsys, flags, named):
    stl = tmp_path / "ball.stl"
    pv.Sphere(radius=1.0).save(stl)
    assert main(["mesh", str(stl), "--h", "0.5", "-o", str(tmp_path / "x.inp"), *flags]) == 1
    assert f"{named} applies to images (.vti, .nii, .nii.gz, .tif, .zarr) only; ball.stl is not one" in capsys.readouterr().err
    assert not (tmp_path / "x.inp").exists()


def test_an_image_with_several_arrays_is_read_by_the_one_named(scan, tmp_path, capsys):
    # a .vti with two arrays and none active said "name one with array=", which the CLI had no flag for
    grid = pv.read(scan)
    two = pv.ImageData(dimensions=grid.dimensions, spacing=grid.spacing, origin=grid.origin)
    two.point_data["CT"] = np.asarray(grid.point_data[grid.array_names[0]])
    two.point_data["mask"] = (two.point_data["CT"] > 500).astype(np.uint8)
    two.point_data.active_scalars_name = None
    path = tmp_path / "two.vti"
    two.save(path)
    out = tmp_path / "two.stl"
    assert main(["surface", str(path), "--level", "500", "-o", str(out), "--no-check"]) == 1
    assert "none is active; name one with array= (fepre mesh and fepre surface: --array NAME)" in capsys.readouterr().err
    assert main(["surface", str(path), "--level", "500", "--array", "CT", "-o", str(out), "--no-check"]) == 0
    assert pv.read(out).volume == pytest.approx(TORUS_VOLUME, rel=0.01)


def test_float_labels_say_what_to_pass(tmp_path, capsys):
    grid = pv.ImageData(dimensions=(6, 6, 6))
    grid["labels"] = np.linspace(0, 2.5, 216)
    grid.save(tmp_path / "float.vti")
    assert main(["mesh", str(tmp_path / "float.vti"), "--labels", "--h", "1", "-o", str(tmp_path / "x.inp")]) == 1
    assert "round or cast them to integers, or mesh a grey image" in capsys.readouterr().err


def test_the_header_names_the_volume_an_images_values_give(tmp_path, capsys):
    # a new user's scan meshed without --partial-volume came out 5.1% short with no word; the
    # header now names the volume its values give when the level set is more than 1% off it
    coarse = partial_volume(TORUS, (-1, -1, -0.4), (1, 1, 0.4), 0.1, scale=1000.0)  # a tube 3 voxels in radius
    coarse.save(tmp_path / "coarse.vti")
    assert main(["surface", str(tmp_path / "coarse.vti"), "--level", "500", "-o", str(tmp_path / "c.stl"), "--no-check"]) == 0
    err = capsys.readouterr().err
    assert re.search(r"the level set holds 1\.05\d+, 1\.\d% less than the 1\.06\d+ its values give", err)
    assert "(--partial-volume keeps that; not for a density)" in err
    assert main(["surface", str(tmp_path / "coarse.vti"), "--level", "500", "--partial-volume", "-o",
                 str(tmp_path / "c.stl"), "--no-check"]) == 0
    assert "its values give" not in capsys.readouterr().err
