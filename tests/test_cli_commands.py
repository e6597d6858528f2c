"""Every `fepre` subcommand on a model file; user errors are messages with exit code 1, not tracebacks."""

from __future__ import annotations

import json
import math
import re
import textwrap

import meshio
import numpy as np
import pytest
import pyvista as pv
from PIL import Image

from fepre.cli import main

BALL = """
from fepre import sdf

base = sdf.plane((0, 0, -1), (0, 0, -0.5))
model = sdf.sphere(1.0) & base  # a ball with its bottom cap cut off flat
h = 0.3
boundaries = {"base": base}
"""
BALL_VOLUME = 4 * math.pi / 3 - math.pi * 0.5**2 * (3 - 0.5) / 3  # the sphere minus a cap of height 0.5


@pytest.fixture(scope="module")
def folder(tmp_path_factory):
    path = tmp_path_factory.mktemp("cli")
    (path / "ball.py").write_text(BALL)
    return path


@pytest.fixture(scope="module")
def meshed(folder):
    assert main(["mesh", str(folder / "ball.py"), "-o", str(folder / "ball.vtu")]) == 0
    assert main(["mesh", str(folder / "ball.py"), "-o", str(folder / "ball.inp"), "--h", "0.35"]) == 0
    return folder


def _non_blank(path) -> float:
    image = np.asarray(Image.open(path).convert("RGB"))
    return float(np.any(image < 235, axis=2).mean())


def test_mesh_says_when_the_mesh_is_in_separate_pieces(folder, capsys):
    # a STEP file's two separate bodies were meshed into two pieces without a word; each needs
    # holding in a solver
    (folder / "two.py").write_text("from fepre import sdf\nmodel = sdf.sphere(1.0) | sdf.sphere(0.8).translate((3, 0, 0))\n")
    assert main(["mesh", str(folder / "two.py"), "-o", str(folder / "two.vtu"), "--h", "0.4"]) == 0
    line = next(text for text in capsys.readouterr().err.splitlines() if "tetrahedra, " in text)
    counts = [int(c.replace(",", "")) for c in re.search(r"in 2 pieces not joined through faces \(([\d,]+), ([\d,]+) cells", line).groups()]
    assert sum(counts) == pv.read(folder / "two.vtu").n_cells and counts[0] > counts[1] > 0
    assert main(["mesh", str(folder / "ball.py"), "-o", str(folder / "one.vtu")]) == 0
    assert "pieces" not in next(text for text in capsys.readouterr().err.splitlines() if "tetrahedra, " in text)


def test_surface_writes_a_closed_stl_with_the_right_volume(folder, capsys):
    out = folder / "ball.stl"
    assert main(["surface", str(folder / "ball.py"), "-o", str(out), "--spacing", "0.04"]) == 0
    assert "watertight" in capsys.readouterr().out
    surface = pv.read(out)
    assert surface.n_open_edges == 0
    assert surface.volume == pytest.approx(BALL_VOLUME, rel=0.01)


def test_surface_methods_and_bad_suffix(folder, capsys):
    out = folder / "nets.ply"
    assert main(["surface", str(folder / "ball.py"), "-o", str(out), "--method", "surface_nets", "--spacing", "0.1"]) == 0
    assert pv.read(out).n_cells > 500
    assert main(["surface", str(folder / "ball.py"), "-o", str(folder / "ball.txt")]) == 1
    assert "--output must end in .stl" in capsys.readouterr().err


def test_mesh_writes_solver_files_with_named_sets(meshed):
    grid = pv.read(meshed / "ball.vtu")  # tetrahedra and the tagged boundary triangles
    tets = grid.extract_cells(np.flatnonzero(grid.celltypes == pv.CellType.TETRA))
    assert tets.n_cells > 500
    assert tets.volume == pytest.approx(BALL_VOLUME, rel=0.08)
    inp = meshio.read(meshed / "ball.inp")
    assert inp.cells[0].type == "tetra" and len(inp.points) > 20
    assert "base" in inp.point_sets
    base = inp.points[inp.point_sets["base"]]
    gap = np.abs(base[:, 2] + 0.5)  # nodes of the faces on the flat cut (its rim is rounded at h)
    assert np.count_nonzero(gap < 1e-6) >= 5 and gap.max() < 0.35


def test_mesh_order_2_and_missing_h(folder, capsys):
    out = folder / "ball2.vtu"
    assert main(["mesh", str(folder / "ball.py"), "-o", str(out), "--order", "2", "--h", "0.4"]) == 0
    assert pv.CellType.QUADRATIC_TETRA in set(np.unique(pv.read(out).celltypes))
    (folder / "noh.py").write_text("from fepre import sdf\nmodel = sdf.sphere(1.0)\n")
    capsys.readouterr()
    assert main(["mesh", str(folder / "noh.py"), "-o", str(folder / "x.vtu")]) == 1
    assert "pass --h or set `h = ...`" in capsys.readouterr().err


