"""Chunked grids on dask: sampling equals the whole grid, chunked surfaces equal single-grid
surfaces for every method (threads and a LocalCluster), zarr stores, streaming STL, bad input."""

from __future__ import annotations

import pickle

import numpy as np
import pytest

import fepre
from fepre import parts, sdf
from fepre.surface import METHODS

pytest.importorskip("dask.array")
pytest.importorskip("zarr")

from fepre.chunked import ChunkedGrid, open_grid, write_isosurface  # noqa: E402
from fepre.chunked.layout import ChunkLayout  # noqa: E402

PARTS = {
    "torus": (sdf.torus(1.0, 0.3), 0.05),
    "cube_with_hole": (parts.cube_with_hole()[0], 0.125),  # faces on grid planes: nodes on the level
    "gyroid_block": (parts.gyroid_block(), 0.04),
}


def _triangle_set(surface) -> np.ndarray:
    """Triangles as sorted rows of corner coordinates, each rotated to start at its least corner."""
    corners = np.asarray(surface.points)[surface.regular_faces]
    rotations = np.stack([np.roll(corners, -k, axis=1).reshape(len(corners), 9) for k in range(3)], axis=1)
    least = np.array([min(range(3), key=lambda k: tuple(row[k, :3])) for row in rotations])
    rows = rotations[np.arange(len(corners)), least]
    return rows[np.lexsort(rows.T[::-1])]


def _same_surface(chunked, whole, method: str) -> None:
    if method == "flying_edges":  # VTK numbers its output itself: equal up to order
        assert chunked.n_points == whole.n_points and chunked.n_cells == whole.n_cells
        np.testing.assert_array_equal(_triangle_set(chunked), _triangle_set(whole))
    else:  # fepre's methods: the very same arrays
        np.testing.assert_array_equal(np.asarray(chunked.points), np.asarray(whole.points))
        np.testing.assert_array_equal(chunked.regular_faces, whole.regular_faces)


@pytest.mark.parametrize("name", sorted(PARTS))
@pytest.mark.parametrize("method", METHODS)
def test_chunked_surface_is_the_single_grid_surface(name, method):
    model, spacing = PARTS[name]
    whole = fepre.isosurface(model, spacing=spacing, method=method)
    chunked = fepre.isosurface(model, spacing=spacing, method=method, chunks=(8, 12, 16))
    assert chunked.n_cells > 1000
    _same_surface(chunked, whole, method)
    assert chunked.field_data["surface_method"][0] == method


def test_chunked_grid_values_are_the_whole_grid_values():
    model, spacing = PARTS["torus"]
    whole = fepre.sample(model, spacing=spacing)
    lazy = fepre.sample(model, spacing=spacing, chunks=16)
    assert isinstance(lazy, ChunkedGrid)
    assert lazy.dimensions == whole.dimensions
    np.testing.assert_allclose(lazy.origin, whole.origin, rtol=0, atol=0)
    np.testing.assert_array_equal(np.asarray(lazy.values.compute()).reshape(-1), whole["sdf"])
    assert lazy.to_image()["sdf"].tobytes() == whole["sdf"].tobytes()


def test_banded_chunks_far_from_the_surface_are_filled_without_evaluation():
    calls = []

    class Counting(sdf.SDF):
        def __init__(self, inner):
            super().__init__(bounds=inner.bounds, exact=inner.exact, children=(inner,))
            self.inner = inner

        def _values(self, x, y, z):
            calls.append(np.broadcast(x, y, z).size)
            return self.inner._values(x, y, z)

    ball = Counting(sdf.sphere(0.5))
    grid = fepre.sample(ball, spacing=0.05, bounds=((-2, -2, -2), (2, 2, 2)), band=0.1, chunks=16)
    values = np.asarray(grid.values.compute())
    far = np.isclose(np.abs(values), grid.band)
    assert far.mean() > 0.9  # the ball fills a small part of the box
    dense = fepre.sample(sdf.sphere(0.5), spacing=0.05, bounds=((-2, -2, -2), (2, 2, 2)))
    near = ~far
    np.testing.assert_array_equal(values.reshape(-1)[near.reshape(-1)], dense["sdf"][near.reshape(-1)])
    assert sum(calls) < 0.2 * values.size  # most chunks cost one evaluation


