"""The images bench's reference volume: a model's volume from cell-centre samples smoothed across
its zero set (fepre.bench.images.sampled_volume), against analytic volumes."""

from __future__ import annotations

import numpy as np
import pytest

from fepre import sdf
from fepre.bench.images import sampled_volume


def test_sampled_volume_of_a_ball_and_a_box():
    assert sampled_volume(sdf.sphere(0.3), -0.5, 0.5, samples=110) == pytest.approx(4 / 3 * np.pi * 0.027, rel=2e-4)
    assert sampled_volume(sdf.box((0.6, 0.4, 0.5)), -0.5, 0.5, samples=100) == pytest.approx(0.12, rel=1e-9)


def test_sampled_volume_of_the_gyroid_phantom_converges():
    gyroid = sdf.box(1.0) & sdf.gyroid(period=1.0, thickness=0.2)
    coarse, fine = (sampled_volume(gyroid, -0.55, 0.55, samples=n) for n in (110, 220))
    assert coarse == pytest.approx(fine, rel=2e-4) and fine == pytest.approx(0.72154, rel=1e-4)  # 330^3: 0.721540
