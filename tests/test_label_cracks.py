"""Background voxels one voxel wide between two labels: warned of, or filled on request."""

from __future__ import annotations

import warnings

import numpy as np
import pytest

import fepre
from fepre import sdf
from fepre.sdf.imagemodel.cracks import background_cracks, filled_cracks
from fepre.sdf.imagemodel.phantoms import label_image

BLOCK, CORE = sdf.box((20, 20, 14)), sdf.box((17, 17, 11))
SHELL = BLOCK - CORE


def _cracked():
    """A shell (label 1) round a core (label 2) with a layer of background between them on the
    core's two faces normal to z (voxel 0.2, the core's faces at z = +-5.5); and how many
    voxels that layer holds."""
    grid = label_image([SHELL, CORE], (-10.95, -10.95, -7.95), (10.95, 10.95, 7.95), 0.2)
    values = np.asarray(grid["labels"]).reshape(grid.dimensions, order="F")
    z = grid.origin[2] + 0.2 * np.arange(grid.dimensions[2])
    x = grid.origin[0] + 0.2 * np.arange(grid.dimensions[0])
    y = grid.origin[1] + 0.2 * np.arange(grid.dimensions[1])
    inside = (np.abs(x)[:, None] < 8.5) & (np.abs(y)[None, :] < 8.5)
    for face in (-5.5, 5.5):
        values[:, :, int(np.argmin(np.abs(z - face)))][inside] = 0
    grid["labels"] = values.ravel(order="F")
    return grid, 2 * int(inside.sum())


def test_cracks_are_found_between_two_labels_only():
    values = np.zeros((7, 5, 5), dtype=np.int16)
    values[1:3] = 1
    values[4:6] = 2
    values[1:6, 0] = 0  # background beside both labels: the part's outside, not a crack
    count, first, pairs = background_cracks(values)
    assert count == 4 * 5 and first.tolist() == [3, 1, 0] and pairs.tolist() == [[1, 2]]
    same = values.copy()
    same[4:6] = 1  # a slit within one label is a feature of that material
    assert background_cracks(same)[0] == 0
    filled, done = filled_cracks(values)
    assert done == 20 and (filled[3, 1:] == 1).all() and background_cracks(filled)[0] == 0


@pytest.mark.slow  # 27 s of the default run on 2 cores
def test_a_cracked_label_image_warns_and_meshes_when_filled():
    grid, layer = _cracked()
    assert background_cracks(np.asarray(grid["labels"]).reshape(grid.dimensions, order="F"))[0] == layer
    with pytest.warns(fepre.ResolutionWarning, match=rf"{layer} background voxel\(s\) lie one voxel wide between two labels \(1 and 2"):
        sdf.labels(grid)
    with warnings.catch_warnings():
        warnings.simplefilter("error", fepre.ResolutionWarning)
        regions = sdf.labels(grid, fill_cracks=True)
    mesh = fepre.distmesh(regions.part, 1.0, regions=regions, progress=False)
    volumes = np.bincount(mesh["region_id"], mesh["volume"])
    # each region's volume is its voxels' in the filled image (the layer went to the shell)
    filled, _ = filled_cracks(np.asarray(grid["labels"]).reshape(grid.dimensions, order="F"))
    voxels = np.bincount(filled.ravel(), minlength=3)[1:] * 0.2**3
    assert volumes == pytest.approx(voxels, rel=0.01)
    before = np.bincount(np.asarray(grid["labels"]), minlength=3)
    assert voxels[0] == pytest.approx((before[1] + layer) * 0.2**3, rel=1e-12)


def test_voxel_centres_on_a_shared_face_take_a_label():
    # the core's faces at z = +-5.5 fall on voxel centres: both models are zero there
    grid = label_image([SHELL, CORE], (-10.9, -10.9, -7.9), (10.9, 10.9, 7.9), 0.2)
    values = np.asarray(grid["labels"]).reshape(grid.dimensions, order="F")
    assert background_cracks(values)[0] == 0
    centre = values[values.shape[0] // 2, values.shape[1] // 2]
    assert (centre[5:-5] > 0).all()


def test_fill_cracks_needs_labels_and_an_image_in_memory(tmp_path, capsys):
    from fepre.cli import main

    grid, _ = _cracked()
    path = tmp_path / "cracked.vti"
    grid.save(path)
    assert main(["mesh", str(path), "--level", "0.5", "--fill-cracks", "--h", "1", "-o", str(tmp_path / "x.vtu")]) != 0
    assert "--fill-cracks is for a label image: add --labels" in capsys.readouterr().err
    assert not (tmp_path / "x.vtu").exists()
    with pytest.raises(ValueError, match="fill_cracks=True needs the image in memory"):
        sdf.labels(grid, fill_cracks=True, chunks=32)