def test_zarr_store_round_trip_and_surface(tmp_path):
    model, spacing = PARTS["gyroid_block"]
    path = tmp_path / "gyroid.zarr"
    grid = fepre.sample(model, spacing=spacing, chunks=20, band=0.1, store=path)
    assert path.is_dir() and grid.store == str(path)
    reopened = open_grid(path)
    assert reopened.dimensions == grid.dimensions and reopened.band == pytest.approx(grid.band)
    np.testing.assert_array_equal(reopened.origin, grid.origin)
    surface = fepre.isosurface(reopened, method="marching_cubes")
    whole = fepre.isosurface(model, spacing=spacing, method="marching_cubes")
    _same_surface(surface, whole, "marching_cubes")
    with pytest.raises(FileExistsError, match="store: .*already exists.*overwrite=True"):
        fepre.sample(model, spacing=spacing, chunks=20, store=path)
    fepre.sample(sdf.sphere(0.5), spacing=0.1, chunks=8, store=path, overwrite=True)
    assert open_grid(path).dimensions == (15, 15, 15)
    assert [p.name for p in tmp_path.iterdir()] == ["gyroid.zarr"]  # no staging left behind


@pytest.mark.parametrize("method", METHODS)
def test_streamed_stl_is_closed_and_holds_the_surface(tmp_path, method):
    import pyvista as pv

    model, spacing = PARTS["gyroid_block"]
    path = tmp_path / "part.stl"
    written = write_isosurface(model, path, method=method, spacing=spacing, chunks=16)
    whole = fepre.isosurface(model, spacing=spacing, method=method)
    assert written.closed and written.seam_edges > 1000 and written.n_vertices is None
    read = pv.read(path)
    assert read.n_cells == written.n_triangles
    if method == "marching_tetrahedra":  # zero-area triangles on seams are kept (0.2 % more)
        assert whole.n_cells <= written.n_triangles <= 1.005 * whole.n_cells
    else:
        assert written.n_triangles == whole.n_cells
    assert abs(read.volume - whole.volume) < 1e-6 * whole.volume
    assert [p.name for p in tmp_path.iterdir()] == ["part.stl"]


@pytest.mark.parametrize("method", ["flying_edges", "dual_contouring"])
def test_streamed_ply_shares_vertices_across_seams(tmp_path, method):
    import pyvista as pv

    model, spacing = PARTS["cube_with_hole"]
    written = write_isosurface(model, tmp_path / "part.ply", method=method, spacing=spacing, chunks=12)
    stl = write_isosurface(model, tmp_path / "part.stl", method=method, spacing=spacing, chunks=12)
    read = pv.read(tmp_path / "part.ply")
    assert written.closed and written.seam_edges > 100
    assert read.n_cells == written.n_triangles == stl.n_triangles
    assert read.n_points == written.n_vertices
    check = fepre.check_surface(read, merge_coincident=False)  # the file's own vertex ids
    assert check.watertight and check.manifold
    whole = fepre.isosurface(model, spacing=spacing, method=method)
    assert check.volume == pytest.approx(whole.volume, rel=1e-6)
    assert read.n_points == whole.n_points
    np.testing.assert_array_equal(_triangle_set(read), _triangle_set(pv.read(tmp_path / "part.stl")))
    assert sorted(p.name for p in tmp_path.iterdir()) == ["part.ply", "part.stl"]


@pytest.mark.slow  # 7 s of the default run on 2 cores
def test_local_cluster_gives_the_same_surface(tmp_path):
    distributed = pytest.importorskip("distributed")
    model, spacing = PARTS["cube_with_hole"]
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True, dashboard_address=None) as cluster:
        with distributed.Client(cluster):
            for method in ("dual_contouring", "flying_edges"):
                chunked = fepre.isosurface(model, spacing=spacing, method=method, chunks=16)
                _same_surface(chunked, fepre.isosurface(model, spacing=spacing, method=method), method)
            written = write_isosurface(model, tmp_path / "part.stl", spacing=spacing, chunks=16, window=3)
            assert written.closed and written.chunks == 27
            assert written.n_triangles == fepre.isosurface(model, spacing=spacing).n_cells


