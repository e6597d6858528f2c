"""Regions that face each other across a gap too narrow for the mesh, found before meshing.

Two solids of an assembly that do not touch (a sheet-metal box's plates stand 0.127 mm apart,
a clearance fit) leave a gap between their regions. A conformal mesh has no interface there:
where the gap is narrower than about h, DistMesh's cells bridge it from one region to the other
and the mesh fails after all its work, far from the cause. :func:`check_clearances` finds such
gaps on the regions' surfaces before any meshing and names them.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .partition import CHECK_SAMPLES, RegionSet, surface_model

__all__ = ["Clearance", "narrow_clearances", "check_clearances", "CLEARANCE", "CLEARANCE_AREA", "FACING"]

#: Two regions' faces this close (times h) and apart are bridged by the mesh: two boxes 0.6 h
#: apart failed ("cells cross an interface"), 0.8 h apart meshed as two pieces (h = 1).
CLEARANCE = 0.75
#: Faces face each other across a gap when their outward normals are within about 25 degrees of
#: opposite (cosine below minus this); a junction's faces (a pin standing on a plate) are not.
FACING = 0.9
#: A gap counts when it spans at least this area (times h squared): about two element faces.
CLEARANCE_AREA = 1.0
#: A point lies on a region's surface, not apart from it, within this (times h).
TOUCHING = 1e-3


@dataclass(frozen=True)
class Clearance:
    """A gap between two regions' faces: the pair, its median width, the area it spans and a place."""

    first: str
    second: str
    width: float
    area: float
    place: tuple[float, float, float]


def _splits_by_construction(regions: RegionSet, model) -> bool:
    """Whether the regions split the part without gaps by construction: each lies ``within`` it
    and is cut from one surface shared with its neighbours (a label image's,
    ``from_shared_surface``)."""
    return all(getattr(region, "within", None) is model and getattr(surface_model(region), "from_shared_surface", False)
               for region in regions.models)


def _surface_samples(regions: RegionSet, lower: np.ndarray, upper: np.ndarray, h: float):
    """Points on the regions' surfaces, about ``spacing`` apart: grid points near each surface,
    projected onto it. Returns ``points, owner, spacing``."""
    extent = np.asarray(upper, float) - np.asarray(lower, float)
    spacing = max(0.5 * h, float((np.prod(extent) / CHECK_SAMPLES) ** (1 / 3)))
    axes = [np.arange(lo + spacing / 2, hi, spacing) for lo, hi in zip(lower, upper)]
    grid = np.stack(np.meshgrid(*axes, indexing="ij"), axis=-1).reshape(-1, 3)
    values = regions.values(grid)
    points, owner = [np.zeros((0, 3))], [np.zeros(0, np.int64)]
    for k, region in enumerate(regions.models):
        near = grid[np.abs(values[:, k]) < 0.5 * spacing]  # a slab one spacing thick: one sample per spacing^2
        for _ in range(2):  # exact in one step for a distance; the second for a bound
            value, gradient = region.value_and_gradient(near)
            near = near - np.asarray(value)[:, None] * np.asarray(gradient)
        points.append(near)
        owner.append(np.full(len(near), k, dtype=np.int64))
    return np.concatenate(points), np.concatenate(owner), spacing


