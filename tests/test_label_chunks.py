"""Label images beyond memory: ``sdf.labels`` of a zarr store or dask array, chunk by chunk,
against the in-memory path (the same triangles, bit for bit), the diagonal joins across chunks,
a conformal mesh from the store, the CLI on a ``.zarr`` store, and the errors."""

from __future__ import annotations

import math

import numpy as np
import pytest

pytest.importorskip("dask.array")
zarr = pytest.importorskip("zarr")

import dask.array as da  # noqa: E402

import fepre  # noqa: E402
from fepre import sdf  # noqa: E402
from fepre.chunked.labels import label_surface_chunked  # noqa: E402
from fepre.chunked.phantom_store import write_label_image  # noqa: E402
from fepre.cli import main  # noqa: E402
from fepre.sdf.imagemodel import ImageInputError  # noqa: E402
from fepre.sdf.imagemodel.labelmodel import BORDER_COPIES  # noqa: E402
from fepre.sdf.imagemodel.multilabel import label_surface  # noqa: E402
from fepre.sdf.imagemodel.phantoms import label_image  # noqa: E402

CUBE, BALL = sdf.box(1.0), sdf.sphere(0.25, center=(0.2, 0, 0))
ROD = sdf.cylinder(radius=0.15, height=0.6, center=(-0.25, 0, 0))
MODELS, BOX, SPACING = [CUBE, BALL, ROD], ((-0.6,) * 3, (0.6,) * 3), 1.2 / 48
NAMES = {1: "matrix", 2: "ball", 3: "rod"}
BALL_VOLUME, ROD_VOLUME = 4 / 3 * math.pi * 0.25**3, math.pi * 0.15**2 * 0.6


def _mesh(model):
    """The label model of a region (the background region is an intersection)."""
    return model if hasattr(model, "faces") else model.children[0]


@pytest.fixture(scope="module")
def phantom(tmp_path_factory):
    """A cube with a ball and a rod in it, 48^3 voxels, as an array and as a zarr store written in
    chunks of 16."""
    path = tmp_path_factory.mktemp("labels") / "labels.zarr"
    grid = label_image(MODELS, *BOX, SPACING)
    values = np.asarray(grid["labels"]).reshape(grid.dimensions, order="F")
    store = write_label_image(MODELS, path, *BOX, SPACING, chunks=16)
    return values, grid, path, store


@pytest.fixture(scope="module")
def both(phantom):
    values, grid, path, _ = phantom
    whole = sdf.labels(values, spacing=grid.spacing, origin=grid.origin, names=NAMES)
    chunked = sdf.labels(str(path), names=NAMES, chunks=20)  # 3 chunks per axis, not the store's 16
    return whole, chunked


def test_the_store_holds_the_phantom(phantom):
    values, grid, _, store = phantom
    assert store.dtype == np.uint8 and np.array_equal(store[:], values)
    assert np.bincount(values.ravel()).tolist()[2] == pytest.approx(BALL_VOLUME / SPACING**3, rel=0.03)
    assert store.attrs["origin"] == pytest.approx(grid.origin, abs=1e-15)


def test_chunked_labels_are_the_in_memory_labels(both):
    whole, chunked = both
    assert list(chunked) == list(whole) == ["matrix", "ball", "rod"]
    assert chunked.labels == whole.labels == {"matrix": 1, "ball": 2, "rod": 3}
    points = np.array([[0.2, 0.0, 0.0], [-0.25, 0.0, 0.2], [0.0, 0.4, 0.4], [0.55, 0.0, 0.0]])
    for name in [*whole, "part"]:
        a = _mesh(whole[name] if name != "part" else whole.part)
        b = _mesh(chunked[name] if name != "part" else chunked.part)
        assert len(a.faces) == len(b.faces) > 1000
        assert np.array_equal(a.vertices, b.vertices) and np.array_equal(a.faces, b.faces)  # the same bits
        assert b.volume == a.volume
        assert np.array_equal(b(points), a(points))
    assert chunked["ball"].volume == pytest.approx(BALL_VOLUME, rel=0.02)
    assert chunked["rod"].volume == pytest.approx(ROD_VOLUME, rel=0.03)
    assert chunked.part.volume == pytest.approx(1.0, rel=0.005)
    assert chunked["ball"](points[:1])[0] == pytest.approx(-0.25, abs=0.3 * SPACING)


