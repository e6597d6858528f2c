"""Mesh corpus parts and judge each mesh against fepre's quality and volume targets."""

from __future__ import annotations

import time
import warnings
from dataclasses import dataclass, field

import numpy as np

from .generate import CorpusPart
from .validate import MeshCheck, check_mesh, monte_carlo_volume

__all__ = ["PartResult", "true_volume", "mesh_part", "judge", "TARGETS"]

#: worst dihedral (deg), largest dihedral (deg), smallest radius ratio
TARGETS = (25.0, 150.0, 0.25)
#: volume error allowed on resolvable parts with flat faces only (their boundary is exact) and
#: walls at least 2 h thick
POLYHEDRAL_VOLUME = 0.005
#: volume error above which an unresolvable part must have said where it lost or added material
SILENT_LOSS = 0.02


@dataclass
class PartResult:
    """A part's mesh, as the independent check saw it, and the verdict."""

    part: CorpusPart
    check: MeshCheck | None
    seconds: float
    volume_error: float  # relative, against the true volume
    warnings: list[str] = field(default_factory=list)  # warning class names
    failures: list[str] = field(default_factory=list)
    error: str | None = None  # the exception, when meshing failed

    @property
    def passed(self) -> bool:
        return self.error is None and not self.failures


def true_volume(part: CorpusPart, samples: int = 400_000) -> float:
    """The part's volume: from its construction, else by Monte Carlo in its bounds."""
    if part.volume is not None:
        return part.volume
    lower, upper = (np.asarray(b, float) for b in part.model.bounds)
    return monte_carlo_volume(part.model, lower, upper, samples)[0]


def mesh_part(part: CorpusPart, volume: float | None = None, **options) -> PartResult:
    """Mesh ``part`` with :func:`fepre.distmesh` (default options) and judge the result."""
    from ..distmesh import distmesh

    volume = true_volume(part) if volume is None else volume
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        start = time.perf_counter()
        try:
            mesh = distmesh(part.model, part.h, **options)
        except Exception as exc:  # a corpus run reports every failure, it does not stop
            return PartResult(part, None, time.perf_counter() - start, float("nan"), [], [], f"{type(exc).__name__}: {exc}")
        seconds = time.perf_counter() - start
    names = sorted({w.category.__name__ for w in caught})
    check = check_mesh(np.asarray(mesh.points), mesh.cells_dict[10], part.model, part.h)
    result = PartResult(part, check, seconds, check.volume / volume - 1.0, names)
    result.failures = judge(part, check, result.volume_error, names)
    return result


def judge(part: CorpusPart, check: MeshCheck, volume_error: float, warned: list[str]) -> list[str]:
    """The targets a mesh misses: validity always; the three shape targets and (flat faces and
    walls of 2 h or more only) the volume on resolvable parts; components where known; on the other parts with flat
    faces, no volume lost or added above 2% without a ResolutionWarning."""
    failures = list(check.problems)
    if part.resolvable:
        low, high, ratio = TARGETS
        if check.min_dihedral < low:
            failures.append(f"worst dihedral {check.min_dihedral:.1f} < {low:g}")
        if check.max_dihedral > high:
            failures.append(f"largest dihedral {check.max_dihedral:.1f} > {high:g}")
        if check.min_radius_ratio < ratio:
            failures.append(f"radius ratio {check.min_radius_ratio:.3f} < {ratio:g}")
        if part.polyhedral and part.min_wall >= 2.0 and abs(volume_error) > POLYHEDRAL_VOLUME:
            failures.append(f"volume error {100 * volume_error:+.2f}%")
    elif part.polyhedral and abs(volume_error) > SILENT_LOSS and "ResolutionWarning" not in warned:
        # (a curved surface's chords lose volume at a coarse h, h^2 / (8 R) deep, by design)
        change = "lost" if volume_error < 0 else "added"
        failures.append(f"{change} {100 * abs(volume_error):.1f}% of the volume without a ResolutionWarning")
    if part.components is not None and check.components != part.components:
        failures.append(f"{check.components} components, not {part.components}")
    return failures
