"""DistMesh options, determinism, progress/callback, internals and bad input."""

from __future__ import annotations

import dataclasses
import itertools
import warnings

import numpy as np
import pytest
from hypothesis import given, settings, strategies as st
from scipy.spatial import Delaunay

import fepre
from fepre import sdf
from fepre.distmesh import DistMeshOptions
from fepre.distmesh.delaunay import gmsh_available, tetrahedralize
from fepre.distmesh.forces import bar_forces, bars_of
from fepre.distmesh.hilbert import hilbert_keys
from fepre.distmesh.initial_points import lattice

from test_distmesh import DEFAULTS, assert_valid, mesh_of

BALL = sdf.sphere(1.0)
H = 0.3

OPTION_VALUES = [
    {"distribution": "cubic"},
    {"distribution": "fcc"},
    {"distribution": "bcc"},
    {"distribution": "cubic", "jitter": 0.0, "boundary_layer": False},
    {"nonlinear": True},
    {"distance_cache": False},
    {"sort": "hilbert", "sort_interval": 1},
    {"termination": "displacement", "maxiter": 60},
    {"termination": "quality", "quality_window": 5},
    {"retriangulation": "move_average", "move_average_window": 3},
    {"delaunay": "scipy"},
    {"deltat": 0.05, "ttol": 0.02},
    {"fscale": 1.2, "geps": 0.2, "ptol": 0.01},
    {"jitter": 0.1, "seed": 7},
]
if gmsh_available():
    OPTION_VALUES.append({"delaunay": "gmsh"})


@pytest.mark.parametrize("overrides", OPTION_VALUES, ids=lambda o: ",".join(f"{k}={v}" for k, v in o.items()))
def test_every_option_value_gives_a_valid_mesh(overrides):
    grid = mesh_of(BALL, H, **overrides)
    assert_valid(grid, BALL, H)
    assert grid.volume == pytest.approx(4 / 3 * np.pi, rel=0.08)


def test_forward_differences_with_deps_for_models_without_gradient():
    class HalfSphere(fepre.sdf.SDF):
        def __init__(self):
            super().__init__(bounds=((-1,) * 3, (1,) * 3), exact=False)

        def _values(self, x, y, z):
            return 0.5 * (np.sqrt(x * x + y * y + z * z) - 1.0)

    model = HalfSphere()
    grid = mesh_of(model, H, deps=1e-6)
    assert_valid(grid, model, H)
    assert grid.volume == pytest.approx(4 / 3 * np.pi, rel=0.08)


def test_delaunay_gmsh_without_gmsh_is_a_clear_error(monkeypatch):
    import builtins

    real_import = builtins.__import__

    def no_gmsh(name, *args, **kwargs):
        if name == "gmsh":
            raise ImportError("No module named 'gmsh'")
        return real_import(name, *args, **kwargs)

    monkeypatch.setattr(builtins, "__import__", no_gmsh)
    with pytest.raises(ImportError, match="delaunay='gmsh'.*gmsh"):
        tetrahedralize(np.random.default_rng(0).random((10, 3)), "gmsh")


def test_same_seed_same_mesh_other_seed_other_mesh():
    first = mesh_of(BALL, H, seed=3)
    second = mesh_of(BALL, H, seed=3)
    np.testing.assert_array_equal(first.points, second.points)
    np.testing.assert_array_equal(first.cells, second.cells)
    np.testing.assert_array_equal(first["min_dihedral_angle"], second["min_dihedral_angle"])
    other = mesh_of(BALL, H, seed=4)
    assert other.n_points != first.n_points or not np.array_equal(other.points, first.points)


