"""The loop's two-slab Delaunay (issue 15): the whole triangulation away from the hull, on both cores."""

from __future__ import annotations

import io

import numpy as np
import pytest

from fepre.distmesh import slab_delaunay
from fepre.distmesh.delaunay import gmsh_available, loop_tetrahedralize, tetrahedralize
from fepre.distmesh.delaunay_worker import serve

pytestmark = pytest.mark.skipif(not gmsh_available(), reason="the slabs are triangulated by gmsh")


@pytest.fixture
def small_threshold(monkeypatch):
    monkeypatch.setattr(slab_delaunay, "PARALLEL_MIN_POINTS", 1000)
    monkeypatch.setattr(slab_delaunay.os, "cpu_count", lambda: 2)


def test_the_slabs_give_the_whole_triangulation_inside(small_threshold):
    rng = np.random.default_rng(3)
    extent = np.array([2.0, 1.0, 1.0])
    points = rng.random((20_000, 3)) * extent
    spacing = (2.0 / len(points)) ** (1 / 3)
    whole = tetrahedralize(points, "gmsh", spacing)
    split, exact = loop_tetrahedralize(points, "gmsh", spacing, 1.2 * spacing)
    assert not exact
    again, _ = loop_tetrahedralize(points, "gmsh", spacing, 1.2 * spacing)
    assert np.array_equal(split, again)  # deterministic
    # the cut is at x = 1; cells more than one spacing inside the hull are the same on both sides
    centroid = lambda tets: points[tets].mean(axis=1)  # noqa: E731
    deep = lambda tets: tets[np.minimum(centroid(tets), extent - centroid(tets)).min(axis=1) > spacing]  # noqa: E731
    assert {tuple(t) for t in deep(whole).tolist()} == {tuple(t) for t in deep(split).tolist()}
    assert np.abs(centroid(deep(split))[:, 0] - 1.0).min() < 0.05  # cells at the cut are in it
    # the volume of the hull, up to the hull's slivers
    from fepre.quality import signed_volumes

    assert signed_volumes(points, split).sum() == pytest.approx(signed_volumes(points, whole).sum(), rel=1e-2)


def test_small_sets_one_core_wide_overlaps_and_parallel_false_use_one_triangulation(small_threshold, monkeypatch):
    points = np.random.default_rng(0).random((5000, 3))
    assert slab_delaunay.split_delaunay(points, 0.01, "scipy") is None  # gmsh only
    assert slab_delaunay.split_delaunay(points, 0.3, "gmsh") is None  # the slabs would overlap too much
    monkeypatch.setattr(slab_delaunay.os, "cpu_count", lambda: 1)
    assert slab_delaunay.split_delaunay(points, 0.01, "gmsh") is None
    tets, exact = loop_tetrahedralize(points, "gmsh", 0.05, 0.01)
    assert exact and np.array_equal(tets, tetrahedralize(points, "gmsh", 0.05))
    monkeypatch.setattr(slab_delaunay.os, "cpu_count", lambda: 2)
    tets, exact = loop_tetrahedralize(points, "gmsh", 0.05, 0.01, parallel=False)
    assert exact and np.array_equal(tets, tetrahedralize(points, "gmsh", 0.05))


def test_the_worker_protocol_answers_each_request_and_reports_errors(monkeypatch):
    from fepre.distmesh import delaunay
    from fepre.errors import MeshingError

    cube = np.array([[i, j, k] for i in (0, 1) for j in (0, 1) for k in (0, 1)], float)
    request = b"".join(np.array([len(p)], np.int64).tobytes() + p.tobytes() for p in (cube, cube[:5]))
    real = delaunay._gmsh

    def failing_on_five(points):
        if len(points) == 5:
            raise MeshingError("gmsh tetrahedralize failed on 5 points: test")
        return real(points)

    monkeypatch.setattr(delaunay, "_gmsh", failing_on_five)
    answer = io.BytesIO()
    serve(io.BytesIO(request), answer)
    data = answer.getvalue()
    count = int(np.frombuffer(data[:8], np.int64)[0])
    tets = np.frombuffer(data[8 : 8 + 16 * count], np.int32).reshape(count, 4)
    assert count >= 5 and set(np.unique(tets).tolist()) == set(range(8))
    status, length = np.frombuffer(data[8 + 16 * count : 24 + 16 * count], np.int64)
    assert status == -1 and data[24 + 16 * count :].decode() == "gmsh tetrahedralize failed on 5 points: test"
    assert length == len(data) - (24 + 16 * count)


