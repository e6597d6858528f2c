"""The thread choice of the compiled kernels: serial below the work a launch pays for, the same
results on one thread and on several, numba's and OpenMP's thread counts put back."""

import numba
import numpy as np
import pytest

import fepre.kernel_threads as kt
from fepre import _cell_kernels as ck
from fepre.distmesh import _bar_kernels as bk
from fepre.distmesh.coverage import covered_nodes
from fepre.distmesh.validate import crossing_faces

MOST = numba.config.NUMBA_NUM_THREADS


def _mesh_cells(seed: int = 0, count: int = 3000):
    """A Delaunay mesh of random points: cells that share faces and edges (scipy, independent)."""
    from scipy.spatial import Delaunay

    points = np.random.default_rng(seed).random((count, 3))
    return points, Delaunay(points).simplices.astype(np.int64)


def _all_kernels(points, tets):
    mate, uses = ck.face_uses(tets, len(points))
    canonical = tets.copy()
    volumes = ck.canonical_cells(points, canonical)
    centroids, reach = ck.centroid_bounds(points, tets, np.linspace(-1, 0, len(points)))
    bars = bk.unique_bars(tets, len(points), ck._EDGES)
    vectors, lengths = bk.bar_vectors(points, bars)
    covered = covered_nodes(points, tets, (0, 0, 0), (0.05, 0.05, 0.05), (21, 21, 21), 1e-12)
    faces = tets[:300, :3]
    return dict(quality=ck.quality_arrays(points, tets), ratio=ck.volume_edge_ratios(points, tets),
                face_keys=ck.packed_face_keys(tets, len(points)), edge_keys=ck.packed_edge_keys(tets, len(points)),
                mate=mate, uses=uses, canonical=canonical, volumes=volumes, centroids=centroids, reach=reach,
                bars=bars, vectors=vectors, lengths=lengths, covered=covered,
                ideal=ck.ideal_positions(points, tets, 0.8), corner=ck.corner_volumes(points, tets),
                extremes=np.stack(ck.shape_extremes(points[tets], 1e-12)), crossing=crossing_faces(points, faces))


@pytest.mark.skipif(MOST < 2, reason="numba allows one thread here")
def test_serial_and_parallel_kernels_give_identical_results(monkeypatch):
    points, tets = _mesh_cells()
    monkeypatch.setattr(kt, "choose_threads", lambda items, seconds=kt.SECONDS_PER_ITEM, most=None: 1)
    serial = _all_kernels(points, tets)
    monkeypatch.setattr(kt, "choose_threads", lambda items, seconds=kt.SECONDS_PER_ITEM, most=None: MOST)
    parallel = _all_kernels(points, tets)
    for name, values in serial.items():
        assert values.shape == parallel[name].shape, name
        assert np.array_equal(values, parallel[name], equal_nan=True), name
    # the kernels did their work: every face of the Delaunay mesh is used once or twice
    assert set(np.unique(serial["uses"])) == {1, 2}
    assert len(serial["bars"]) == len(np.unique(np.sort(tets[:, [[0, 1], [0, 2], [0, 3], [1, 2], [1, 3], [2, 3]]], axis=2)
                                                .reshape(-1, 2), axis=0))


def test_small_work_runs_serially_without_a_probe(monkeypatch):
    def no_probe(threads):
        raise AssertionError("probed for work under SERIAL_SECONDS")

    monkeypatch.setattr(kt, "launch_seconds", no_probe)
    items = int(kt.SERIAL_SECONDS / 1e-8) - 1
    assert kt.choose_threads(items, 1e-8, most=4) == 1
    assert kt.choose_threads(10**9, 1e-8, most=1) == 1


@pytest.mark.parametrize("launch, expected", [(5e-6, 4), (1e-2, 1)])
def test_the_measured_launch_cost_decides(monkeypatch, launch, expected):
    """1e6 items of 10 ns: 10 ms of serial work, 7.5 ms saved on 4 threads. A free machine's
    launch (5 us) pays; a busy machine's (10 ms of libgomp spinning) does not."""
    monkeypatch.setattr(kt, "launch_seconds", lambda threads: launch)
    assert kt.choose_threads(10**6, 1e-8, most=4) == expected
    # the break-even: the threads' share of the work (3/4 on 4 threads) against twice the launch,
    # and never under SERIAL_SECONDS of work
    even = max(2 * launch / (0.75 * 1e-8), kt.SERIAL_SECONDS / 1e-8)
    assert kt.choose_threads(int(1.01 * even), 1e-8, most=4) == 4
    assert kt.choose_threads(int(0.99 * even), 1e-8, most=4) == 1


def test_the_probe_is_measured_once_per_interval(monkeypatch):
    kt._probe_state.update(threads=0, seconds=np.inf, at=-np.inf)
    first = kt.launch_seconds(1)
    assert 0 < first < 1.0
    calls = []
    original = kt._probe
    monkeypatch.setattr(kt, "_probe", lambda out: calls.append(len(out)) or original(out))
    assert kt.launch_seconds(1) == first  # within the interval: the figure kept
    assert calls == []
    kt._probe_state["at"] -= 2 * kt.PROBE_INTERVAL
    kt.launch_seconds(1)
    assert calls == [1]


