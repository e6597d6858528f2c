"""`fepre demo --quick`: every part's STL, VTU and INP, one report, a summary table."""

from __future__ import annotations

import math
import re

import meshio
import numpy as np
import pytest
import pyvista as pv

from fepre.cli import main
from fepre.demo import demo_parts

EXACT = {"cube_with_hole": 125 - 5 * math.pi, "sphere": 4 * math.pi / 3, "torus": 2 * math.pi**2 * 0.16}
# no closed form: Monte Carlo with 2e7 points (and flying edges at a fine spacing agree)
REFERENCE = {"l_bracket": 7.408, "gyroid_block": 3.2776, "imported_block": 18480.9}


@pytest.fixture(scope="module")
def demo(tmp_path_factory):
    outdir = tmp_path_factory.mktemp("demo") / "out"
    import io
    from contextlib import redirect_stderr, redirect_stdout

    out, err = io.StringIO(), io.StringIO()
    with redirect_stdout(out), redirect_stderr(err):
        code = main(["demo", str(outdir), "--quick"])
    return outdir, code, out.getvalue(), err.getvalue()


def test_demo_parts_are_the_five_of_the_issue_and_an_imported_one():
    names = [part.name for part in demo_parts(quick=True)]
    assert names == ["cube_with_hole", "sphere", "torus", "l_bracket", "gyroid_block", "imported_block", "scanned_bone"]


@pytest.mark.slow
def test_demo_writes_every_file_of_every_part(demo):
    outdir, code, out, err = demo
    failed = dict(re.findall(r"^(\w+) FAILED: (.*)$", out, flags=re.M))
    assert code == (1 if failed else 0)
    assert not failed, f"demo parts failed: {failed}"
    report = (outdir / "report.html").read_text()
    for name, reason in failed.items():  # a part that fails is reported, and the others still run
        assert f"{name} failed: " in report
    written = [part.name for part in demo_parts(quick=True) if part.name not in failed]
    for name in written:
        surface = pv.read(outdir / f"{name}.stl")
        assert surface.n_open_edges == 0, f"{name}.stl is not closed"
        grid = pv.read(outdir / f"{name}.vtu")
        tets = grid.extract_cells(np.flatnonzero(grid.celltypes == pv.CellType.TETRA))
        inp = meshio.read(outdir / f"{name}.inp")
        assert len(inp.cells[0].data) == tets.n_cells > 50
        if name in EXACT:
            assert surface.volume == pytest.approx(EXACT[name], rel=0.02)
            assert tets.volume == pytest.approx(EXACT[name], rel=0.12)
        if name in REFERENCE:  # coarse (quick) h: the bracket's plate is 1.5 h thick, the sheet h
            assert tets.volume == pytest.approx(REFERENCE[name], rel=0.05)
    if "imported_block" in written:  # the STL the demo wrote first, read back as the part
        # the block less the slot (40 x 8 x 6) and the two holes (radius 4, 20 deep)
        assert pv.read(outdir / "imported_block_input.stl").volume == pytest.approx(24000 - 1920 - 2 * math.pi * 16 * 20, rel=0.002)
    if "cube_with_hole" in written:
        assert {"hole", "top", "bottom"} <= set(meshio.read(outdir / "cube_with_hole.inp").point_sets)


@pytest.mark.slow
def test_demo_prints_a_summary_and_progress_and_writes_one_report(demo):
    outdir, _, out, err = demo
    header = next(line for line in out.splitlines() if line.startswith("part"))
    assert header.split()[:4] == ["part", "h", "tets", "nodes"]
    for part in demo_parts(quick=True):
        assert f"{part.name}: surface" in err and f"{part.name}: DistMesh" in err
    # a log: each step on its own line with the time since the start, and the time left
    steps = [line for line in err.splitlines() if "demo [" in line]
    assert steps and all(line.startswith("[") and " s] demo [" in line for line in steps)
    assert any("s left for the demo)" in line for line in steps)
    html = (outdir / "report.html").read_text()
    assert html.count("data:image/png;base64") >= 4
    assert "<h2>Summary</h2>" in html
    assert sorted(p.name for p in outdir.iterdir() if p.suffix == ".html") == ["report.html"]


def test_demo_table_shows_the_worst_cells_on_every_measure():
    # The table hid the worst cells: only min dihedral and mean radius ratio.
    from fepre.demo import _summary_rows

    header = _summary_rows([], {})[0]
    assert {"min dihedral", "max dihedral", "min radius ratio", "mean radius ratio"} <= set(header)


def test_time_left_scales_the_measured_cost_per_cell_to_the_parts_ahead():
    """The estimate was the mean time per part times the parts left: cheap parts first and the
    gyroid and imported blocks last made it say "about 21 s left" 44 s before the end. It now
    prices the cells still to mesh at the seconds per cell measured so far."""
    from fepre.demo import time_left

    assert time_left([], [5000.0]) is None  # nothing measured yet: no figure
    # two small parts: 4000 cells in 8 s, 2 ms a cell; the big part ahead has 10000 cells
    assert time_left([(1000.0, 2.0), (3000.0, 6.0)], [10000.0]) == pytest.approx(20.0)
    assert time_left([(1000.0, 2.0)], []) == 0.0
    assert time_left([(0.0, 2.0)], [100.0]) is None  # no cells measured: no rate


def test_progress_line_says_what_it_knows():
    from fepre.demo import progress_note

    note = progress_note(elapsed=12.0, done=2, total=6, left=30.4, unestimated=["imported_block"])
    assert note == "12 s in, 2 of 6 parts done; not counting imported_block, about 30 s left for the demo"
    assert progress_note(elapsed=3.0, done=1, total=6, left=None, unestimated=[]) == "3 s in, 1 of 6 parts done"
    last = progress_note(elapsed=16.0, done=5, total=6, left=None, unestimated=["imported_block"])
    assert last == "16 s in, 5 of 6 parts done; no estimate for imported_block"  # not "about 0 s left"