def _noisy(size: int, seed: int) -> np.ndarray:
    """Four labels in blobs a few voxels across, with background specks: hundreds of faces with
    a label on one diagonal only, joined across the chunks' sides."""
    from scipy import ndimage

    rng = np.random.default_rng(seed)
    values = np.argmax(ndimage.gaussian_filter(rng.random((4, size, size, size)), (0, 1.2, 1.2, 1.2)), axis=0)
    values[rng.random(values.shape) < 0.01] = 0
    return values.astype(np.int16)


@pytest.mark.parametrize("smoothing, keep", [(0.5, False), (0.0, False), (1.0, True)])
def test_diagonal_joins_across_chunks(smoothing, keep):
    values = _noisy(28, 3)
    found = label_surface_chunked(da.from_array(values, chunks=10), smoothing=smoothing, keep_background=keep, chunks=8)
    indices = found.plan.indices(values)
    origin = np.zeros(3)
    assert found.reaches is not keep  # the blobs reach the border: padded by its copies
    if found.reaches:
        indices = np.pad(indices, BORDER_COPIES, mode="edge")
        origin = origin - BORDER_COPIES
    whole = label_surface(indices, len(found.plan.order), np.ones(3), origin, smoothing, 0, 30)
    assert found.joined > 100 and found.chunks == (3 if keep else 4) ** 3
    for name in ("vertices", "faces", "inner", "outer", "plane"):
        assert np.array_equal(getattr(found.surface, name), getattr(whole, name)), name


@pytest.mark.slow  # 4 s of the default run on 2 cores
def test_one_label_windows_are_skipped_and_reaching_the_border():
    values = np.ones((40, 40, 40), np.uint8)
    values[25:, :, :] = 2  # two labels, both on the border; a plane at x = 24.5
    found = label_surface_chunked(da.from_array(values, chunks=20), chunks=11)
    assert found.reaches and found.skipped > 0 and found.joined == 0
    regions = sdf.labels(da.from_array(values, chunks=20), chunks=11)
    memory = sdf.labels(values)
    points = np.array([[20.0, 20.0, 20.0], [24.0, 3.0, 7.0], [39.4, 0.0, 0.0], [-0.6, 10.0, 10.0]])
    assert np.array_equal(regions.part(points), memory.part(points))
    assert np.array_equal(regions["label_1"](points), memory["label_1"](points))
    assert regions.part(points[:1])[0] == pytest.approx(-19.5)  # the voxels' box (x, y, z from -0.5 to 39.5) cuts the part
    assert regions["label_1"](points[1:2])[0] == pytest.approx(-0.5, abs=1e-9)  # the plane, sharp


@pytest.mark.slow  # 10 s of the default run on 2 cores
def test_conformal_mesh_from_the_store(both):
    whole, chunked = both
    h = 0.1
    mesh = fepre.distmesh(chunked.part, h, regions=chunked, progress=False)
    reference = fepre.distmesh(whole.part, h, regions=whole, progress=False)
    assert list(mesh.field_data["region_names"]) == ["matrix", "ball", "rod"]
    volumes = np.bincount(mesh["region_id"], mesh["volume"])
    assert volumes == pytest.approx(np.bincount(reference["region_id"], reference["volume"]), rel=1e-9)
    assert mesh.n_cells == reference.n_cells
    assert volumes[1] == pytest.approx(BALL_VOLUME, rel=0.1) and volumes.sum() == pytest.approx(1.0, rel=0.01)
    for k in range(3):
        assert mesh["min_dihedral_angle"][mesh["region_id"] == k].min() >= 25.0


@pytest.mark.slow  # 6 s of the default run on 2 cores
def test_cli_meshes_a_label_store(phantom, tmp_path):
    _, _, path, _ = phantom
    out = tmp_path / "labels.inp"
    assert main(["mesh", str(path), "--labels", "--label", "1=matrix", "--label", "2=ball", "--label", "3=rod",
                 "--h", "0.1", "--no-features", "-o", str(out), "--quiet"]) == 0
    text = out.read_text()
    assert all(f"ELSET={name}" in text for name in ("matrix", "ball", "rod"))
    import pyvista as pv

    assert pv.read(out).volume == pytest.approx(1.0, rel=0.02)


