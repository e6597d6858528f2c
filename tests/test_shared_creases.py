"""Issue 33: a graded mesh finds its features once: the size field's crease search is the mesher's."""

import sys
import warnings

import numpy as np

import fepre
from fepre import sdf


def _counting(monkeypatch):
    import fepre.features  # noqa: F401 - the package module, not the callable

    features_module = sys.modules["fepre.features"]
    calls = []
    search = features_module.find_creases

    def counted(*args, **kwargs):
        calls.append(args[1])
        return search(*args, **kwargs)

    monkeypatch.setattr(features_module, "find_creases", counted)
    return calls


def test_a_graded_mesh_searches_for_creases_once(monkeypatch):
    part = sdf.box((8.0, 8.0, 3.0)) - sdf.cylinder(1.5, 4.0)
    calls = _counting(monkeypatch)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        mesh = fepre.distmesh(part, (1.0, 3.0))
    assert calls == [0.25]  # hmin / 4, the size field's and then the mesher's
    assert int((np.asarray(mesh["feature"]) == 2).sum()) == 8  # the box's corners


def test_creases_taken_from_a_larger_box_are_those_found_in_the_box():
    """The size field searches its box with a margin; the mesher's box (the part's) takes the
    creases in it, and the features built from them are a fresh search's."""
    part = sdf.box((8.0, 8.0, 3.0)) - sdf.cylinder(1.5, 4.0)
    lower, upper = np.array([-4.0, -4.0, -1.5]), np.array([4.0, 4.0, 1.5])
    wide = fepre.features(part, 0.25, spacing=0.25, bounds=(lower - 2.0, upper + 2.0), warn=False)
    fresh = fepre.features(part, 1.0, bounds=(lower, upper), warn=False)
    reused = fepre.features(part, 1.0, bounds=(lower, upper), warn=False, creases=wide.creases)
    assert reused.creases is not fresh.creases
    assert len(reused.corners) == len(fresh.corners) == 8  # the box's (the bore's rims are closed curves)
    assert len(reused.curves) == len(fresh.curves) == 14
    ours, theirs = (np.array(sorted(map(tuple, np.round(found.nodes, 6)))) for found in (reused, fresh))
    assert ours.shape == theirs.shape and np.abs(ours - theirs).max() < 1e-6
    assert reused.creases is wide.creases  # all of its points are in the box
    # another model (the same shape, another object), another angle or spacing: searched again
    twin = sdf.box((8.0, 8.0, 3.0)) - sdf.cylinder(1.5, 4.0)
    for found in (fepre.features(twin, 1.0, bounds=(lower, upper), warn=False, creases=wide.creases),
                  fepre.features(part, 1.0, angle=45.0, bounds=(lower, upper), warn=False, creases=wide.creases),
                  fepre.features(part, 1.2, bounds=(lower, upper), warn=False, creases=wide.creases)):
        assert found.creases is not wide.creases and len(found.corners) == 8
    # a crease box within the box searched: the search covers the box, points outside are dropped
    inner = fepre.features(part, 1.0, spacing=0.25, bounds=(lower + np.array([4.0, 0, 0]), upper), warn=False, creases=wide.creases)
    assert inner.creases.points[:, 0].min() >= -1e-9
