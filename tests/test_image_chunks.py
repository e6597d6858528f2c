"""Images beyond memory: ``sdf.image`` of a zarr store or dask array, chunk by chunk, against the
in-memory path (the same triangles, bit for bit), the B-spline refinement against scipy's zoom,
the bound that skips chunks, the CLI on a ``.zarr`` store, and the errors."""

from __future__ import annotations

import math

import numpy as np
import pytest
import pyvista as pv

pytest.importorskip("dask.array")
zarr = pytest.importorskip("zarr")

import dask.array as da  # noqa: E402

from fepre import sdf  # noqa: E402
from fepre.chunked.phantom_store import write_partial_volume  # noqa: E402
from fepre.cli import main  # noqa: E402
from fepre.sdf.imagemodel import ImageInputError  # noqa: E402
from fepre.sdf.imagemodel.bspline import NEGATIVE_TAPS, refine_samples  # noqa: E402
from fepre.sdf.imagemodel.phantoms import partial_volume  # noqa: E402

TORUS = sdf.torus(0.6, 0.25)
TORUS_VOLUME = 2 * math.pi**2 * 0.6 * 0.25**2


def _sorted_rows(points: np.ndarray) -> np.ndarray:
    return points[np.lexsort(points.T[::-1])]


def _triangles(model) -> np.ndarray:
    """The triangles as rows of their corners' ranks in the lexicographic order of the vertices,
    each row rotated to start at its smallest rank (orientation kept), rows sorted."""
    rank = np.empty(len(model.vertices), dtype=np.int64)
    rank[np.lexsort(model.vertices.T[::-1])] = np.arange(len(model.vertices))
    faces = rank[model.faces]
    shift = np.argmin(faces, axis=1)
    rows = np.take_along_axis(faces, (shift[:, None] + np.arange(3)) % 3, axis=1)
    return rows[np.lexsort(rows.T[::-1])]


def _mesh(model):
    return model if hasattr(model, "faces") else model.children[0]


@pytest.fixture(scope="module")
def torus_image(tmp_path_factory):
    """A 64^3 partial-volume torus as an array and as a zarr store written chunk by chunk."""
    folder = tmp_path_factory.mktemp("zarr")
    grid = partial_volume(TORUS, (-1,) * 3, (1,) * 3, 2 / 64)
    values = np.asarray(grid["density"]).reshape(grid.dimensions, order="F")
    store = write_partial_volume(TORUS, folder / "torus.zarr", (-1,) * 3, (1,) * 3, 2 / 64, chunks=16)
    return values, grid, folder / "torus.zarr", store


def test_the_zarr_store_holds_the_phantom(torus_image):
    values, grid, _, store = torus_image
    assert np.array_equal(store[:], values)
    assert store.attrs["origin"] == pytest.approx(grid.origin, abs=1e-15)


@pytest.mark.slow  # 7 s of the default run on 2 cores
def test_chunked_image_is_the_in_memory_image(torus_image):
    values, grid, path, _ = torus_image
    whole = sdf.image(values, level=0.5, spacing=grid.spacing, origin=grid.origin, refine=2)
    chunked = sdf.image(str(path), level=0.5, chunks=24)  # 3 chunks per axis, not the store's 16
    assert type(chunked) is type(whole) is sdf.ImageModel
    assert len(chunked.faces) == len(whole.faces) > 50_000
    assert np.array_equal(_sorted_rows(chunked.vertices), _sorted_rows(whole.vertices))  # the same bits
    assert np.array_equal(_triangles(chunked), _triangles(whole))  # and oriented alike
    assert chunked.volume == pytest.approx(whole.volume, rel=1e-12)
    assert chunked.volume == pytest.approx(TORUS_VOLUME, rel=0.01)
    points = np.array([[0.6, 0.0, 0.0], [0.0, 0.0, 0.0], [0.0, 0.85, 0.0]])
    assert np.array_equal(chunked(points), whole(points))
    assert chunked(points)[0] == pytest.approx(-0.25, abs=0.1 * 2 / 64)