def test_info_prints_counts_quality_and_sets(meshed, capsys):
    assert main(["info", str(meshed / "ball.inp")]) == 0
    out = capsys.readouterr().out
    inp = meshio.read(meshed / "ball.inp")
    assert f"points     {len(inp.points)}" in out
    assert f"TETRA {len(inp.cells[0].data)}" in out
    assert "min_dihedral_angle" in out and "base" in out
    assert main(["info", str(meshed / "ball.vtu")]) == 0
    assert "radius_ratio" in capsys.readouterr().out


def test_info_on_a_model_file_names_the_commands_that_take_it(folder, capsys):
    assert main(["info", str(folder / "ball.py")]) == 1
    err = capsys.readouterr().err
    assert "is a model file, not a mesh" in err and f"fepre mesh {folder / 'ball.py'} --h H" in err
    step = folder / "part.step"
    step.write_text("ISO-10303-21;\n")
    assert main(["info", str(step)]) == 1
    assert "fepre features" in capsys.readouterr().err


def test_view_screenshots_are_not_blank(meshed, folder, capsys):
    for source, png in ((meshed / "ball.vtu", "mesh.png"), (folder / "ball.py", "model.png")):
        assert main(["view", str(source), "--screenshot", str(folder / png)]) == 0
        assert _non_blank(folder / png) > 0.05
    assert "wrote" in capsys.readouterr().out


def test_view_without_a_display_asks_for_a_screenshot(meshed, capsys, monkeypatch):
    monkeypatch.delenv("DISPLAY", raising=False)
    monkeypatch.delenv("WAYLAND_DISPLAY", raising=False)
    assert main(["view", str(meshed / "ball.vtu")]) == 1
    assert "pass --screenshot" in capsys.readouterr().err


@pytest.mark.slow  # 3 s of the default run on 2 cores
def test_compare_writes_table_json_and_report(meshed, capsys):
    report, figures = meshed / "cmp.html", meshed / "cmp.json"
    argv = ["compare", str(meshed / "ball.py"), "--h", "0.4", "--references", "gmsh", "--report", str(report), "--json", str(figures)]
    assert main(argv) == 0
    out = capsys.readouterr().out
    data = json.loads(figures.read_text())
    assert set(data["meshes"]) == {"fepre", "gmsh"}
    assert str(data["meshes"]["gmsh"]["elements"]) in out.split("\n")[2]  # the "tetrahedra" row
    assert "data:image/png;base64" in report.read_text()


@pytest.mark.parametrize(
    "content, words",
    [
        ("model = sdf.sphere(1.0\n", "syntax error"),
        ("from fepre import sdf\nthing = sdf.sphere(1.0)\n", "defines no `model`"),
        ("from fepre import sdf\nx = 1 / 0\nmodel = sdf.sphere(1.0)\n", "failed to run (line 2): ZeroDivisionError"),
        ("model = 3\n", "`model` must be an fepre SDF"),
        ("from fepre import sdf\nmodel = sdf.sphere(1.0)\nh = -1\n", "h must be > 0"),
    ],
)
def test_bad_model_files_give_a_clear_error_and_exit_1(tmp_path, capsys, content, words):
    path = tmp_path / "bad.py"
    path.write_text(content)
    assert main(["surface", str(path), "-o", str(tmp_path / "x.stl")]) == 1
    err = capsys.readouterr().err
    assert words in err and str(path) in err and "Traceback" not in err
    assert not (tmp_path / "x.stl").exists()


@pytest.mark.parametrize(
    "flags, words",
    [
        # inf, nan, 0 and negative lengths: refused by argparse (the test after the next)
        (["--h", "5"], "--h 5 must be smaller than the part's largest extent 2"),
        (["--h", "0.5", "--hmax", "0.25"], "--hmax must be larger than --h; got --hmax 0.25 and --h 0.5"),
    ],
)
def test_edge_lengths_are_checked_and_the_flag_named_before_meshing(tmp_path, capsys, flags, words):
    path = tmp_path / "ball.py"
    path.write_text("from fepre import sdf\nmodel = sdf.sphere(1.0)\n")
    out = tmp_path / "x.inp"
    assert main(["mesh", str(path), *flags, "-o", str(out)]) == 1
    err = capsys.readouterr().err
    assert words in err and "DistMesh" not in err and not out.exists()


def test_max_cells_refuses_a_finer_mesh_by_its_flag_and_writes_nothing(tmp_path, capsys):
    path = tmp_path / "ball.py"
    path.write_text("from fepre import sdf\nmodel = sdf.sphere(1.0)\n")
    out = tmp_path / "x.inp"
    # a unit ball at h = 0.1: 4189 h^3, about 35,000 cells
    assert main(["mesh", str(path), "--h", "0.1", "--max-cells", "1e4", "-o", str(out)]) == 1
    err = capsys.readouterr().err
    assert re.search(r"about 3\d,\d{3} cells, more than max_cells = 10,000 \(CLI: --max-cells\)", err)
    assert "DistMesh h=0.1" in err and "MAX_CELLS" not in err and not out.exists()
    for value in ("1.5", "0", "many", "-3"):
        with pytest.raises(SystemExit):
            main(["mesh", str(path), "--h", "0.1", "--max-cells", value, "-o", str(out)])
        err = capsys.readouterr().err
        assert "argument --max-cells: expected a whole number of cells >= 1" in err and repr(value) in err
    assert not out.exists()