def test_a_mesh_runs_the_same_loop_with_and_without_the_second_process(small_threshold, monkeypatch):
    import fepre
    from fepre import sdf

    splits = []
    real = slab_delaunay.split_delaunay

    def counted(*args):
        result = real(*args)
        splits.append(result is not None)
        return result

    monkeypatch.setattr(slab_delaunay, "split_delaunay", counted)
    model = sdf.box((2.0, 1.0, 1.0)) - sdf.cylinder(0.25, 2.0)
    both = fepre.distmesh(model, 0.12, parallel=True)
    assert splits and all(splits)
    one = fepre.distmesh(model, 0.12, parallel=False)
    # the same loop; the final mesh triangulates anew where one process would reuse the loop's
    # last (still nearly Delaunay) triangulation, so the quality stage may start from other cells
    for key in ("distmesh_iterations", "distmesh_triangulations"):
        assert both.field_data[key][0] == one.field_data[key][0]
    assert abs(both.n_cells / one.n_cells - 1) < 0.02
    assert both.volume == pytest.approx(one.volume, rel=2e-3)
    assert both["min_dihedral_angle"].min() >= 28.0 and both["radius_ratio"].min() >= 0.3


def test_a_busy_worker_or_a_forked_child_does_not_share_requests(small_threshold, monkeypatch):
    points = np.random.default_rng(5).random((5000, 3)) * [2.0, 1.0, 1.0]
    with slab_delaunay._Worker.busy:  # another thread's request is under way
        assert slab_delaunay.split_delaunay(points, 0.02, "gmsh") is None
    assert slab_delaunay.split_delaunay(points, 0.02, "gmsh") is not None
    first = slab_delaunay._Worker.process()
    monkeypatch.setattr(slab_delaunay._Worker, "_owner", -1)  # as seen from a forked child
    second = slab_delaunay._Worker.process()
    assert second is not first and second.poll() is None
    first.stdin.close()
    first.wait(timeout=5)


def test_a_failing_worker_leaves_the_triangulation_to_this_process(small_threshold, monkeypatch):
    points = np.random.default_rng(6).random((5000, 3)) * [2.0, 1.0, 1.0]
    slab_delaunay._Worker.process().kill()  # the worker dies between two requests
    slab_delaunay._Worker.process().wait(timeout=5)
    monkeypatch.setattr(slab_delaunay._Worker, "process", classmethod(lambda cls: cls._process))
    assert slab_delaunay.split_delaunay(points, 0.02, "gmsh") is None
    monkeypatch.undo()
    monkeypatch.setattr(slab_delaunay, "PARALLEL_MIN_POINTS", 1000)
    monkeypatch.setattr(slab_delaunay.os, "cpu_count", lambda: 2)
    assert slab_delaunay.split_delaunay(points, 0.02, "gmsh") is not None  # a new worker


def test_a_write_to_a_closed_pipe_raises_after_meshing_with_gmsh():
    # gmsh.initialize sets SIGPIPE to its default action: after any DistMesh, writing to a pipe
    # whose reader had gone (a dead worker, a socket, `| head`) killed Python with exit 141
    import subprocess
    import sys

    script = (
        "import subprocess, fepre\n"
        "from fepre import sdf\n"
        "fepre.distmesh(sdf.sphere(1.0), 0.5, delaunay='gmsh')\n"
        "p = subprocess.Popen(['true'], stdin=subprocess.PIPE); p.wait()\n"
        "try:\n    p.stdin.write(b'x' * 100000); p.stdin.flush()\n"
        "except BrokenPipeError:\n    print('raised')\n"
    )
    done = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True, timeout=120)
    assert done.returncode == 0 and done.stdout.strip() == "raised", (done.returncode, done.stderr[-500:])