class _Unpicklable(sdf.SDF):
    def __init__(self):
        super().__init__(bounds=((-1, -1, -1), (1, 1, 1)), exact=True)
        self.lock = __import__("threading").Lock()

    def _values(self, x, y, z):
        return np.sqrt(x * x + y * y + z * z) - 1.0


def test_unpicklable_model_is_named_before_work(monkeypatch):
    from fepre.chunked import cluster

    model = sdf.sphere(0.3) | _Unpicklable().translate((2, 0, 0))
    with pytest.raises(TypeError, match=r"model\.children\[1\]\.children\[0\] \(_Unpicklable\) does not pickle.*lock"):
        cluster.check_picklable(model)
    monkeypatch.setattr(cluster, "needs_pickling", lambda: True)
    monkeypatch.setattr("fepre.chunked.api.needs_pickling", lambda: True)
    with pytest.raises(TypeError, match="cannot be sent to the dask workers"):
        fepre.isosurface(model, spacing=0.1, chunks=8)
    pickle.dumps(sdf.sphere(1.0) - sdf.box((1, 1, 1)))  # fepre's own models pickle


@pytest.mark.parametrize(
    "kwargs, error, match",
    [
        ({"chunks": 4}, ValueError, "chunks must be at least 8 nodes"),
        ({"chunks": (8, 8)}, TypeError, "chunks must be an int or 3 ints"),
        ({"chunks": 8.5}, TypeError, "chunks must be an int or 3 ints"),
        ({"chunks": True}, TypeError, "chunks must be an int or 3 ints"),
        ({"store": "x.zarr"}, ValueError, "store needs chunks"),
    ],
)
def test_bad_sampling_arguments(kwargs, error, match):
    with pytest.raises(error, match=match):
        fepre.sample(sdf.sphere(1.0), spacing=0.1, **kwargs)


def test_bad_surface_arguments(tmp_path):
    ball = sdf.sphere(1.0)
    with pytest.raises(ValueError, match="chunks must be at least 8"):
        fepre.isosurface(ball, spacing=0.1, chunks=2)
    with pytest.raises(ValueError, match="band .* does not contain level"):
        fepre.isosurface(ball, spacing=0.1, chunks=8, band=0.2, level=0.5)
    grid = fepre.sample(ball, spacing=0.1, chunks=8)
    with pytest.raises(ValueError, match="differs from the ChunkedGrid's chunks"):
        fepre.isosurface(grid, chunks=16)
    with pytest.raises(ValueError, match="spacing applies only when source is a model"):
        fepre.isosurface(grid, spacing=0.1)
    with pytest.raises(ValueError, match="a streamed surface is written as binary STL or PLY"):
        write_isosurface(ball, tmp_path / "ball.obj", spacing=0.1, chunks=8)
    with pytest.raises(FileNotFoundError, match="path: folder .* does not exist"):
        write_isosurface(ball, tmp_path / "no" / "ball.stl", spacing=0.1, chunks=8)
    with pytest.raises(FileNotFoundError, match="store: folder"):
        fepre.sample(ball, spacing=0.1, chunks=8, store=tmp_path / "no" / "g.zarr")
    with pytest.raises(ValueError, match="not a zarr array written by fepre.sample"):
        open_grid(tmp_path / "missing.zarr")


def test_layout_merges_a_short_last_chunk():
    layout = ChunkLayout.of((35, 16, 8), (16, 16, 16))
    assert layout.sizes == ((16, 19), (16,), (8,))
    assert sum(1 for _ in layout) == layout.n_chunks == 2


def test_docstring_examples_run():
    import doctest
    import importlib

    names = ["fepre.chunked", "fepre.chunked.layout", "fepre.chunked.grid", "fepre.chunked.api", "fepre.chunked.cluster",
             "fepre.surface.dual_cells", "fepre.surface.qef", "fepre.surface.dual_contouring", "fepre.sampling"]
    for name in names:
        result = doctest.testmod(importlib.import_module(name))
        assert result.failed == 0, name