def _store(path, values):
    store = zarr.create_array(store=str(path), shape=values.shape, chunks=(8,) * values.ndim, dtype=values.dtype)
    store[...] = values
    return str(path)


@pytest.mark.parametrize("kind, message", [
    ("one", "holds 1 label besides the background 0 (values [0, 3])"),
    ("float", "holds non-integer values (float32); a label image holds integer labels"),
    ("flat", "is not a 3D image (shape (16, 16))"),
    ("names", "gives labels [7] that the image does not hold"),
])
def test_bad_label_stores(tmp_path, kind, message, capsys):
    values = np.zeros((16, 16, 16), np.uint8)
    values[4:12, 4:12, 4:12] = 3
    if kind == "float":
        values = values.astype(np.float32) + 0.25
    elif kind == "flat":
        values = values[:, :, 0]
    elif kind == "names":
        values[6:8, 6:8, 6:8] = 1
    path = _store(tmp_path / f"{kind}.zarr", values)
    with pytest.raises(ImageInputError, match=r"^" + str(path).replace(".", r"\.")) as error:
        sdf.labels(path, names={7: "x"} if kind == "names" else None)
    assert message in str(error.value)
    if kind == "one":  # through the CLI: the file and the cause, no traceback
        assert main(["mesh", path, "--labels", "--h", "1", "-o", str(tmp_path / "x.inp"), "--quiet"]) == 1
        assert message in capsys.readouterr().err


def test_chunks_is_checked():
    with pytest.raises(ValueError, match="chunks"):
        sdf.labels(np.zeros((10, 10, 10), np.uint8), chunks=2)


@pytest.mark.slow
def test_the_mni_brain_chunked_is_the_brain_in_memory():
    """A real segmentation (the MNI brain of examples/brain_mri.py at 2 mm, 98 x 116 x 94, three
    labels): joins in several chunks (225 nodes), the same triangles in chunks of 48."""
    import runpy
    from pathlib import Path

    pytest.importorskip("nibabel")
    namespace = runpy.run_path(str(Path(__file__).parents[1] / "examples" / "brain_mri.py"))
    if namespace["template_folder"]() is None:
        pytest.skip("the MNI152 templates come with nilearn: pip install --no-deps nilearn")
    values, spacing, origin = namespace["mni152_labels"]()
    found = label_surface_chunked(da.from_array(values, chunks=64), spacing=spacing, origin=origin, chunks=48)
    spacing = np.asarray(spacing, float)
    indices = np.pad(found.plan.indices(values), BORDER_COPIES, mode="edge")  # the brain stem reaches the border
    whole = label_surface(indices, 4, spacing, np.asarray(origin, float) - BORDER_COPIES * spacing, 0.5, 0, 30)
    assert found.reaches and found.joined > 100 and found.retaken > 1
    assert np.array_equal(found.surface.vertices, whole.vertices) and np.array_equal(found.surface.faces, whole.faces)


@pytest.mark.parametrize("options", [
    {"spacing": (1.0, 0.5, 2.0), "smoothing": 1.5},  # anisotropic: the Gaussian's reach differs per axis
    {"background": 100, "names": {0: "a", 7000: "b"}},  # label values far apart, another background
    {"keep_background": True, "spacing": (2.0, 1.0, 1.0)},
])
def test_spacing_label_values_and_background(options):
    values = np.array([0, 100, 7000], np.uint16)[_noisy(24, 5) % 3]
    whole = sdf.labels(values, **options)
    chunked = sdf.labels(da.from_array(values, chunks=(7, 9, 11)), chunks=(9, 12, 10), **options)
    assert list(chunked) == list(whole) and chunked.labels == whole.labels
    points = np.random.default_rng(0).uniform(-3, 50, (500, 3))
    for name in [*whole, "part"]:
        a, b = (whole[name], chunked[name]) if name != "part" else (whole.part, chunked.part)
        assert np.array_equal(a(points), b(points))
        if hasattr(a, "faces"):
            assert np.array_equal(a.vertices, b.vertices) and np.array_equal(a.faces, b.faces)
