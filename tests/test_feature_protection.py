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


@pytest.mark.parametrize("dense", [True, False])
def test_voxel_filter_with_a_reach_per_anchor(dense, monkeypatch):
    """Reaches 0.02-0.4 (more than MAX_RINGS apart): every point within its anchor's reach kept,
    and far fewer points than a filter at the largest reach for all."""
    if not dense:
        monkeypatch.setattr(feature_protection, "_DENSE_VOXELS", 0)
    rng = np.random.default_rng(5)
    anchors = rng.uniform(-1, 1, (80, 3))
    reach = np.where(np.arange(80) < 8, 0.4, 0.02)
    points = rng.uniform(-1.5, 1.5, (40000, 3))
    near = _VoxelFilter(anchors, reach)
    mask = near(points)
    distance = np.linalg.norm(points[:, None] - anchors[None], axis=2)
    assert mask[(distance <= reach[None]).any(axis=1)].all()
    assert mask.sum() < 0.5 * _VoxelFilter(anchors, 0.4)(points).sum()


def test_push_in_a_graded_mesh_moves_the_points_an_unfiltered_push_moves():
    """Feature pieces 0.1-0.6 long (a size field): the per-piece filter changes nothing."""
    part = sdf.box((2.0, 1.0, 0.5)) - sdf.cylinder(0.2, 1.0)
    found = fepre.features(part, 0.1, size=lambda p: 1.0 + 5.0 * np.clip(np.abs(p[:, 0]) - 0.3, 0.0, 1.0), warn=False)
    lengths = np.linalg.norm(found.segments[:, 1] - found.segments[:, 0], axis=1)
    assert lengths.max() > 3 * lengths.min()
    protection = FeatureProtection(found, part, 0.1)
    points = np.random.default_rng(6).uniform(-1.1, 1.1, (30000, 3)) * [1.0, 0.55, 0.3]
    moved = points.copy()
    index, _ = protection.push(moved, np.ones(len(points), bool))
    assert 100 < len(index)
    reference = points.copy()
    protection._near = lambda p: np.ones(len(p), bool)
    reference_index, _ = protection.push(reference, np.ones(len(points), bool))
    assert np.array_equal(reference_index, index) and np.array_equal(reference, moved)