def test_a_file_without_an_edge_length_is_refused_before_it_is_read(tmp_path, capsys):
    # a STEP file carries no edge length: the error comes before its (slow) tessellation; this
    # one is not even a STEP file, and reading it would fail otherwise
    junk = tmp_path / "part.step"
    junk.write_text("not a STEP file")
    for command in (["mesh", str(junk), "--hmax", "5", "-o", str(tmp_path / "x.inp")], ["size", str(junk), "--hmax", "5", "-o", str(tmp_path / "x.vti")]):
        assert main(command) == 1
        err = capsys.readouterr().err
        assert "no edge length: pass --h" in err and "part.step" in err


def test_edge_lengths_as_the_parts_diagonal_over_n(tmp_path, capsys):
    # The hint said "--h D/20" and --h refused it ("invalid float value"): D/N is now an edge
    # length, the diagonal of the part's box over N, said on the header line.
    stl = tmp_path / "box.stl"
    pv.Box(bounds=(0, 4, 0, 3, 0, 12)).triangulate().save(stl)  # diagonal 13
    out = tmp_path / "box.vtu"
    assert main(["mesh", str(stl), "--h", "D/10", "--hmax", "d/5", "-o", str(out)]) == 0
    err = capsys.readouterr().err
    assert "--h D/10: 1.3 (the part's box has a diagonal of 13)" in err and "--hmax D/5: 2.6" in err
    assert "h from 1.3 to 2.6" in err
    for flags, words in ((["--h", "D/0"], "argument --h: D/N needs a number N > 0"),
                         (["--h", "D/fifty"], "argument --h: D/N needs a number N > 0"),
                         (["--h", "half"], "argument --h: expected a length, or D/N")):
        with pytest.raises(SystemExit):
            main(["mesh", str(stl), *flags, "-o", str(tmp_path / "x.vtu")])
        assert words in capsys.readouterr().err
    assert main(["mesh", str(stl), "-o", str(tmp_path / "x.vtu")]) == 1
    assert "or --h D/N for the part's bounding-box diagonal over N" in capsys.readouterr().err


@pytest.mark.slow  # 20 s of the default run on 2 cores
def test_strict_writes_nothing_when_the_mesh_draws_a_resolution_warning(tmp_path, capsys):
    # a new user's enclosure at D/25 came out with a free 57-cell piece, warned, written, exit 0,
    # and CalculiX solved it; --strict refuses such a mesh
    path = tmp_path / "fin.py"
    path.write_text("from fepre import sdf\nmodel = sdf.box((8, 8, 2)) | sdf.box((0.3, 8, 6)).translate((2, 0, 3))\n")
    out = tmp_path / "fin.inp"
    assert main(["mesh", str(path), "--h", "1", "--strict", "-o", str(out), "--quiet"]) == 1
    err = capsys.readouterr().err
    assert "warning: distmesh: the mesh leaves out about" in err
    assert "error: --strict: " in err and "nothing written" in err and not out.exists()
    # a ball of radius 1 at h = 0.3 is 3% short of its volume by its chords, which warns too
    ball = tmp_path / "ball.py"
    ball.write_text("from fepre import sdf\nmodel = sdf.sphere(1.0)\n")
    assert main(["mesh", str(ball), "--h", "0.3", "--strict", "-o", str(tmp_path / "ball.inp"), "--quiet"]) == 1
    assert "the mesh's volume is" in capsys.readouterr().err
    assert main(["mesh", str(ball), "--h", "0.1", "--strict", "-o", str(tmp_path / "ball.inp"), "--quiet"]) == 0


def test_missing_files_and_bad_usage(tmp_path, capsys):
    assert main(["mesh", str(tmp_path / "nope.py"), "-o", str(tmp_path / "x.inp")]) == 1
    assert "does not exist" in capsys.readouterr().err
    assert main(["info", str(tmp_path / "nope.vtu")]) == 1
    assert main(["view", str(tmp_path / "nope.vtu"), "--screenshot", str(tmp_path / "x.png")]) == 1
    (tmp_path / "junk.vtu").write_text(textwrap.dedent("not a mesh"))
    assert main(["info", str(tmp_path / "junk.vtu")]) == 1
    assert "holds no points" in capsys.readouterr().err
    with pytest.raises(SystemExit) as exit_:
        main(["mesh", "ball.py"])  # -o is required
    assert exit_.value.code == 2
    with pytest.raises(SystemExit) as exit_:  # named by its flag, before the model is read
        main(["mesh", str(tmp_path / "nope.py"), "-o", str(tmp_path / "x.inp"), "--seed", "-3"])
    assert exit_.value.code == 2 and "argument --seed: expected a non-negative integer; got '-3'" in capsys.readouterr().err


