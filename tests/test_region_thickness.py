"""A region mesh that fails names the regions under two elements thick and the h that gives
the thinnest two across (``fepre.regions.thickness``), in the API's exception and the CLI."""

from __future__ import annotations

import re
import subprocess
import sys
import warnings

import numpy as np
import pytest

import fepre
from fepre import sdf
from fepre.errors import MeshingError
from fepre.regions.partition import RegionSet
from fepre.regions.thickness import region_depths

notes = pytest.mark.skipif(not hasattr(Exception, "add_note"), reason="exception notes need Python 3.11")


def test_region_depths_are_the_largest_balls_inside():
    slab = sdf.box((10.0, 10.0, 1.0), (0, 0, 0.5))
    block = sdf.box((10.0, 10.0, 4.0), (0, 0, 3.0))
    ball = sdf.sphere(1.5, center=(0, 0, 3.0))
    found = region_depths(RegionSet(("slab", "block", "ball"), (slab, block - ball, ball)), slab | block,
                          (-5, -5, 0), (5, 5, 5), 0.4)
    depths = [depth for depth, _ in found]
    assert depths[0] == pytest.approx(0.5, abs=0.05)  # the slab is 1 thick
    assert depths[2] == pytest.approx(1.5, abs=0.1)  # the ball's centre
    assert found[2][1] == pytest.approx([0, 0, 3.0], abs=0.15)
    assert depths[1] == pytest.approx(2.0, abs=0.1)  # the block round the ball: 4 x 4 beside it, 2 deep


def _phantom_regions(seed: int):
    from fepre.bench.label_corpus import phantom

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return phantom(seed, 0.25)


@pytest.mark.slow  # 4 s of the default run on 2 cores
@notes
def test_a_failed_region_mesh_names_the_thin_regions():
    # seed 5 of the label corpus: label_2, 9 voxels' volume, is too small for its own mesh at h = 1
    regions = sdf.labels(_phantom_regions(5))
    with pytest.raises(MeshingError) as caught:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            fepre.distmesh(regions.part, 1.0, regions=regions, progress=False)
    (note,) = caught.value.__notes__
    assert re.search(r"'label_2' at most 1\.25 thick \(its thickest place at \(3, -0\.5, -2\)\)", note), note
    assert "h <= 0.625 gives the thinnest two elements across" in note


@pytest.mark.slow
def test_the_h_a_failed_region_mesh_names_meshes_it():
    regions = sdf.labels(_phantom_regions(5))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        mesh = fepre.distmesh(regions.part, 0.625, regions=regions, progress=False)
    worst = [mesh["min_dihedral_angle"][mesh["region_id"] == k].min() for k in range(len(regions))]
    assert min(worst) >= 25.0


@pytest.mark.slow  # 9 s of the default run on 2 cores
@notes
def test_the_cli_prints_the_notes_of_an_error(tmp_path):
    _phantom_regions(5).save(tmp_path / "labels.vti")
    command = [sys.executable, "-m", "fepre", "mesh", str(tmp_path / "labels.vti"), "--labels", "--h", "1",
               "-o", str(tmp_path / "out.inp")]
    done = subprocess.run(command, capture_output=True, text=True, cwd=tmp_path)
    assert done.returncode == 1
    error = [line for line in done.stderr.splitlines() if line.startswith("fepre mesh: error:")]
    assert len(error) == 1 and "h <= 0.625 gives the thinnest two elements across" in error[0]
    assert not (tmp_path / "out.inp").exists()