def test_distance_cache_changes_nothing_but_the_evaluations(monkeypatch):
    """The cache only skips points whose sdf bound is below -geps: same mesh, fewer evaluations."""
    from fepre.distmesh import validate

    # the final volume check's own samples (32^3 at least) are the same with and without the
    # cache; fewer of them keep the loop's evaluations, which the cache saves, the bulk
    monkeypatch.setattr(validate, "_VOLUME_SAMPLES", (2_048, 64_000))

    class Counting(fepre.sdf.SDF):
        analytic_gradient = True

        def __init__(self):
            super().__init__(bounds=((-1,) * 3, (1,) * 3), exact=True)
            self.evaluated = 0

        def _values(self, x, y, z):
            self.evaluated += np.broadcast(x, y, z).size
            return np.sqrt(x * x + y * y + z * z) - 1.0

        def _values_and_gradient(self, x, y, z):
            return BALL._values_and_gradient(x, y, z)

    counts = {}
    grids = {}
    for cache in (True, False):
        model = Counting()
        grids[cache] = mesh_of(model, 0.15, distance_cache=cache, slivers=False, check_resolution=False)
        counts[cache] = model.evaluated
    np.testing.assert_array_equal(grids[True].points, grids[False].points)
    np.testing.assert_array_equal(grids[True].cells, grids[False].cells)
    assert counts[True] < 0.6 * counts[False]


def test_options_object_and_overrides():
    options = DistMeshOptions(deltat=0.05, nonlinear=True)
    grid = mesh_of(BALL, H, options=options, maxiter=7, termination="displacement")
    assert grid.field_data["distmesh_iterations"][0] == 7
    assert dataclasses.replace(options, deltat=0.2).deltat == 0.2
    doc = DistMeshOptions.__doc__
    for field in dataclasses.fields(DistMeshOptions):
        assert f"{field.name} :" in doc, field.name


def test_maxiter_warns_and_returns_mesh():
    with pytest.warns(fepre.ConvergenceWarning, match="maxiter=3"):
        grid = fepre.distmesh(BALL, H, maxiter=3, termination="displacement", **DEFAULTS)
    assert_valid(grid, BALL, H)


def test_progress_line_and_callback(capsys):
    states = []
    mesh_of(BALL, H, progress=True, callback=lambda s: states.append((s.iteration, len(s.points), s.tets.shape, s.max_move)))
    err = capsys.readouterr().err
    assert "distmesh: iteration" in err and "points" in err and "worst dihedral" in err
    assert [s[0] for s in states] == list(range(1, len(states) + 1))
    assert all(shape[1] == 4 for _, _, shape, _ in states)


def test_history_retriangulation_and_termination_records():
    grid = mesh_of(BALL, 0.25, slivers=False)
    f = grid.field_data
    n = int(f["distmesh_iterations"][0])
    assert f["distmesh_retriangulated"][0] == 1
    assert f["distmesh_retriangulated"].sum() == f["distmesh_triangulations"][0]
    assert np.all(f["distmesh_min_quality"] <= f["distmesh_mean_quality"])
    assert f["distmesh_mean_quality"][-1] > 0.8
    assert n >= 1 and f["distmesh_converged"][0] == 1


# ---------------------------------------------------------------- internals against naive versions


def test_bars_match_a_set_of_edges():
    points = np.random.default_rng(0).random((50, 3))
    tets = Delaunay(points).simplices
    expected = {tuple(sorted(pair)) for tet in tets for pair in itertools.combinations(tet, 2)}
    bars = bars_of(tets, len(points))
    assert {tuple(b) for b in bars.tolist()} == expected and len(bars) == len(expected)
    assert bars.tolist() == sorted([int(a), int(b)] for a, b in expected)  # by first, then second end
    assert bars_of(np.zeros((0, 4), int), 3).shape == (0, 2)
    # unused points and repeated cells
    assert bars_of(np.array([[5, 1, 3, 7], [7, 3, 1, 5]]), 9).tolist() == [[1, 3], [1, 5], [1, 7], [3, 5], [3, 7], [5, 7]]


def test_bar_forces_match_a_loop():
    rng = np.random.default_rng(1)
    points = rng.random((30, 3))
    bars = bars_of(Delaunay(points).simplices, 30)
    hbars = 1.0 + rng.random(len(bars))
    for nonlinear in (False, True):
        total, lengths = bar_forces(points, bars, 1.2, nonlinear, hbars)
        scale = (np.sum(lengths**3) / np.sum(hbars**3)) ** (1 / 3)
        expected = np.zeros_like(points)
        for (i, j), h in zip(bars, hbars):
            v = points[j] - points[i]
            length = np.linalg.norm(v)
            l0 = 1.2 * h * scale
            f = max(l0 - length, 0.0) * ((length + l0) / (2 * l0) if nonlinear else 1.0)
            expected[j] += f * v / length
            expected[i] -= f * v / length
        np.testing.assert_allclose(total, expected, atol=1e-12)