@pytest.mark.slow  # 4 s of the default run on 2 cores
def test_border_smoothing_and_refine_one_match_too():
    """A solid cut by the image's box (padding), smoothing, refine 1 and 3, from a dask array."""
    grid = partial_volume(TORUS, (-0.7,) * 3, (0.7,) * 3, 1.4 / 36)
    values = np.asarray(grid["density"]).reshape(grid.dimensions, order="F")
    geometry = dict(spacing=grid.spacing, origin=grid.origin)
    for options in ({"smoothing": 1.0}, {"refine": 1}, {"refine": 3, "inside": "below", "level": 0.4}):  # 2: above
        options = {"level": 0.5, **options}
        whole = sdf.image(values, **geometry, **{"refine": 2, **options})
        chunked = sdf.image(da.from_array(values, chunks=10), chunks=12, **geometry, **options)
        a, b = _mesh(whole), _mesh(chunked)
        assert type(whole) is type(chunked)
        assert np.array_equal(_sorted_rows(a.vertices), _sorted_rows(b.vertices)), options
        assert np.array_equal(_triangles(a), _triangles(b)), options
    assert type(whole).__name__ == "Intersection"  # the torus reaches the box: cut by it


def test_refinement_is_scipy_zoom():
    from scipy import ndimage

    samples = np.random.default_rng(1).random((9, 7, 8)).astype(np.float32)
    counts = [(n - 1) * 2 + 1 for n in samples.shape]
    ours = refine_samples(samples, (0, 0, 0), (0, 0, 0), counts, 2)
    theirs = ndimage.zoom(samples, np.array(counts) / np.array(samples.shape), order=3, mode="nearest",
                          grid_mode=False, output=np.float32)
    assert np.abs(ours - theirs).max() < 1e-6
    assert np.abs(ours[::2, ::2, ::2] - samples).max() < 1e-6


def test_the_skip_bound_holds_on_its_worst_case():
    """The interpolant of samples in [low, high] stays above low - 13 (high - low), and comes
    close to it on the alternating pattern that makes every negative tap count."""
    i, j, k = np.indices((25, 25, 25))
    checker = ((i + j + k) % 2).astype(np.float32)  # 0/1 alternating: the coefficients' extreme
    fine = refine_samples(checker, (0, 0, 0), (4, 4, 4), (40, 40, 40), 2)
    bound = 0.0 - NEGATIVE_TAPS * 1.0
    assert fine.min() >= bound - 1e-6
    rng = np.random.default_rng(3)
    noisy = rng.uniform(0.9, 1.0, (20, 20, 20)).astype(np.float32)
    fine = refine_samples(noisy, (0, 0, 0), (0, 0, 0), (39, 39, 39), 2)
    assert fine.min() >= 0.9 - NEGATIVE_TAPS * 0.1


def test_cli_surface_and_errors_of_a_zarr_image(torus_image, tmp_path, capsys):
    _, _, path, _ = torus_image
    out = tmp_path / "torus.stl"
    assert main(["surface", str(path), "--level", "0.5", "-o", str(out)]) == 0
    surface = pv.read(out)
    assert surface.n_cells > 50_000 and surface.n_open_edges == 0
    assert surface.volume == pytest.approx(TORUS_VOLUME, rel=0.01)
    assert main(["surface", str(path), "--level", "3", "-o", str(out)]) != 0
    assert "level 3.0 is outside the image's values (0.0 to 1.0)" in capsys.readouterr().err
    assert main(["mesh", str(path), "--h", "0.1", "-o", str(tmp_path / "t.inp")]) != 0
    assert "is an image: pass --level" in capsys.readouterr().err


