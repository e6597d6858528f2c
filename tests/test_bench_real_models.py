"""``fepre bench mesh-models --real FOLDER``: the bench's core on a tiny model in a tmp folder."""

from __future__ import annotations

import numpy as np
import pytest
import pyvista as pv

from fepre.bench import real_models


def _box(path, missing_face: bool = False):
    box = pv.Cube(x_length=2.0, y_length=1.0, z_length=1.0).triangulate().subdivide(1)
    if missing_face:
        box = box.extract_cells(np.flatnonzero(box.cell_normals[:, 2] < 0.9)).extract_surface(algorithm=None)
    box.save(path)
    return path


@pytest.mark.slow  # 6 s of the default run on 2 cores
def test_bench_core_on_a_tiny_box(tmp_path):
    _box(tmp_path / "box.stl")
    (tmp_path / "notes.txt").write_text("not a model")
    lines: list[str] = []
    rows = real_models.bench_folder(tmp_path, ["6"], pytetwild=True, out=lines.append, warm_up=False)
    assert len(rows) == 1
    row = rows[0]
    assert row["model"] == "box.stl" and row["closed"] and row["size"] == "D/6"
    assert row["reference_volume"] == pytest.approx(2.0, rel=1e-12)        # divergence volume, closed input
    assert row["h"] == pytest.approx(np.sqrt(6.0) / 6)
    for mesher in ("fepre", "pytetwild"):
        figures = row[mesher]
        assert "error" not in figures, figures
        assert figures["valid"], figures["problems"]
        assert abs(figures["volume"]) < 0.01                              # a box: no chords
        assert figures["boundary"] < 0.05 and figures["seconds"] > 0
        assert 0 < figures["worst"] <= 70.53 <= figures["largest"] < 180 and 0 < figures["rr"] <= 1
    assert row["fepre"]["boundary"] < 1e-3 and row["fepre"]["off"] == 0.0  # fepre's nodes on the faces
    text = "\n".join(lines)
    assert "box.stl" in text and "time fepre/pytetwild: median" in text and "1 of 1 meshes valid" in text


def test_a_pytetwild_run_over_its_time_is_stopped_and_reported(tmp_path):
    _box(tmp_path / "box.stl")
    lines: list[str] = []
    rows = real_models.bench_folder(tmp_path, ["6"], pytetwild=True, out=lines.append, warm_up=False,
                                    pytetwild_timeout=0.05)
    assert "within 0.05 s (stopped)" in rows[0]["pytetwild"]["error"]
    assert rows[0]["fepre"]["valid"]
    assert "failed: MeshingError: pytetwild did not finish" in "\n".join(lines)


def test_open_input_is_retried_with_the_winding_number_and_sizes_are_checked(tmp_path):
    _box(tmp_path / "tray.stl", missing_face=True)          # a planar hole: closed flat, not refused
    rows = real_models.bench_folder(tmp_path, ["5"], pytetwild=False, out=lambda line: None, samples=200_000,
                                    warm_up=False)
    assert rows[0]["fepre"]["inside"] == "closed" and not rows[0]["closed"]
    assert abs(rows[0]["fepre"]["volume"]) < 0.015          # against the winding-number volume (MC: 0.3%)
    with pytest.raises(ValueError, match="--sizes: '50:60' is not K"):
        real_models.Size.parse("50:60")
    assert real_models.Size.parse("50:12").h(100.0) == (2.0, 100.0 / 12)
    with pytest.raises(ValueError, match="holds no model"):
        real_models.bench_folder(tmp_path / "..", ["5"], pytetwild=False, names=["nothing-like-this"])


def test_the_reference_turns_a_closed_piece_written_inside_out(tmp_path):
    """Two boxes in a file that is not consistently oriented (one triangle of the second is
    flipped), the first written inside out, as CAD exports of several bodies can be: each closed
    piece is turned to enclose positive volume (the first counted nothing before)."""
    first = pv.Cube(x_length=2.0, y_length=1.0, z_length=1.0).triangulate()
    first_faces = first.faces.reshape(-1, 4)[:, 1:][:, ::-1]
    second = pv.Cube(center=(4.0, 0, 0)).triangulate()
    second_faces = second.faces.reshape(-1, 4)[:, 1:].copy()
    second_faces[0] = second_faces[0, ::-1]
    points = np.concatenate([first.points, second.points])
    faces = np.concatenate([first_faces, second_faces + first.n_points])
    rows = ["solid two"]
    for triangle in points[faces]:
        rows += [" facet normal 0 0 0", "  outer loop", *(f"   vertex {x} {y} {z}" for x, y, z in triangle),
                 "  endloop", " endfacet"]
    (tmp_path / "two.stl").write_text("\n".join(rows + ["endsolid two"]) + "\n")  # as written, not reoriented
    ref = real_models.reference(tmp_path / "two.stl", samples=400_000)
    assert not ref.closed
    assert ref.volume == pytest.approx(3.0, rel=0.03)


def test_the_reference_of_overlapping_shells_is_their_union(tmp_path):
    """Two closed boxes that overlap by half: the file is closed and consistently oriented, but its
    divergence volume (2) counts the overlap twice; the reference is the union's (1.5)."""
    (pv.Cube().triangulate() + pv.Cube(center=(0.5, 0, 0)).triangulate()).save(tmp_path / "two.stl")
    ref = real_models.reference(tmp_path / "two.stl", samples=400_000)
    assert ref.closed and ref.overlapping
    assert ref.volume == pytest.approx(1.5, rel=0.01)


def test_the_reference_of_a_closed_surface_written_inside_out_is_its_volume(tmp_path):
    """CGAL's beam.off, a box whose faces all point inwards: closed and consistently oriented,
    its winding number -1 inside; it was taken for overlapping shells and its volume for 0."""
    box = pv.Cube(x_length=0.4, y_length=0.4, z_length=3.6).triangulate()
    pv.PolyData(box.points, np.column_stack([np.full(box.n_cells, 3), box.faces.reshape(-1, 4)[:, 1:][:, ::-1]]).ravel()).save(
        tmp_path / "beam.stl")
    ref = real_models.reference(tmp_path / "beam.stl", samples=100_000)
    assert ref.closed and not ref.overlapping
    assert ref.volume == pytest.approx(0.576, rel=1e-6)  # the STL's float32 coordinates