@pytest.mark.parametrize("value", ["-1", "0", "nan", "inf"])
def test_a_length_that_is_no_length_is_refused_by_its_flag_before_the_model_is_read(tmp_path, capsys, value):
    # a new user's --h -1 on an 84k-triangle STL was refused after 262 s of reading it; the file
    # here does not exist, so any other order of checks says so instead
    for flag in ("--h", "--hmax"):
        with pytest.raises(SystemExit) as exit_:
            main(["mesh", str(tmp_path / "nope.stl"), "-o", str(tmp_path / "x.vtu"), flag, value])
        err = capsys.readouterr().err
        assert exit_.value.code == 2 and f"argument {flag}: a length must be a finite number > 0" in err, err
        assert f"got '{value}'" in err


def test_an_hmax_under_h_is_refused_before_the_model_is_read(tmp_path, capsys):
    missing = str(tmp_path / "nope.stl")
    assert main(["mesh", missing, "-o", str(tmp_path / "x.vtu"), "--h", "1", "--hmax", "0.5"]) == 1
    assert "--hmax must be larger than --h; got --hmax 0.5 and --h 1" in capsys.readouterr().err
    assert main(["mesh", missing, "-o", str(tmp_path / "x.vtu"), "--h", "D/50", "--hmax", "D/100"]) == 1
    assert "--hmax must be larger than --h; got --hmax D/100 and --h D/50" in capsys.readouterr().err
    assert main(["size", missing, "-o", str(tmp_path / "x.vti"), "--h", "2", "--hmax", "2"]) == 1
    assert "--hmax must be larger than --h" in capsys.readouterr().err
    assert not list(tmp_path.iterdir())


def test_features_prints_and_writes_the_rim_of_the_cut_ball(folder, capsys):
    out = folder / "ball_features.vtp"
    assert main(["features", str(folder / "ball.py"), "-o", str(out)]) == 0
    printed = capsys.readouterr().out
    assert "corners          0" in printed and "curves           1 (1 closed)" in printed
    rim = pv.read(out)
    assert rim.n_lines == 1
    # the circle where the plane z = -0.5 cuts the unit sphere: radius sqrt(0.75)
    np.testing.assert_allclose(np.linalg.norm(rim.points[:, :2], axis=1), math.sqrt(0.75), atol=1e-9)
    np.testing.assert_allclose(rim.points[:, 2], -0.5, atol=1e-9)
    assert main(["features", str(folder / "ball.py"), "-o", str(folder / "rim.stl")]) == 1
    assert "--output must end in .vtp or .vtk" in capsys.readouterr().err


def test_mesh_keeps_the_rim_sharp_unless_told_not_to(folder):
    sharp, rounded = folder / "sharp.vtu", folder / "rounded.vtu"
    assert main(["mesh", str(folder / "ball.py"), "-o", str(sharp)]) == 0
    assert main(["mesh", str(folder / "ball.py"), "-o", str(rounded), "--no-features"]) == 0
    on_rim = lambda grid: np.sum((np.abs(grid.points[:, 2] + 0.5) < 1e-9)  # noqa: E731
                                 & (np.abs(np.linalg.norm(grid.points[:, :2], axis=1) - math.sqrt(0.75)) < 1e-9))
    assert on_rim(pv.read(sharp)) >= round(2 * math.pi * math.sqrt(0.75) / 0.3)
    assert on_rim(pv.read(rounded)) < on_rim(pv.read(sharp))


@pytest.mark.parametrize(
    "argv, message",
    [
        (["mesh", "{ball}", "-o", "{dir}/a.foo"], "--output must end in .inp"),
        (["mesh", "{ball}", "-o", "{dir}/nodir/a.inp"], "the folder '{dir}/nodir' does not exist"),
        (["compare", "{ball}", "--report", "{dir}/nodir/r.html"], "--report '{dir}/nodir/r.html': the folder"),
        (["compare", "{ball}", "--json", "{dir}/r.txt"], "--json must end in .json"),
        (["mesh", "{ball}", "-o", "{dir}/a.mesh", "--order", "2"], "--order 2: format medit (.mesh) supports order 1 only"),
        (["view", "{ball}", "--screenshot", "{dir}/nodir/a.png"], "--screenshot '{dir}/nodir/a.png': the folder"),
    ],
)
def test_bad_output_paths_fail_before_any_work(folder, tmp_path, capsys, argv, message):
    # `-o a.foo` used to be refused after 6.8 s of meshing, a missing folder after the whole run.
    fill = {"ball": str(folder / "ball.py"), "dir": str(tmp_path)}
    start = __import__("time").perf_counter()
    assert main([a.format(**fill) for a in argv]) == 1
    assert __import__("time").perf_counter() - start < 5.0  # DistMesh of the ball alone takes longer
    assert message.format(**fill) in capsys.readouterr().err
    assert list(tmp_path.iterdir()) == []


