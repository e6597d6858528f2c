"""How long a DistMesh run has left: the loop's end from its quality trend, the stages after it
from the loop's own Delaunay time."""

from __future__ import annotations

import sys
import time

import numpy as np

__all__ = ["iterations_left", "seconds_after", "StageLog"]

#: what the stages after the loop cost, in units of one loop iteration's bar forces (a single-core
#: numpy pass over the bars, so a measure of this machine and this mesh's size); measured on a
#: sphere (1.5M cells: 62, 74, 10), a box with 20 holes (1.1M: 150, 80, 13) and a gyroid block
#: (550k: 260, 124, 22): the middles, so an estimate within about a factor of two
AFTER_LOOP = {"final mesh": 100.0, "quality stage": 85.0, "checks and output": 15.0}


def iterations_left(mean_quality, window: int, tol: float, maxiter: int) -> float | None:
    """Iterations the loop still needs by its quality criterion, or None while it cannot tell.

    The loop stops when the best mean volume-edge ratio of the last ``window`` iterations beats
    the best before them by less than ``tol`` (:class:`~fepre.distmesh.options.DistMeshOptions`).
    That gain shrinks about geometrically as the points settle: a line through the logarithm
    of the recent gains says where it falls under ``tol``.

    Examples
    --------
    >>> k = np.arange(25)
    >>> quality = 0.9 - 0.05 * np.exp(-k / 8)  # settles with a time constant of 8 iterations
    >>> round(iterations_left(quality, 10, 0.002, 1000))  # the criterion stops it at iteration 35
    9
    """
    quality = np.asarray(mean_quality, dtype=np.float64)
    done = len(quality)
    if done < window + 3:
        return None
    best = np.maximum.accumulate(quality)
    gains = (best[window:] - best[:-window])[-2 * window :]
    at = np.arange(done - len(gains), done, dtype=np.float64)
    floor = max(2 * window - done, 0)
    growing = gains > 0
    if gains[-1] < tol:
        return float(min(floor, maxiter - done))
    if growing.sum() < 3:
        return None
    slope, intercept = np.polyfit(at[growing], np.log(gains[growing]), 1)
    if slope >= 0:
        return None
    end = (np.log(tol) - intercept) / slope
    return float(np.clip(end - done + 1, floor, maxiter - done))


def seconds_after(stage: str | None, force_seconds: float) -> float:
    """Seconds the stages after ``stage`` will take (all of them for None), from the time of one
    iteration's bar forces."""
    names = list(AFTER_LOOP)
    following = names if stage is None else names[names.index(stage) + 1 :]
    return force_seconds * sum(AFTER_LOOP[name] for name in following)


class StageLog:
    """The progress lines of the stages after the loop: what each did, its time, the time left.

    Examples
    --------
    >>> import io
    >>> stream = io.StringIO()
    >>> log = StageLog(True, force_seconds=0.01, stream=stream)
    >>> log("final mesh", "9 nodes, 12 cells")
    >>> stream.getvalue().startswith("distmesh: final mesh: 9 nodes, 12 cells")
    True
    >>> "about 1 s left" in stream.getvalue()  # (85 + 15) x 0.01 s
    True
    """

    def __init__(self, enabled: bool, force_seconds: float, stream=None) -> None:
        self.enabled, self.force_seconds, self.stream = enabled, force_seconds, stream
        self.started = time.perf_counter()

    def __call__(self, stage: str, detail: str) -> None:
        now = time.perf_counter()
        seconds, self.started = now - self.started, now
        if not self.enabled:
            return
        left = seconds_after(stage, self.force_seconds)
        tail = f", about {left:.0f} s left" if stage != list(AFTER_LOOP)[-1] else ""
        stream = self.stream if self.stream is not None else sys.stderr
        stream.write(f"distmesh: {stage}: {detail} (this stage {seconds:.2f} s{tail})\n")
        stream.flush()
