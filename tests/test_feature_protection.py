"""The feature neighbourhoods DistMesh keeps its points out of."""

import numpy as np
import pytest

import fepre
from fepre import sdf
from fepre.distmesh import feature_protection
from fepre.distmesh.feature_protection import FeatureProtection, _VoxelFilter
from fepre.features.geometry import nearest_on_segments


@pytest.mark.parametrize("dense", [True, False])
def test_voxel_filter_keeps_every_point_within_reach(dense, monkeypatch):
    if not dense:
        monkeypatch.setattr(feature_protection, "_DENSE_VOXELS", 0)
    rng = np.random.default_rng(4)
    anchors = rng.uniform(-1, 1, (60, 3))
    points = rng.uniform(-1.5, 1.5, (20000, 3))
    near = _VoxelFilter(anchors, 0.1)
    assert (near.marked is not None) == dense
    mask = near(points)
    distance = np.linalg.norm(points[:, None] - anchors[None], axis=2).min(axis=1)
    assert mask[distance <= 0.1].all()
    assert mask.sum() < 0.2 * len(points)  # and leaves most of the others out
    assert not _VoxelFilter(np.zeros((0, 3)), 0.1)(points).any()


def test_push_moves_points_out_of_the_neighbourhood_only():
    """Against nearest_on_segments on every point: the same points move, to the same places."""
    part = sdf.box((2.0, 1.0, 0.5)) - sdf.cylinder(0.2, 1.0)
    found = fepre.features(part, 0.1, warn=False)
    protection = FeatureProtection(found, part, 0.1)
    points = np.random.default_rng(2).uniform(-1.1, 1.1, (30000, 3)) * [1.0, 0.55, 0.3]
    distance, foot, segment = nearest_on_segments(points, protection.segments, protection.corners, with_index=True)
    close = distance < protection.radius(segment)
    assert 100 < close.sum() < len(points) // 2
    moved = points.copy()
    index, step = protection.push(moved, np.ones(len(points), bool))
    assert sorted(index.tolist()) == np.flatnonzero(close).tolist()
    assert np.array_equal(moved[~close], points[~close])
    reference = points.copy()  # every point measured, none filtered out first
    protection._near = lambda p: np.ones(len(p), bool)
    reference_index, _ = protection.push(reference, np.ones(len(points), bool))
    assert np.array_equal(reference_index, index) and np.array_equal(reference, moved)
    # each moved point ends on the rim of its nearest feature's neighbourhood
    foot_distance = np.linalg.norm(moved[index] - foot[index], axis=1)
    assert np.allclose(foot_distance, protection.radius(segment[index]))
    assert np.allclose(step, np.linalg.norm(moved[index] - points[index], axis=1))
    protection = FeatureProtection(found, part, 0.1)
    assert protection.inside(points).tolist() == close.tolist()