def narrow_clearances(regions: RegionSet, model, lower, upper, h: float) -> list[Clearance]:
    """The gaps narrower than ``CLEARANCE h`` between faces of two regions that face each other.

    A sample on one region's surface (and the part's) is in such a gap when the nearest other
    region is between ``TOUCHING h`` and ``CLEARANCE h`` away, its face there looks back
    (normals within ``FACING`` of opposite), and the middle of the gap lies in no region and
    outside the part. Gaps spanning less than ``CLEARANCE_AREA h^2`` are left out. Regions that
    split the part by construction (a label image's) are not sampled.

    Examples
    --------
    >>> from fepre import sdf
    >>> from fepre.regions.partition import RegionSet
    >>> a, b = sdf.box((4, 4, 4), (0, 0, 0)), sdf.box((4, 4, 4), (4.1, 0, 0))
    >>> gaps = narrow_clearances(RegionSet(("a", "b"), (a, b)), a | b, (-3, -3, -3), (7, 3, 3), 1.0)
    >>> [(g.first, g.second, round(g.width, 3)) for g in gaps]
    [('a', 'b', 0.1)]
    """
    if _splits_by_construction(regions, model):
        return []
    points, owner, spacing = _surface_samples(regions, lower, upper, h)
    if len(points) == 0:
        return []
    values = regions.values(points)
    values[np.arange(len(points)), owner] = np.inf
    other = np.argmin(values, axis=1)
    width = values[np.arange(len(points)), other]
    candidate = np.flatnonzero((width > TOUCHING * h) & (width < CLEARANCE * h))
    found: list[Clearance] = []
    if candidate.size == 0:
        return found
    facing = np.zeros(len(candidate), dtype=bool)
    middle = np.zeros((len(candidate), 3))
    for a in np.unique(owner[candidate]).tolist():
        for b in np.unique(other[candidate][owner[candidate] == a]).tolist():
            mine = np.flatnonzero((owner[candidate] == a) & (other[candidate] == b))
            p = points[candidate[mine]]
            normal = np.asarray(regions.models[a].value_and_gradient(p)[1])
            away = np.asarray(regions.models[b].value_and_gradient(p)[1])  # from the other region to p
            facing[mine] = (normal * away).sum(axis=1) < -FACING
            middle[mine] = p + 0.5 * width[candidate[mine], None] * normal
    # the gap is the part's: its middle outside the part and in no region, its faces on the
    # part's surface (two regions apart where the part does not reach them are no concern)
    on_part = np.asarray(model(points[candidate]), dtype=np.float64) <= TOUCHING * h
    in_gap = facing & on_part & (np.asarray(model(middle), dtype=np.float64) > 0.0) & (regions.values(middle).min(axis=1) > 0.0)
    chosen = candidate[in_gap]
    pairs = np.sort(np.column_stack([owner[chosen], other[chosen]]), axis=1)
    for a, b in np.unique(pairs, axis=0).tolist():
        mine = chosen[(pairs[:, 0] == a) & (pairs[:, 1] == b)]
        # the gap's area: the larger side's, as the grid cells its samples fall in (one per
        # spacing^2 of a face; a face between two layers of the grid is sampled twice)
        area = max(len(np.unique(np.floor(points[mine[owner[mine] == k]] / spacing), axis=0)) for k in (a, b)) * spacing**2
        if area < CLEARANCE_AREA * h * h:
            continue
        widths = width[mine]
        place = points[mine[np.argsort(widths)[len(widths) // 2]]]
        found.append(Clearance(regions.names[a], regions.names[b], float(np.median(widths)), area,
                               tuple(float(x) for x in place)))
    return sorted(found, key=lambda gap: -gap.area)


def check_clearances(regions: RegionSet, model, lower, upper, h: float) -> None:
    """A ValueError naming every pair of regions that face each other across a gap narrower
    than ``CLEARANCE h`` (:func:`narrow_clearances`), which no conformal mesh at ``h`` can keep
    open or join."""
    from ..arguments import shown

    gaps = narrow_clearances(regions, model, lower, upper, h)
    if not gaps:
        return
    listed = "; ".join(f"{g.first!r} and {g.second!r} {g.width:.4g} apart over an area of about {g.area:.3g} "
                       f"(e.g. at {shown(np.round(g.place, 6))})" for g in gaps[:6])
    more = f"; and {len(gaps) - 6} more pair(s)" if len(gaps) > 6 else ""
    narrowest = min(g.width for g in gaps)
    raise ValueError(
        f"regions face each other, apart, across gaps narrower than {CLEARANCE} h = {CLEARANCE * h:.4g} (a clearance, "
        f"or a thin wedge where two regions part): "
        f"{listed}{more}. A conformal mesh at h={h:.4g} would bridge them (it has no interface there). Close the gaps "
        f"in the model so that the solids share their faces, mesh the part without regions (CLI: without --solids; its "
        f"cells then fill the gaps and join the solids there), "
        f"or give h below {narrowest / CLEARANCE:.3g} (the narrowest gap / {CLEARANCE})")