@settings(max_examples=20, deadline=None)
@given(bits=st.integers(1, 4))
def test_hilbert_order_visits_grid_neighbours(bits):
    n = 1 << bits
    grid = np.array(list(itertools.product(range(n), repeat=3)), float)
    keys = hilbert_keys(grid, bits)
    assert sorted(keys.tolist()) == list(range(n**3))
    ordered = grid[np.argsort(keys)]
    steps = np.abs(np.diff(ordered, axis=0)).sum(axis=1)
    assert np.all(steps == 1)


def test_cospherical_cubic_lattice_is_handled():
    cube = lattice(np.zeros(3), np.ones(3), 0.25, "cubic")  # 125 co-spherical points
    tets = tetrahedralize(cube, "scipy", 0.25)
    from fepre.quality import signed_volumes

    volumes = signed_volumes(cube, tets)
    assert volumes.min() > 0 and volumes.sum() == pytest.approx(1.0)
    # raw algorithm (slivers=False): the co-spherical start is what is under test
    grid = mesh_of(sdf.box((1.0, 1.0, 1.0)), 0.25, distribution="cubic", jitter=0.0, boundary_layer=False, slivers=False)
    assert_valid(grid, sdf.box((1.0, 1.0, 1.0)), 0.25)


# ---------------------------------------------------------------- bad input


@pytest.mark.parametrize(
    "kwargs, error, match",
    [
        ({"h": 0.0}, ValueError, "h must be > 0"),
        ({"h": -1.0}, ValueError, "h must be > 0"),
        ({"h": 5.0}, ValueError, "h=5.0"),
        ({"h": 0.3, "bounds": ((1, -1, -1), (-1, 1, 1))}, ValueError, "bounds must have min < max"),
        ({"h": 0.3, "size": lambda p: -np.ones(len(p))}, ValueError, "size must return finite values > 0"),
        ({"h": 0.3, "size": lambda p: np.ones((len(p), 2))}, ValueError, "size must return shape"),
        ({"h": 0.3, "size": 3.0}, TypeError, "size must be a callable"),
        ({"h": 0.3, "fixed": [[0.0, 0.0, 2.0]]}, ValueError, "fixed points must lie in the domain"),
        ({"h": 0.3, "fixed": [[0.0, 0.0]]}, ValueError, "fixed must have shape"),
        ({"h": 0.3, "deltaT": 0.1}, TypeError, "unknown DistMesh option.*'deltaT'.*valid options: deltat"),
        ({"h": 0.3, "distribution": "hex"}, ValueError, "distribution must be one of"),
        ({"h": 0.3, "termination": "never"}, ValueError, "termination must be one of"),
        ({"h": 0.3, "retriangulation": "always"}, ValueError, "retriangulation must be one of"),
        ({"h": 0.3, "delaunay": "tetgen"}, ValueError, "delaunay must be one of"),
        ({"h": 0.3, "sort": "morton"}, ValueError, "sort must be one of"),
        ({"h": 0.3, "deltat": 0.0}, ValueError, "deltat must be > 0"),
        ({"h": 0.3, "maxiter": 0}, ValueError, "maxiter must be a positive integer"),
        ({"h": 0.3, "nonlinear": "yes"}, TypeError, "nonlinear must be True or False"),
        ({"h": 0.3, "options": {"deltat": 0.1}}, TypeError, "options must be a fepre.DistMeshOptions"),
        ({"h": "D/0"}, ValueError, "h must be a length, or 'D/N' .* got 'D/0'"),
        ({"h": "0.3"}, ValueError, "h must be a length, or 'D/N' .* got '0.3'"),
        ({"h": ("D/40", "D/x")}, ValueError, "got 'D/x'"),
    ],
)
def test_bad_input_names_the_parameter(kwargs, error, match):
    with pytest.raises(error, match=match):
        fepre.distmesh(BALL, **kwargs)