def test_an_empty_model_is_an_error_and_writes_nothing(tmp_path, capsys):
    # `fepre surface empty.py -o a.stl` wrote an 84-byte empty STL and exited 0.
    model = tmp_path / "empty.py"
    model.write_text("from fepre import sdf\nmodel = sdf.sphere(1.0) & sdf.box(0.5, center=(5, 5, 5))\n"
                     "bounds = ((-1, -1, -1), (1, 1, 1))\n")
    assert main(["surface", str(model), "-o", str(tmp_path / "a.stl")]) == 1
    assert "is empty" in capsys.readouterr().err
    assert sorted(p.name for p in tmp_path.iterdir()) == ["empty.py"]


def test_signatures_show_the_parameters():
    import inspect

    import fepre

    for function, parameter in ((fepre.distmesh, "h"), (fepre.export, "order"), (fepre.features, "angle")):
        assert parameter in inspect.signature(function).parameters


def test_warnings_are_one_clean_line(tmp_path, capsys):
    # They showed "cli.py:124: UserWarning: ..." and the source line of fepre's own code.
    model = tmp_path / "empty.py"
    model.write_text("from fepre import sdf\nmodel = sdf.sphere(1.0) & sdf.box(0.5, center=(5, 5, 5))\n"
                     "bounds = ((-1, -1, -1), (1, 1, 1))\n")
    main(["surface", str(model), "-o", str(tmp_path / "a.stl")])
    err = capsys.readouterr().err.splitlines()
    assert any(line.startswith("fepre surface: warning: the surface is empty") for line in err)
    assert not any("UserWarning" in line or ".py:" in line for line in err)


def test_an_empty_intersection_is_named_as_such():
    # "bounds must have min < max on every axis; axis 0 has 4.75 >= 4.75" said nothing useful.
    import fepre
    from fepre import sdf

    empty = sdf.sphere(1.0) & sdf.box(0.5, center=(5, 5, 5))
    for call in (lambda: fepre.distmesh(empty, 0.1), lambda: fepre.sample(empty, spacing=0.1),
                 lambda: fepre.features(empty, 0.1)):
        with pytest.raises(ValueError, match="the model is empty: its bounds have no volume"):
            call()


def test_a_named_boundary_that_matches_no_face_is_an_error(tmp_path, capsys):
    # It was dropped from the .inp with a warning naming API keywords, and exit 0.
    model = tmp_path / "part.py"
    model.write_text("from fepre import sdf\nmodel = sdf.sphere(1.0)\nh = 0.5\n"
                     "boundaries = {'lid': sdf.plane((0, 0, 1), (0, 0, 5.0))}\n")
    assert main(["mesh", str(model), "-o", str(tmp_path / "part.inp")]) == 1
    err = capsys.readouterr().err
    assert "boundaries 'lid' in" in err and "match no boundary face" in err and "boundary_tolerance" not in err
    assert sorted(p.name for p in tmp_path.iterdir()) == ["part.py"]


def test_surface_level_bounds_no_check_and_quiet(tmp_path, capsys):
    model = tmp_path / "ball.py"
    model.write_text("from fepre import sdf\nmodel = sdf.sphere(1.0)\n")
    grown = tmp_path / "grown.stl"
    assert main(["surface", str(model), "-o", str(grown), "--level", "0.2", "--spacing", "0.05",
                 "--bounds", "-1.5", "-1.5", "-1.5", "1.5", "1.5", "1.5", "--no-check", "--quiet"]) == 0
    captured = capsys.readouterr()
    assert captured.out.strip() == f"wrote {grown}" and "watertight" not in captured.out and captured.err == ""
    assert pv.read(grown).volume == pytest.approx(4 / 3 * math.pi * 1.2**3, rel=0.01)  # the offset surface
    half = tmp_path / "half.stl"
    assert main(["surface", str(model), "-o", str(half), "--bounds", "-2", "-2", "0", "2", "2", "2", "--spacing", "0.05"]) == 0
    points = np.asarray(pv.read(half).points)
    assert points[:, 2].min() >= -1e-9 and "watertight" in capsys.readouterr().out
    assert main(["surface", str(model), "-o", str(half), "--bounds", "1", "-2", "0", "-1", "2", "2"]) == 1
    assert "--bounds must have min < max" in capsys.readouterr().err


def test_view_slice_and_clip_render_inside(meshed, tmp_path, capsys):
    for option in (["--slice", "z=0.2"], ["--clip", "y"]):
        png = tmp_path / f"{option[0][2:]}.png"
        assert main(["view", str(meshed / "ball.vtu"), *option, "--screenshot", str(png)]) == 0
        assert _non_blank(png) > 0.05
    assert main(["view", str(meshed / "ball.vtu"), "--slice", "w", "--screenshot", str(tmp_path / "x.png")]) == 1
    assert "--slice must be x, y or z" in capsys.readouterr().err
    assert main(["view", str(meshed / "ball.vtu"), "--slice", "z", "--clip", "x", "--screenshot", str(tmp_path / "x.png")]) == 1
    assert "not both" in capsys.readouterr().err


