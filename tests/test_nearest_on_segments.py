"""nearest_on_segments' compiled candidate loop: the array form's results bit for bit, and the
true nearest segment (brute force over all of them) where segments have similar lengths."""

from __future__ import annotations

import numpy as np
from scipy.spatial import cKDTree

from fepre.features.geometry import _CANDIDATES, nearest_on_segments


def _array_form(points, segments):
    """The candidate search as numpy arrays (the form the kernel replaced)."""
    a, b = segments[:, 0], segments[:, 1]
    k = min(_CANDIDATES, len(segments))
    _, candidates = cKDTree(0.5 * (a + b)).query(points, k=k)
    candidates = candidates.reshape(len(points), k)
    sa, sb = a[candidates], b[candidates]
    edge = sb - sa
    t = np.einsum("nkd,nkd->nk", points[:, None, :] - sa, edge) / np.maximum(np.einsum("nkd,nkd->nk", edge, edge), 1e-300)
    foot = sa + np.clip(t, 0.0, 1.0)[:, :, None] * edge
    distance = np.linalg.norm(points[:, None, :] - foot, axis=2)
    pick = np.argmin(distance, axis=1)
    rows = np.arange(len(points))
    return distance[rows, pick], foot[rows, pick], candidates[rows, pick]


def _segments(rng, count, scale):
    start = rng.uniform(-5, 5, (count, 3)) * scale
    segments = np.stack([start, start + rng.normal(size=(count, 3)) * 0.5 * scale], axis=1)
    segments[:2, 1] = segments[:2, 0]  # zero-length pieces
    return segments


def test_kernel_equals_the_array_form_bit_for_bit():
    rng = np.random.default_rng(7)
    for scale in (1e-3, 1.0, 1e4):
        segments = _segments(rng, 150, scale)
        points = rng.uniform(-6, 6, (3000, 3)) * scale
        distance, foot, index = nearest_on_segments(points, segments, np.zeros((0, 3)), with_index=True)
        expected = _array_form(points, segments)
        assert np.array_equal(distance, expected[0])
        assert np.array_equal(foot, expected[1])
        assert np.array_equal(index, expected[2])


def test_nearest_segment_matches_brute_force():
    rng = np.random.default_rng(3)
    t = np.linspace(0.0, 2.0 * np.pi, 61)
    ring = np.stack([np.cos(t), np.sin(t), np.zeros_like(t)], axis=1)  # a circle of 60 equal chords
    segments = np.stack([ring[:-1], ring[1:]], axis=1)
    points = rng.uniform(-1.5, 1.5, (2000, 3))
    distance, foot, index = nearest_on_segments(points, segments, np.zeros((0, 3)), with_index=True)
    a, e = segments[:, 0], segments[:, 1] - segments[:, 0]
    s = np.clip(np.einsum("nsd,sd->ns", points[:, None] - a, e) / np.einsum("sd,sd->s", e, e), 0.0, 1.0)
    brute = np.linalg.norm(points[:, None] - (a + s[..., None] * e), axis=2)
    assert np.allclose(distance, brute.min(axis=1), rtol=0, atol=1e-12)
    assert np.allclose(brute[np.arange(len(points)), index], distance, rtol=0, atol=1e-12)
    assert np.allclose(np.linalg.norm(points - foot, axis=1), distance, rtol=0, atol=1e-12)