def test_bad_chunked_images(tmp_path):
    flat = zarr.create_array(store=str(tmp_path / "flat.zarr"), shape=(20, 20), dtype="float32")
    with pytest.raises(ImageInputError, match=r"flat.zarr is not a 3D image \(shape \(20, 20\)\)"):
        sdf.image(tmp_path / "flat.zarr", level=0.5)
    with pytest.raises(ImageInputError, match="is not a 3D image"):
        sdf.image(flat, level=0.5)
    cube = da.zeros((12, 12, 12), chunks=6).astype(np.float32)
    with pytest.raises(ValueError, match="level is required .* between the image's values 0.0 and 0.0"):
        sdf.image(cube)
    with pytest.raises(ImageInputError, match=r"dask array: level 0.5 is outside the image's values \(0.0 to 0.0\)"):
        sdf.image(cube, level=0.5)
    holed = da.from_array(np.where(np.arange(12**3).reshape(12, 12, 12) == 5, np.nan, 1.0), chunks=6)
    with pytest.raises(ImageInputError, match="1 non-finite values"):
        sdf.image(holed, level=0.5)
    with pytest.raises(ImageInputError, match="does not exist"):
        sdf.image(tmp_path / "missing.zarr", level=0.5)
    group = zarr.open_group(str(tmp_path / "group.zarr"), mode="w")
    group.create_array("a", shape=(8, 8, 8), dtype="float32")
    group.create_array("b", shape=(8, 8, 8), dtype="float32")
    with pytest.raises(ImageInputError, match="zarr group with arrays 'a', 'b'; name one with array="):
        sdf.image(tmp_path / "group.zarr", level=0.5)
    with pytest.raises(ValueError, match="chunks"):
        sdf.image(cube, level=0.5, chunks=4)


@pytest.mark.slow
def test_a_larger_chunked_image_is_the_in_memory_image(tmp_path):
    """160^3 voxels (refined: 319^3 nodes), chunks of 48 samples, smoothing 0.7: the same bits."""
    torus = sdf.torus(0.6, 0.2)
    grid = partial_volume(torus, (-1,) * 3, (1,) * 3, 2 / 160)
    values = np.asarray(grid["density"]).reshape(grid.dimensions, order="F")
    store = write_partial_volume(torus, tmp_path / "torus.zarr", (-1,) * 3, (1,) * 3, 2 / 160, chunks=64)
    whole = sdf.image(values, level=0.5, spacing=grid.spacing, origin=grid.origin, refine=2, smoothing=0.7)
    chunked = sdf.image(store, level=0.5, chunks=48, smoothing=0.7)
    assert np.array_equal(_sorted_rows(chunked.vertices), _sorted_rows(whole.vertices))
    assert np.array_equal(_triangles(chunked), _triangles(whole))
    assert chunked.volume == pytest.approx(2 * math.pi**2 * 0.6 * 0.2**2, rel=0.01)


def test_chunks_away_from_the_level_are_skipped():
    """A ball in a 48^3 image in chunks of 12, refine 1 (at refine 2 every window of so small an
    image reaches 40 samples beyond its chunk, over the ball): the corner chunks' samples are all
    0, surely outside; skipped before any filtering."""
    from fepre.chunked.image import level_set_triangles

    x, y, z = np.mgrid[-1:1:48j, -1:1:48j, -1:1:48j]
    ball = (np.sqrt(x**2 + y**2 + z**2) < 0.5).astype(np.float32)
    found = level_set_triangles(da.from_array(ball, chunks=16), 0.5, spacing=2 / 47, origin=-1.0, chunks=12,
                                refine=1)
    assert found.chunks == 64
    assert 0 < found.skipped < 64
    assert np.abs(np.linalg.norm(found.vertices, axis=1) - 0.5).max() < 2 / 47  # the level set is the sphere's


def test_a_grey_store_is_no_label_image(torus_image):
    """sdf.labels reads stores chunk by chunk (tests/test_label_chunks.py); a partial-volume
    image is refused by its first pass, naming the store."""
    _, _, path, _ = torus_image
    with pytest.raises(ImageInputError, match=f"^{path}.* holds non-integer values .float32.; a label image holds integer"):
        sdf.labels(str(path))