def test_mesh_quiet_prints_only_the_written_file(tmp_path, capsys):
    # a flat-faced part: the ball at h = 0.4 (D/5) is 6.9% short of its volume, which warns
    (tmp_path / "block.py").write_text("from fepre import sdf\nmodel = sdf.box((2, 1, 1))\n")
    out = tmp_path / "block.inp"
    assert main(["mesh", str(tmp_path / "block.py"), "-o", str(out), "--h", "0.4", "--quiet"]) == 0
    captured = capsys.readouterr()
    assert captured.out.startswith(f"wrote {out}") and captured.err == "" and "min_dihedral" not in captured.out


@pytest.mark.slow  # 4 s of the default run on 2 cores
def test_api_warnings_point_at_the_users_line(tmp_path):
    # They pointed into fepre ("fepre/distmesh/__init__.py:27", "fepre/export/__init__.py:199").
    import subprocess
    import sys

    script = tmp_path / "user.py"
    script.write_text(
        "import warnings, fepre\nfrom fepre import sdf\nwarnings.simplefilter('always')\n"
        "fepre.distmesh(sdf.sphere(1.0), 0.4, maxiter=3)\n"
        "fepre.export(fepre.distmesh(sdf.sphere(1.0), 0.5), 'x.inp', boundaries={'lid': sdf.plane((0, 0, 1), (0, 0, 5))})\n"
    )
    done = subprocess.run([sys.executable, str(script)], cwd=tmp_path, capture_output=True, text=True, timeout=300)
    lines = [line for line in done.stderr.splitlines() if "Warning:" in line]
    assert any(line.startswith(f"{script}:4: ConvergenceWarning") for line in lines), lines
    assert any(line.startswith(f"{script}:5: BoundaryWarning") for line in lines), lines
    assert not any("/fepre/" in line for line in lines)


@pytest.mark.parametrize("command", ["surface", "mesh", "features", "compare"])
def test_an_unbounded_model_gets_the_model_file_hint_everywhere(tmp_path, capsys, command):
    model = tmp_path / "lattice.py"
    model.write_text("from fepre import sdf\nmodel = sdf.gyroid(1.0)\nh = 0.2\n")
    extra = {"surface": ["-o", str(tmp_path / "a.stl")], "mesh": ["-o", str(tmp_path / "a.inp")]}.get(command, [])
    assert main([command, str(model), *extra]) == 1
    assert "the model is unbounded; set `bounds = ((xmin, ymin, zmin), (xmax, ymax, zmax))` in the model file" in capsys.readouterr().err


REGIONS_MODEL = """from fepre import sdf
model = sdf.box((2, 1, 1), center=(1, 0.5, 0.5))
regions = {"soft": sdf.box((1, 1, 1), center=(0.5, 0.5, 0.5)), "stiff": sdf.box((1, 1, 1), center=(1.5, 0.5, 0.5))}
materials = {"soft": (1000, 0.3), "stiff": (3000, 0.3)}
h = 0.25
"""


def test_mesh_with_regions_writes_sections_and_the_interface(tmp_path, capsys):
    (tmp_path / "bar.py").write_text(REGIONS_MODEL)
    assert main(["mesh", str(tmp_path / "bar.py"), "-o", str(tmp_path / "bar.inp"), "--quiet"]) == 0
    text = (tmp_path / "bar.inp").read_text()
    assert "*MATERIAL, NAME=soft" in text and "*SOLID SECTION, ELSET=stiff, MATERIAL=stiff" in text
    assert "*SURFACE, NAME=interface_soft_stiff, TYPE=ELEMENT" in text
    grid = pv.read(tmp_path / "bar.inp")
    volumes = grid.compute_cell_sizes()["Volume"]
    np.testing.assert_allclose(np.bincount(grid["region_id"], volumes), [1.0, 1.0], rtol=1e-12)
    # flags override the file's materials; --no-regions meshes one region
    assert main(["mesh", str(tmp_path / "bar.py"), "-o", str(tmp_path / "flags.inp"), "--quiet",
                 "--material", "soft", "5", "0.2", "--material", "stiff", "7", "0.25"]) == 0
    assert "5.000000000000e+00, 2.000000000000e-01" in (tmp_path / "flags.inp").read_text()
    assert main(["mesh", str(tmp_path / "bar.py"), "-o", str(tmp_path / "one.vtu"), "--quiet", "--no-regions"]) == 0
    picture = tmp_path / "regions.png"
    assert main(["view", str(tmp_path / "bar.inp"), "--metric", "region_id", "--screenshot", str(picture)]) == 0
    pixels = np.asarray(Image.open(picture).convert("RGB")).reshape(-1, 3).astype(int)
    for colour in ((0x1F, 0x77, 0xB4), (0xFF, 0x7F, 0x0E)):  # one colour per region (shaded)
        assert (np.abs(pixels - colour).sum(axis=1) < 120).sum() > 500
    one = pv.read(tmp_path / "one.vtu")
    from fepre.export.grid import set_names

    # the one region is "volume" (in the file's field data as volume_set: a cell array is named volume)
    assert set_names(one)[0] == ["volume"] and set(np.unique(one["region_id"])) == {0}


