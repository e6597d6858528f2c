"""How thick each region is: the regions too thin for h, named when a region mesh fails.

A region mesh fails in many ways where a region is about one element thick (cells across an
interface, a region too small for its own mesh, a fixed node on the boundary); each message
names its own symptom. :func:`thin_regions_note` names the likely cause once: every region
whose thickest place is under two elements at h, how thick it is there, and the h that gives it
two elements across.
"""

from __future__ import annotations

import numpy as np

from .partition import CHECK_SAMPLES, RegionSet

__all__ = ["region_depths", "thin_regions_note"]


def region_depths(regions: RegionSet, model, lower, upper, h: float) -> list[tuple[float, np.ndarray]]:
    """Each region's deepest point inside the part: ``(depth, point)``, the radius of the largest
    ball in the region and the part (to a grid of spacing h/4 or coarser, up to
    ``CHECK_SAMPLES`` points per region), and its centre.

    Examples
    --------
    >>> from fepre import sdf
    >>> from fepre.regions.partition import RegionSet
    >>> slab, block = sdf.box((10.0, 10.0, 1.0), (0, 0, 0.5)), sdf.box((10.0, 10.0, 4.0), (0, 0, 3.0))
    >>> found = region_depths(RegionSet(("slab", "block"), (slab, block)), slab | block, (-5, -5, 0), (5, 5, 5), 1.0)
    >>> [round(depth, 2) for depth, _ in found]
    [0.5, 2.0]
    """
    found = []
    lower, upper = np.asarray(lower, dtype=np.float64), np.asarray(upper, dtype=np.float64)
    for region in regions.models:
        box_lower, box_upper = lower, upper
        if region.bounds is not None:
            box_lower = np.maximum(lower, np.asarray(region.bounds[0], dtype=np.float64))
            box_upper = np.minimum(upper, np.asarray(region.bounds[1], dtype=np.float64))
        extent = np.maximum(box_upper - box_lower, 0.0)
        spacing = max(0.25 * h, float((np.prod(extent) / CHECK_SAMPLES) ** (1 / 3)))
        axes = [np.arange(lo + spacing / 2, hi, spacing) if hi > lo else np.array([lo]) for lo, hi in zip(box_lower, box_upper)]
        grid = np.stack(np.meshgrid(*axes, indexing="ij"), axis=-1).reshape(-1, 3)
        values = np.maximum(np.asarray(region(grid), dtype=np.float64), np.asarray(model(grid), dtype=np.float64))
        deepest = int(np.argmin(values))
        found.append((max(0.0, -float(values[deepest])), grid[deepest]))
    return found


def thin_regions_note(regions: RegionSet, model, lower, upper, h: float, offset=None) -> str | None:
    """A sentence naming the regions less than two elements thick at ``h`` (their deepest place
    under ``h``) and the h that gives the thinnest two elements across, or None. ``offset``
    moves the places named to the user's frame."""
    depths = region_depths(regions, model, lower, upper, h)
    thin = sorted((depth, name, point) for (depth, point), name in zip(depths, regions.names) if depth < h)
    if not thin:
        return None
    shift = np.zeros(3) if offset is None else np.asarray(offset, dtype=np.float64)
    listed = "; ".join(f"{name!r} at most {2 * depth:.3g} thick (its thickest place at "
                       f"({', '.join(f'{c:.6g}' for c in point + shift)}))" for depth, name, point in thin[:6])
    more = f"; and {len(thin) - 6} more" if len(thin) > 6 else ""
    said = f"regions less than two elements thick at h={h:g}, which a region mesh often cannot follow: {listed}{more}"
    thinnest = thin[0][0]
    if thinnest <= 0.0:
        return said
    digits = 10.0 ** (np.floor(np.log10(thinnest)) - 2)
    enough = float(np.floor(thinnest / digits) * digits)  # three digits, rounded down: not listed again at it
    return (f"{said}; h <= {enough:.3g} gives the thinnest two elements across (or h=({enough:.3g}, {h:g}): that fine only "
            f"where it is needed)")
