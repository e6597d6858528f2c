"""Named regions that split a part: their values, the region of a point, the checks on them."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

__all__ = ["RegionSet", "region_set", "OVERLAP_DEPTH", "CHECK_SAMPLES"]
#: Two regions overlap where both are more negative than this (times h); a point of the part
#: deeper than this is uncovered when no region holds it.
OVERLAP_DEPTH = 0.05
#: Largest number of grid samples of the coverage check.
CHECK_SAMPLES = 300_000


@dataclass(frozen=True)
class RegionSet:
    """The regions of ``distmesh(..., regions=)``: names and signed distance functions.

    Attributes
    ----------
    names : tuple of str
        Region names, in the order given (solver-safe set names).
    models : tuple of fepre.sdf.SDF
        Each region's model (negative inside); only its part inside the meshed model counts.
    """

    names: tuple[str, ...]
    models: tuple[Any, ...]
    #: each region's share of the part's volume, as sampled by the checks (sums to 1)
    shares: tuple[float, ...] = ()

    def meshing_order(self) -> np.ndarray:
        """Regions from the smallest share of the part to the largest: the interfaces are laid
        out by meshing the regions in this order (a small insert or lattice first, so its convex
        edges get its own DistMesh surface and the region around it wraps around them)."""
        shares = np.asarray(self.shares if self.shares else np.ones(len(self.names)))
        return np.argsort(shares, kind="stable")

    def values(self, points: np.ndarray) -> np.ndarray:
        """(N, K) value of every region at every point."""
        return np.column_stack([np.asarray(model(points), dtype=np.float64) for model in self.models])

    def region_of(self, points: np.ndarray) -> np.ndarray:
        """(N,) index of the region holding each point (the one of least value)."""
        return np.argmin(self.values(points), axis=1)

    def interface_distance(self, points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Distance of each point to the boundary of its region with another region, and that
        other region's index: the value of the region second to hold the point."""
        values = self.values(points)
        order = np.argsort(values, axis=1)[:, :2]
        other = order[:, 1]
        return values[np.arange(len(points)), other], other

    def on_interface(self, points: np.ndarray, tol: float) -> np.ndarray:
        """(N,) bool: the point lies on the zero sets of two regions (within ``tol``)."""
        values = np.sort(np.abs(self.values(points)), axis=1)
        return values[:, 1] <= tol


def check_regions(regions: Any) -> None:
    """Check that ``regions`` maps at least two solver-safe names to 3D SDFs (TypeError or
    ValueError naming what is wrong), before any work that uses them."""
    from ..arguments import check_names
    from ..sdf.core import SDF

    if not isinstance(regions, dict):
        raise TypeError(f"regions must be a dict of names to fepre SDFs (e.g. {{'skin': ..., 'core': ...}}); got {type(regions).__name__}")
    if len(regions) < 2:
        got = f"{len(regions)} region"
        raise ValueError(f"regions must be a dict of at least two names to fepre SDFs (e.g. {{'skin': ..., 'core': ...}}); got {got}")
    check_names(list(regions), "regions")
    for name, region in regions.items():
        if not isinstance(region, SDF) or region.dim != 3:
            raise TypeError(f"regions[{name!r}] must be a 3D fepre.sdf.SDF; got {type(region).__name__}")


def surface_model(region):
    """The mesh model under a region ``within`` its part (a label image's, an assembly's solid),
    through the translation that moves it into the local frame of a part far from the origin;
    the region itself when it has none."""
    while not hasattr(region, "volume") and len(getattr(region, "children", ())) == 1:
        region = region.children[0]
    return region


def _own_volume(region) -> float:
    """The volume of a region ``within`` its part: its mesh model's."""
    return float(surface_model(region).volume)


def region_set(regions: Any, model, h: float, lower: np.ndarray, upper: np.ndarray) -> RegionSet:
    """The checked regions of ``distmesh(..., regions=)``.

    ``regions`` maps at least two names to 3D SDFs. They must not overlap inside the part and
    must cover it: both are checked on a grid over the bounds (spacing about ``h/2``, at most
    ``CHECK_SAMPLES`` points) to ``OVERLAP_DEPTH h``.
    """
    check_regions(regions)
    names = list(regions)
    found = RegionSet(tuple(names), tuple(regions.values()))
    if all(getattr(region, "within", None) is model for region in regions.values()):
        # a label image's regions in their own part: one shared surface splits it, without gaps
        # or overlaps, by construction (sdf.labels); sampling all of them at h/2 to check it was
        # 12 of 75-110 s of a 256^3 image's mesh. The shares (the meshing order) are their volumes.
        volumes = np.array([_own_volume(region) for region in regions.values()])
        return RegionSet(found.names, found.models, tuple((volumes / volumes.sum()).tolist()))

    extent = upper - lower
    spacing = max(0.5 * h, float((np.prod(extent) / CHECK_SAMPLES) ** (1 / 3)))
    axes = [np.linspace(lo, hi, max(2, int(np.ceil((hi - lo) / spacing)) + 1)) for lo, hi in zip(lower, upper)]
    grid = np.stack(np.meshgrid(*axes, indexing="ij"), axis=-1).reshape(-1, 3)
    depth = OVERLAP_DEPTH * h
    grid = grid[np.asarray(model(grid)) < -depth]
    if len(grid) == 0:
        return found
    values = found.values(grid)
    holding = values < -depth
    overlap = holding.sum(axis=1) > 1
    if overlap.any():
        first = int(np.argmax(overlap))
        both = [names[k] for k in np.flatnonzero(holding[first])]
        raise ValueError(
            f"regions {both[0]!r} and {both[1]!r} overlap inside the part (both hold {np.round(grid[first], 6).tolist()}, "
            f"{int(overlap.sum())} of {len(grid)} samples held twice); give regions that split the part "
            f"(e.g. core = inner, skin = part - inner)"
        )
    uncovered = (values > depth).all(axis=1)
    if uncovered.any():
        first = int(np.argmax(uncovered))
        raise ValueError(
            f"regions leave part of the model uncovered: {np.round(grid[first], 6).tolist()} is inside the "
            f"model but in no region ({int(uncovered.sum())} of {len(grid)} samples); give regions whose "
            f"union holds the whole part"
        )
    counts = np.bincount(np.argmin(values, axis=1), minlength=len(names))
    empty = [names[k] for k in np.flatnonzero(counts == 0)]
    if empty:
        raise ValueError(
            f"regions {', '.join(map(repr, empty))} hold no part of the model (no sample of the part, "
            f"{spacing:.3g} apart, lies in them); give regions inside the model, or a smaller h for a thin one"
        )
    return RegionSet(found.names, found.models, tuple((counts / counts.sum()).tolist()))