@pytest.mark.parametrize(
    "extra, message",
    [
        (["--material", "soft", "1", "0.3"], "must give every region a material; missing stiff"),
        (["--material", "soft", "1", "0.3", "--material", "core", "1", "0.3", "--material", "stiff", "1", "0.3"],
         "--material names core, not a region of the mesh"),
        (["--material", "soft", "x", "0.3", "--material", "stiff", "1", "0.3"], "E and NU must be numbers"),
        (["--material", "soft", "1", "0.7", "--material", "stiff", "1", "0.3"], "nu must lie in (-1, 0.5)"),
        (["--period", "2"], "--period: "),
    ],
)
def test_bad_region_flags_fail_before_any_work(tmp_path, capsys, extra, message):
    (tmp_path / "bar.py").write_text(REGIONS_MODEL)
    assert main(["mesh", str(tmp_path / "bar.py"), "-o", str(tmp_path / "bar.inp"), *extra]) == 1
    assert message in capsys.readouterr().err
    assert not (tmp_path / "bar.inp").exists()


def test_materials_need_an_inp_and_regions_must_split_the_part(tmp_path, capsys):
    (tmp_path / "bar.py").write_text(REGIONS_MODEL)
    flags = ["--material", "soft", "1", "0.3", "--material", "stiff", "1", "0.3"]
    assert main(["mesh", str(tmp_path / "bar.py"), "-o", str(tmp_path / "bar.msh"), *flags]) == 1
    assert "only an .inp file carries materials" in capsys.readouterr().err
    (tmp_path / "gap.py").write_text(REGIONS_MODEL.replace("center=(1.5, 0.5, 0.5)", "center=(1.7, 0.5, 0.5)"))
    assert main(["mesh", str(tmp_path / "gap.py"), "-o", str(tmp_path / "gap.inp")]) == 1
    assert "uncovered" in capsys.readouterr().err
    assert not list(tmp_path.glob("*.inp")) and not list(tmp_path.glob("*.msh"))


def test_a_one_region_model_file_s_materials_are_written(tmp_path, capsys):
    # a model file's `materials` for its one region ("volume") was dropped when it had no
    # `regions`: the .inp had no *MATERIAL and CalculiX stopped with "no material was assigned"
    (tmp_path / "bar.py").write_text('from fepre import sdf\nmodel = sdf.box((10, 2, 2))\nmaterials = {"volume": (210e3, 0.3)}\n')
    assert main(["mesh", str(tmp_path / "bar.py"), "-o", str(tmp_path / "bar.inp"), "--h", "0.8", "--quiet"]) == 0
    deck = (tmp_path / "bar.inp").read_text()
    assert "*MATERIAL, NAME=volume" in deck and "*SOLID SECTION, ELSET=volume, MATERIAL=volume" in deck
    young, poisson = deck[deck.index("*ELASTIC"):].splitlines()[1].split(",")
    assert float(young) == 210e3 and float(poisson) == 0.3
    (tmp_path / "wrong.py").write_text('from fepre import sdf\nmodel = sdf.box((10, 2, 2))\nmaterials = {"steel": (210e3, 0.3)}\n')
    assert main(["mesh", str(tmp_path / "wrong.py"), "-o", str(tmp_path / "wrong.inp"), "--h", "0.8"]) == 1
    assert "names steel, not a region of the mesh (regions: volume)" in capsys.readouterr().err
    assert not (tmp_path / "wrong.inp").exists()


def test_mesh_xdmf_names_every_file_and_info_reads_the_facet_tags(folder, tmp_path, capsys):
    """XDMF is four files (cells and facets, each with its .h5): `fepre mesh` says so, and `fepre
    info` reads the facets companion and reports its tags."""
    out = tmp_path / "ball.xdmf"
    assert main(["mesh", str(folder / "ball.py"), "-o", str(out), "--h", "0.4", "--quiet"]) == 0
    printed = capsys.readouterr().out
    for name in ("ball.xdmf", "ball.h5", "ball_facets.xdmf", "ball_facets.h5"):
        assert (tmp_path / name).is_file()
        assert f"wrote {tmp_path / name}" in printed, printed
    facets = meshio.read(tmp_path / "ball_facets.xdmf")
    ids = np.concatenate([np.asarray(b) for b in facets.cell_data["boundary_id"]])
    assert main(["info", str(out)]) == 0
    info = capsys.readouterr().out
    assert f"base ({int(np.count_nonzero(ids == 1))})" in info, info
    assert f"boundary ({int(np.count_nonzero(ids == 2))})" in info, info
    assert "ball_facets.xdmf" in info