def test_h_as_a_share_of_the_diagonal_as_on_the_command_line():
    # "D/N" is the diagonal of the domain's box over N, as --h D/50 is; the mesh is the one of
    # the length it stands for, alone or in a pair, and wherever the part is placed
    box = sdf.box((2.0, 1.0, 1.0))
    diagonal = float(np.sqrt(6.0))
    named, given = fepre.distmesh(box, h="D/10"), fepre.distmesh(box, h=diagonal / 10)
    assert named.n_cells == given.n_cells > 0
    np.testing.assert_array_equal(named.points, given.points)
    far = box.translate((1e4, 0.0, 0.0))
    graded = fepre.distmesh(far, h=("D/30", "D/8"))
    assert graded.n_cells == fepre.distmesh(far, h=(diagonal / 30, diagonal / 8)).n_cells
    roomy = ((-2.0, -1.0, -1.0), (2.0, 1.0, 1.0))  # the box given, not the model's
    assert fepre.distmesh(box, h="d/20", bounds=roomy).n_cells == fepre.distmesh(box, h=np.sqrt(24.0) / 20, bounds=roomy).n_cells


@pytest.mark.slow  # 4 s of the default run on 2 cores
def test_bounds_that_cut_the_solid_mesh_the_part_inside_them():
    # an unbounded gyroid given bounds (as the "bounds is required" message asks) was refused
    # after the loop as "cells outside the part; try a smaller h"; now the bounds cut it, as
    # the model & box the user would otherwise write
    lattice = sdf.gyroid(1.0, 0.3)
    cell = ((0.0, 0.0, 0.0), (1.0, 1.0, 1.0))
    given = fepre.distmesh(lattice, 0.1, bounds=cell)
    written = fepre.distmesh(lattice & sdf.box((1.0, 1.0, 1.0), center=(0.5, 0.5, 0.5)), 0.1, bounds=cell)
    assert given.n_cells == written.n_cells > 1000
    np.testing.assert_array_equal(given.points, written.points)
    assert given["min_dihedral_angle"].min() >= 25.0
    # half a ball: its volume, every node in the box
    half = fepre.distmesh(BALL, 0.15, bounds=((-1.2, -1.2, -1.2), (0.0, 1.2, 1.2)))
    assert abs(half.volume / (2.0 * np.pi / 3.0) - 1.0) < 0.02
    assert np.asarray(half.points)[:, 0].max() <= 1e-9
    # a box that holds the solid leaves the model as it is
    from fepre.distmesh.mesher import _cut_by_bounds

    assert _cut_by_bounds(BALL, np.full(3, -1.5), np.full(3, 1.5), 0.1) is BALL


def test_empty_domain_and_unbounded_model():
    with pytest.raises(fepre.MeshingError, match="misses the bounds"):
        fepre.distmesh(BALL, 0.3, bounds=((2, 2, 2), (3, 3, 3)))
    with pytest.raises(ValueError, match="too large for the domain"):
        fepre.distmesh(sdf.sphere(0.05), 0.3, bounds=((-1, -1, -1), (1, 1, 1)))
    with pytest.raises(ValueError, match="bounds is required"):
        fepre.distmesh(sdf.plane((0, 0, 1)), 0.3)
    with pytest.raises(TypeError, match="model must be a 3D"):
        fepre.distmesh(lambda p: p[:, 0], 0.3)
    # a file's name (a new user's first try): told to read it
    for call in (lambda: fepre.distmesh("cube.off", h=0.3), lambda: fepre.size_field("cube.off", 0.1, 1.0),
                 lambda: fepre.features("cube.off", h=0.3)):
        with pytest.raises(TypeError, match=r"got the str 'cube.off': read a file first with fepre.sdf.mesh\('cube.off'\)"):
            call()


def test_no_bars_push_nothing_and_warn_nothing():
    """A triangulation with no cell inside the part (a new user's thin tray at D/25 met one in
    the loop) gave numpy's 'Mean of empty slice' warnings to the user."""
    import warnings

    from fepre.distmesh.forces import bar_forces

    points = np.random.default_rng(0).random((5, 3))
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        forces, lengths = bar_forces(points, np.zeros((0, 2), dtype=np.int64), 1.2, False)
    assert forces.shape == (5, 3) and not forces.any() and lengths.size == 0