def _model_file(tmp_path):
    path = tmp_path / "part.py"
    path.write_text(
        "from fepre import sdf\n"
        "model = sdf.infill(sdf.box((4, 4, 2)) - sdf.cylinder(0.8, 3), sdf.gyroid(2.0, 0.3), wall=0.4)\n"
    )
    return path


def test_cli_samples_to_zarr_and_streams_the_surface(tmp_path, capsys):
    import pyvista as pv

    from fepre.cli import main

    part = _model_file(tmp_path)
    store = tmp_path / "grid.zarr"
    assert main(["sample", str(part), "-o", str(store), "--spacing", "0.1", "--chunks", "24", "--band", "0.3", "--quiet"]) == 0
    assert open_grid(store).band == pytest.approx(0.3)
    assert main(["sample", str(part), "-o", str(store), "--spacing", "0.1", "--chunks", "24"]) == 1
    assert "already exists; pass --overwrite" in capsys.readouterr().err
    stl = tmp_path / "part.stl"
    assert main(["surface", str(store), "-o", str(stl), "--method", "surface_nets"]) == 0
    out = capsys.readouterr().out
    assert "closed and manifold" in out
    count = int(out.split("streamed surface: ")[1].split()[0])
    whole = fepre.isosurface(fepre.modelfile.load_model(part).model, spacing=0.1, method="surface_nets")
    assert pv.read(stl).n_cells == count == whole.n_cells
    vtp = tmp_path / "part.vtp"
    assert main(["surface", str(part), "-o", str(vtp), "--spacing", "0.1", "--chunks", "16", "24", "32", "--quiet"]) == 0
    assert pv.read(vtp).n_cells == fepre.isosurface(fepre.modelfile.load_model(part).model, spacing=0.1).n_cells


@pytest.mark.parametrize(
    "args, message",
    [
        (["--chunks", "4"], "--chunks must be at least 8"),
        (["--chunks", "16", "16"], "--chunks takes one number or three"),
        (["--band", "0.2"], "--band applies with --chunks"),
    ],
)
def test_cli_bad_chunk_flags(tmp_path, capsys, args, message):
    from fepre.cli import main

    part = _model_file(tmp_path)
    assert main(["surface", str(part), "-o", str(tmp_path / "s.stl"), "--spacing", "0.2", *args]) == 1
    assert message in capsys.readouterr().err
    assert not (tmp_path / "s.stl").exists()


def test_cli_sample_flags_checked(tmp_path, capsys):
    from fepre.cli import main

    part = _model_file(tmp_path)
    assert main(["sample", str(part), "-o", str(tmp_path / "g.zarr")]) == 1
    assert "--output .zarr needs --chunks" in capsys.readouterr().err
    assert main(["sample", str(part), "-o", str(tmp_path / "g.vti"), "--chunks", "16"]) == 1
    assert "--chunks writes a .zarr store" in capsys.readouterr().err
    assert main(["sample", str(part), "-o", str(tmp_path / "g.vti"), "--spacing", "0.2", "--quiet"]) == 0
    assert sorted(p.name for p in tmp_path.iterdir()) == ["g.vti", "part.py"]


def test_without_dask_the_error_says_what_to_install(tmp_path, capsys, monkeypatch):
    import sys

    from fepre.cli import main

    monkeypatch.setitem(sys.modules, "dask", None)
    monkeypatch.setitem(sys.modules, "dask.array", None)
    with pytest.raises(ImportError, match=r"pip install 'fepre\[dask\]'"):
        fepre.sample(sdf.sphere(1.0), spacing=0.1, chunks=8)
    part = _model_file(tmp_path)
    assert main(["surface", str(part), "-o", str(tmp_path / "s.stl"), "--chunks", "16", "--spacing", "0.5"]) == 1
    assert "needs dask: pip install 'fepre[dask]'" in capsys.readouterr().err
    assert sorted(p.name for p in tmp_path.iterdir()) == ["part.py"]
