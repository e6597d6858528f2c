"""Faces between two regions that lie inside a third one between them (a punctured layer) are
named (RegionConstraint._warn_crossed_regions); faces on a real interface are not."""

from __future__ import annotations

import warnings
from types import SimpleNamespace

import numpy as np
import pytest

import fepre
from fepre import sdf
from fepre.regions.constraint import RegionConstraint
from fepre.regions.partition import RegionSet

#: two blocks a layer 0.2 thick apart (|x| <= 0.1), and a block b touching a on its other side
LEFT = sdf.plane((1.0, 0.0, 0.0), (-0.1, 0.0, 0.0))
LAYER = sdf.box((0.2, 10.0, 10.0))
RIGHT = sdf.plane((-1.0, 0.0, 0.0), (0.1, 0.0, 0.0))
REGIONS = RegionSet(("left", "layer", "right"), (LEFT, LAYER, RIGHT))


def _job(points, h=0.4, size=None):
    return SimpleNamespace(points=np.asarray(points, float), h=h, size=size, absolute=False,
                           options=SimpleNamespace(check_resolution=True), frame_offset=np.zeros(3))


def _warned(points, faces, pairs, h=0.4):
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        RegionConstraint._warn_crossed_regions(SimpleNamespace(region_set=REGIONS), _job(points, h),
                                               np.asarray(faces), np.asarray(pairs))
    return [str(w.message) for w in caught if issubclass(w.category, fepre.ResolutionWarning)]


def test_faces_through_a_layer_join_regions_that_do_not_touch():
    # a face across the layer's mid-plane between left and right: 0.1 from both, 0.25 h = 0.1 ...
    points = [[0.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0], [-0.1, 0.0, 0.0], [-0.1, 1.0, 0.0], [-0.1, 0.0, 1.0]]
    said = _warned(points, [[0, 1, 2], [3, 4, 5]], [[0, 2], [0, 1]], h=0.3)
    assert len(said) == 1
    assert "1 face(s) (area 0.5) join 'left' and 'right' through 'layer'" in said[0]
    assert "do not touch in the model" in said[0] and "'left' and 'layer'" not in said[0]
    # the same face at h = 0.5: within 0.25 h of both surfaces, a chord's sag; nothing said
    assert _warned(points, [[0, 1, 2]], [[0, 2]], h=0.5) == []


def test_faces_on_a_real_interface_are_not_named():
    # left | layer faces on x = -0.1, some a little off (chords), and one far off, which the
    # region volume check is for (the pair does touch)
    points = [[-0.1, 0.0, 0.0], [-0.1, 1.0, 0.0], [-0.1, 0.0, 1.0], [-0.08, 2.0, 0.0], [-0.08, 3.0, 0.0], [-0.08, 2.0, 1.0],
              [0.05, 5.0, 0.0], [0.05, 6.0, 0.0], [0.05, 5.0, 1.0]]
    assert _warned(points, [[0, 1, 2], [3, 4, 5], [6, 7, 8]], [[0, 1], [0, 1], [0, 1]], h=0.4) == []


def test_region_meshes_of_touching_regions_say_nothing():
    part = sdf.box((2.0, 2.0, 2.0))
    regions = {"lower": part & sdf.plane((0, 0, 1), (0, 0, 0)), "upper": part & sdf.plane((0, 0, -1), (0, 0, 0))}
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        fepre.distmesh(part, 0.5, regions=regions)
    assert not any(" join " in str(w.message) for w in caught)