def test_numba_thread_count_is_put_back_even_on_error(monkeypatch):
    before = numba.get_num_threads()
    monkeypatch.setattr(kt, "choose_threads", lambda items, seconds=kt.SECONDS_PER_ITEM, most=None: 1)
    with pytest.raises(RuntimeError):
        with kt.kernel_threads(10**9):
            assert numba.get_num_threads() == 1
            raise RuntimeError("inside")
    assert numba.get_num_threads() == before


def test_gmsh_triangulation_threads_and_openmp_count():
    gmsh = pytest.importorskip("gmsh")
    from fepre.distmesh.delaunay import _OpenMPThreads, _gmsh

    if not hasattr(gmsh.lib, "omp_get_max_threads"):
        pytest.skip("this gmsh build does not export OpenMP's calls")
    before = int(gmsh.lib.omp_get_max_threads())
    with _OpenMPThreads(gmsh, 1):
        assert int(gmsh.lib.omp_get_max_threads()) == 1
    assert int(gmsh.lib.omp_get_max_threads()) == before
    points = np.random.default_rng(3).random((2000, 3))
    one = _gmsh(points, 1)
    assert int(gmsh.lib.omp_get_max_threads()) == before
    two = _gmsh(points, 2)
    canon = [np.unique(np.sort(t, axis=1), axis=0) for t in (one, two)]
    assert np.array_equal(canon[0], canon[1])
    # a triangulation of the hull less the cells at its rim (the box corners' cells, dropped)
    from scipy.spatial import ConvexHull

    corners = points[one]
    volume = np.abs(np.einsum("ij,ij->i", corners[:, 1] - corners[:, 0],
                              np.cross(corners[:, 2] - corners[:, 0], corners[:, 3] - corners[:, 0]))).sum() / 6
    assert 0.9 * ConvexHull(points).volume < volume <= ConvexHull(points).volume * (1 + 1e-9)


def _parallel_kernels(tree):
    import ast

    names = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.FunctionDef):
            for decorator in node.decorator_list:
                if isinstance(decorator, ast.Call) and any(k.arg == "parallel" and getattr(k.value, "value", False)
                                                           for k in decorator.keywords):
                    names.add(node.name)
    return names


def _ungated_calls(tree, kernels):
    """Calls of ``kernels`` outside a ``with kernel_threads(...)`` block, as line numbers."""
    import ast

    found = []

    def visit(node, gated):
        if isinstance(node, ast.With):
            gated = gated or any(isinstance(item.context_expr, ast.Call)
                                 and getattr(item.context_expr.func, "id", "") == "kernel_threads" for item in node.items)
        if isinstance(node, ast.FunctionDef) and node.name in kernels:
            return  # a kernel's own body
        if isinstance(node, ast.Call) and getattr(node.func, "id", "") in kernels and not gated:
            found.append(node.lineno)
        for child in ast.iter_child_nodes(node):
            visit(child, gated)

    visit(tree, False)
    return found


@pytest.mark.slow  # 3 s of the default run on 2 cores
def test_every_parallel_kernel_is_launched_through_the_thread_choice():
    """A new ``parallel=True`` kernel called without ``kernel_threads`` would pay the busy-wait
    of every launch again: each call site in fepre is inside the ``with`` block."""
    import ast
    from pathlib import Path

    root = Path(kt.__file__).parent
    checked, ungated = 0, []
    for path in sorted(root.rglob("*.py")):
        if path.name == "kernel_threads.py":
            continue  # its probe is the launch it times
        tree = ast.parse(path.read_text())
        kernels = _parallel_kernels(tree)
        if kernels:
            checked += len(kernels)
            ungated += [f"{path.relative_to(root)}:{line}" for line in _ungated_calls(tree, kernels)]
    assert checked >= 20  # the per-cell, per-bar, coverage, validation and feature kernels
    assert ungated == []
    # and the check finds an ungated call
    sample = ast.parse("from numba import njit\n@njit(parallel=True)\ndef k(x):\n    pass\ndef f(x):\n    k(x)\n"
                       "def g(x):\n    with kernel_threads(len(x)):\n        k(x)\n")
    assert _ungated_calls(sample, _parallel_kernels(sample)) == [6]


def test_docstring_examples_run():
    import doctest

    assert doctest.testmod(kt).failed == 0


def test_one_blas_thread_limits_blas_inside_the_block_only():
    from threadpoolctl import threadpool_info

    from fepre.kernel_threads import one_blas_thread

    def blas_threads():
        return [lib["num_threads"] for lib in threadpool_info() if lib["user_api"] == "blas"]

    before = blas_threads()
    points = np.random.default_rng(0).normal(size=(200_000, 3))
    matrix = np.random.default_rng(1).normal(size=(3, 3))
    free = points @ matrix.T
    with one_blas_thread():
        assert blas_threads() and set(blas_threads()) == {1}
        single = points @ matrix.T
    assert blas_threads() == before
    assert np.array_equal(single, free)  # each row's product is the same on any thread