def test_mesh_and_info_print_each_boundary_sets_faces_and_area(folder, tmp_path, capsys):
    # Issue 33: nothing printed showed a set's area, so a set taking extra faces went unseen. The
    # ball's flat base is a disc of radius sqrt(0.75): area 0.75 pi; quadratic faces follow its rim.
    out = tmp_path / "ball.inp"
    assert main(["mesh", str(folder / "ball.py"), "-o", str(out), "--order", "2", "--quiet"]) == 0
    printed = capsys.readouterr().out
    lines = {line.split()[2]: line for line in printed.splitlines() if line.startswith("boundary set ")}
    assert set(lines) == {"base", "boundary"}, printed
    base = re.search(r"base\s+(\d+) faces  area ([\d.]+)", lines["base"])
    assert float(base.group(2)) == pytest.approx(0.75 * math.pi, rel=1e-3)
    for name in (out, tmp_path / "ball.vtu", tmp_path / "ball.xdmf"):
        if name != out:
            assert main(["mesh", str(folder / "ball.py"), "-o", str(name), "--order", "2", "--quiet"]) == 0
            capsys.readouterr()
        assert main(["info", str(name)]) == 0
        info = capsys.readouterr().out
        assert "boundary set areas" in info, info
        again = re.search(r"base\s+(\d+) faces  area ([\d.]+)", info.split("boundary set areas")[1])
        assert again.groups() == base.groups(), (name, info)


def test_mesh_prints_the_exact_area_a_model_file_gives_beside_the_sets(tmp_path, capsys):
    # fepre cannot know a set's exact area; the user can (`boundary_areas`), and sees the difference.
    model = tmp_path / "ball.py"
    model.write_text(BALL + "import math\nboundary_areas = {'base': 0.75 * math.pi}\n")
    assert main(["mesh", str(model), "-o", str(tmp_path / "ball.inp"), "--order", "2", "--quiet"]) == 0
    line = next(x for x in capsys.readouterr().out.splitlines() if x.startswith("boundary set base"))
    difference = float(re.search(r"\(exact 2.356194: ([+-][\d.]+)%\)", line).group(1))
    assert abs(difference) <= 0.1, line
    model.write_text(BALL + "boundary_areas = {'lid': 1.0}\n")
    assert main(["mesh", str(model), "-o", str(tmp_path / "bad.inp"), "--quiet"]) == 1
    assert "`boundary_areas` names ['lid'], which are not in `boundaries` ['base']" in capsys.readouterr().err
    model.write_text(BALL + "boundary_areas = {'base': -1.0}\n")
    assert main(["mesh", str(model), "-o", str(tmp_path / "bad.inp"), "--quiet"]) == 1
    assert "boundary_areas['base']" in capsys.readouterr().err


def test_a_model_file_sets_the_boundary_tolerance(tmp_path, capsys):
    # a triangle-mesh model's facets lie only near an exact cylinder named as a set: the file
    # says how far its nodes may be (the warning names the value); out of (0, 0.25] is refused
    import pyvista as pv

    from fepre.modelfile import load_model

    pv.Cylinder(radius=2.0, height=4.0, resolution=48).triangulate().save(tmp_path / "bar.stl")
    text = (f"from fepre import sdf\nmodel = sdf.mesh({str(tmp_path / 'bar.stl')!r})\n"
            "boundaries = {'side': sdf.cylinder(radius=2.0, height=10.0, axis='x')}\n")
    (tmp_path / "bar.py").write_text(text + "boundary_tolerance = 0.03\n")
    assert load_model(tmp_path / "bar.py").boundary_tolerance == 0.03
    assert main(["mesh", str(tmp_path / "bar.py"), "--h", "0.4", "-o", str(tmp_path / "bar.inp"), "--quiet"]) == 0
    line = next(line for line in capsys.readouterr().out.splitlines() if "boundary set side" in line)
    assert float(line.split("area")[1]) == pytest.approx(2 * np.pi * 2 * 4, rel=0.02)  # the facets' chords
    (tmp_path / "bad.py").write_text(text + "boundary_tolerance = 0.5\n")
    assert main(["mesh", str(tmp_path / "bad.py"), "--h", "0.4", "-o", str(tmp_path / "bad.inp")]) == 1
    assert "`boundary_tolerance` must be in (0, 0.25]" in capsys.readouterr().err


@pytest.mark.slow  # 3 s of the default run on 2 cores
def test_the_header_of_shells_split_at_their_seams_counts_no_smooth_pieces(tmp_path, capsys):
    """Two crossing boxes: their triangles are split into loose pieces where they cross, each a
    smooth piece of its own (two touching boxes of 11,688 triangles read "18679 smooth pieces")."""
    stl = tmp_path / "pair.stl"
    (pv.Cube().triangulate() + pv.Cube(center=(0.37, 0.41, 0.29)).triangulate()).save(stl)
    assert main(["surface", str(stl), "-o", str(tmp_path / "x.stl")]) == 0
    header = [line for line in capsys.readouterr().err.splitlines() if "pair.stl:" in line]
    assert header and "triangles; repaired:" in header[0] and "smooth pieces" not in header[0], header
    single = tmp_path / "box.stl"
    pv.Cube().triangulate().save(single)
    assert main(["surface", str(single), "-o", str(tmp_path / "y.stl")]) == 0
    assert "12 triangles, 6 smooth pieces; closed and consistently oriented" in capsys.readouterr().err
