"""The time left of a DistMesh run (issue 15): the loop's end from its quality trend, the stages after it."""

from __future__ import annotations

import doctest
import importlib
import io
import re

import numpy as np
import pytest

import fepre
from fepre import sdf
from fepre.distmesh.estimate import AFTER_LOOP, StageLog, iterations_left, seconds_after


def stop_of(quality: np.ndarray, window: int, tol: float) -> int:
    """The iteration at which the loop's quality criterion (one history) stops it."""
    for done in range(2 * window, len(quality) + 1):
        history = quality[:done]
        if max(history[-window:]) - max(history[:-window]) < tol:
            return done
    raise AssertionError("never stops")


@pytest.mark.parametrize("tau", [4.0, 8.0, 20.0])
def test_a_geometric_settling_is_predicted_to_the_iteration(tau):
    quality = 0.9 - 0.06 * np.exp(-np.arange(400) / tau)
    stop = stop_of(quality, 10, 0.002)
    for done in range(14, stop - 1, 3):
        left = iterations_left(quality[:done], 10, 0.002, 1000)
        assert left is not None and abs(done + left - stop) <= 1.5


def test_short_histories_stalls_and_maxiter():
    assert iterations_left(np.linspace(0.5, 0.6, 12), 10, 0.002, 1000) is None  # too short to tell
    flat = np.full(15, 0.8)
    assert iterations_left(flat, 10, 0.002, 1000) == 5  # no gain: stops once the window allows
    assert iterations_left(np.full(40, 0.8), 10, 0.002, 1000) == 0
    rising = 0.5 + 0.01 * np.arange(30)  # gains that do not shrink: cannot tell
    assert iterations_left(rising, 10, 0.002, 1000) is None
    slow = 0.9 - 0.3 * np.exp(-np.arange(30) / 200.0)  # the criterion would stop it near 400
    assert iterations_left(slow, 10, 0.002, 100) == 70  # never past maxiter


def test_stage_lines_say_what_is_left():
    stream = io.StringIO()
    log = StageLog(True, force_seconds=0.1, stream=stream)
    for stage in AFTER_LOOP:
        log(stage, "done")
    lines = stream.getvalue().splitlines()
    assert [line.split(":")[1].strip() for line in lines] == list(AFTER_LOOP)
    # the stage's own seconds, not the run's so far (a new user read "1.93 s" after "4.55 s" as elapsed)
    assert re.search(r"final mesh: done \(this stage \d+\.\d\d s, about \d+ s left\)$", lines[0])
    assert lines[0].endswith(f"about {seconds_after('final mesh', 0.1):.0f} s left)")
    assert seconds_after("final mesh", 0.1) == pytest.approx(0.1 * (AFTER_LOOP["quality stage"] + AFTER_LOOP["checks and output"]))
    assert "left" not in lines[-1]
    silent = io.StringIO()
    StageLog(False, 0.1, stream=silent)("final mesh", "x")
    assert silent.getvalue() == ""


def test_a_run_prints_each_stage_after_the_loop_with_the_time_left(capsys):
    mesh = fepre.distmesh(sdf.box((2.0, 1.0, 1.0)) - sdf.cylinder(0.3, 2.0), 0.15, progress=True)
    lines = [line for line in capsys.readouterr().err.replace("\r", "\n").splitlines() if line.startswith("distmesh:")]
    stages = [line.split(":")[1].strip() for line in lines if "iteration" not in line]
    assert stages == list(AFTER_LOOP)
    assert f"{mesh.n_cells:,} cells" in lines[-1]


def test_the_loop_line_adds_the_loop_and_the_stages_after_it():
    from fepre.distmesh.loop import _time_left
    from fepre.distmesh.options import DistMeshOptions

    options = DistMeshOptions()
    quality = 0.9 - 0.06 * np.exp(-np.arange(25) / 8.0)
    history = {"mean_quality": list(quality), "min_quality": list(quality - 0.5)}
    left = iterations_left(quality, options.quality_window, options.quality_tol, options.maxiter)
    text = _time_left(history, options, [0.5] * 25, force_seconds=0.01)
    assert text == f", about {left * 0.5 + seconds_after(None, 0.01):.0f} s left"
    assert _time_left({"mean_quality": [0.5] * 5, "min_quality": [0.1] * 5}, options, [0.5] * 5, 0.01) == ""
    assert _time_left(history, DistMeshOptions(termination="displacement"), [0.5] * 25, 0.01) == ""


@pytest.mark.parametrize("name", ["fepre.distmesh.estimate", "fepre.distmesh.delaunay"])
def test_docstring_examples_run(name):
    result = doctest.testmod(importlib.import_module(name))
    assert result.failed == 0 and result.attempted > 0
