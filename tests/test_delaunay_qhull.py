"""Qhull's precision failures fall back to a joggled triangulation, with a short message."""

import numpy as np
import pytest
import scipy.spatial

from fepre.distmesh import delaunay
from fepre.errors import MeshingError
from fepre.quality import signed_volumes


def _lattice():
    axis = np.arange(5.0)
    return np.stack(np.meshgrid(axis, axis, axis, indexing="ij"), -1).reshape(-1, 3)


def test_a_wide_merge_error_is_retried_with_joggled_input(monkeypatch):
    """A plate with a 0.6 fin meshed at h = 0.3 (80k nodes, many exactly on the box faces) made
    Qhull stop with a "wide merge error" and a 7,000-line message; the retry with QJ meshes it
    (554,536 cells, volume 1696.000 of 1696, worst dihedral 33.0 deg)."""
    real = scipy.spatial.Delaunay
    calls = []

    def failing_once(points, *args, **kwargs):
        calls.append(kwargs.get("qhull_options"))
        if len(calls) == 1:
            raise scipy.spatial.QhullError("QH6417 qhull precision error (qh_merge_twisted)\n" + "details\n" * 7000)
        return real(points, *args, **kwargs)

    monkeypatch.setattr(scipy.spatial, "Delaunay", failing_once)
    points = _lattice()
    tets = delaunay.tetrahedralize(points, "scipy")
    assert calls == [None, "QJ Qbb"]
    volumes = signed_volumes(points, tets)
    assert volumes.min() > 0
    assert volumes.sum() == pytest.approx(64.0)


def test_a_triangulation_that_fails_twice_gives_one_line(monkeypatch):
    def failing(points, *args, **kwargs):
        raise scipy.spatial.QhullError("QH6417 qhull precision error\n" + "details\n" * 7000)

    monkeypatch.setattr(scipy.spatial, "Delaunay", failing)
    with pytest.raises(MeshingError) as caught:
        delaunay.tetrahedralize(_lattice(), "scipy")
    assert str(caught.value) == "Delaunay triangulation (Qhull) failed on 125 points: QH6417 qhull precision error"
