"""Smoke test of ``fepre bench sdf`` at a tiny size."""

from __future__ import annotations

import numpy as np

from fepre.bench import sdf as bench


def test_bench_runs_and_fepre_agrees_with_vtk(capsys):
    assert bench.main(["--size", "24", "--repeat", "1"]) == 0
    out = capsys.readouterr().out
    for label in ("fepre values_on_axes", "vtkSampleFunction", "numpy copy", "speed-up over VTK", "agreement"):
        assert label in out
    model = bench.fepre_model()
    assert sum(1 for _ in model.walk()) >= 6


def test_vtk_model_is_the_fepre_model():
    size = 20
    sampler = bench.vtk_sampler(size)
    theirs = bench.vtk_values(sampler)
    axis = np.linspace(*bench.BOUNDS, size)
    ours = bench.fepre_model().values_on_axes(axis, axis, axis, dtype=np.float64).ravel()
    assert np.mean((ours < 0) == (theirs < 0)) > 0.999
    # vtkSphere and vtkCylinder are quadratic (r^2 - R^2), vtkBox a distance: where the box
    # decides (outside it, on the side away from the sphere) both give the same distance.
    x = np.broadcast_to(axis[None, None, :], (size,) * 3).ravel()
    box_side = (ours > 0) & (x < -1.2)
    assert box_side.sum() > 100
    np.testing.assert_allclose(ours[box_side], theirs[box_side], atol=1e-6)
