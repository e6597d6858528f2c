"""Material of the model that a mesh left out: walls, fins and pins thinner than ``h`` resolves.

DistMesh keeps a cell when its centroid is inside, so a wall thinner than about ``h`` comes out
thinner, perforated or not at all, without any error. :func:`lost_material` finds such places
independently of how the mesh was made: it samples the model at ``h / 4`` near its surface
(a narrow band), probes the mesh at the nodes clearly inside the model (deeper than ``0.1 h``, below
the chord sag of a convex surface of radius ``h`` or more) with VTK's probe filter, and groups the
nodes that no cell holds into connected regions. Each region reports where it is, how thick the
material there is (twice the deepest value of the model in it: exact for an exact distance) and
about how much volume is missing (the grid cells of its nodes, each counted by the share of it
inside the model, from the node's value; the shallow nodes next to the region included).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

__all__ = ["LostRegion", "lost_material", "lost_material_message"]

#: nodes at least this deep (times h) must be in the mesh
_DEPTH = 0.1
#: grid spacing (times h)
_SPACING = 0.25
#: a region is reported from this many lost deep nodes (an eighth of h^3 at h/4)
_MIN_NODES = 8
#: largest number of grid nodes sampled; coarser spacing beyond it
_MAX_NODES = 16_000_000


@dataclass(frozen=True)
class LostRegion:
    """A connected piece of the model that the mesh does not cover.

    Attributes
    ----------
    center : (3,) tuple of float
        Centroid of the region's lost sample nodes.
    thickness : float
        About how thick the model is there (twice the deepest value of the model in the region).
    volume : float
        About how much of the model's volume is missing there (world units cubed).
    """

    center: tuple[float, float, float]
    thickness: float
    volume: float


def lost_material(model, points: np.ndarray, tets: np.ndarray, h: float) -> list[LostRegion]:
    """The regions of ``model`` (deeper than ``0.1 h``) that no tetrahedron covers, largest first.

    Examples
    --------
    >>> from fepre import sdf, distmesh
    >>> import warnings
    >>> fin = sdf.box((8, 8, 2)) | sdf.box((0.5, 8, 6)).translate((2, 0, 3))   # a 0.5 thick fin
    >>> with warnings.catch_warnings():
    ...     warnings.simplefilter("ignore")
    ...     mesh = distmesh(fin, 1.0)
    >>> region = lost_material(fin, mesh.points, mesh.cells_dict[10], 1.0)[0]
    >>> round(region.thickness, 2)
    0.5
    """
    import pyvista as pv
    from scipy import ndimage

    from ..sampling import sample

    points = np.asarray(points, dtype=np.float64)
    lower, upper = points.min(axis=0) - h, points.max(axis=0) + h
    if model.bounds is not None:
        lower = np.minimum(lower, np.asarray(model.bounds[0], float) - h)
        upper = np.maximum(upper, np.asarray(model.bounds[1], float) + h)
    spacing = _SPACING * h
    extent = upper - lower
    count = np.prod(np.ceil(extent / spacing) + 1)
    if count > _MAX_NODES:
        spacing *= float((count / _MAX_NODES) ** (1.0 / 3.0))
    grid = sample(model, spacing=spacing, bounds=(tuple(lower), tuple(upper)), dtype="float64", band=h)
    values = np.asarray(grid["sdf"]).reshape(grid.dimensions[::-1])  # (nz, ny, nx)
    step = np.asarray(grid.spacing, float)
    origin = np.asarray(grid.origin, float)
    # the share of each node's cell of the grid inside the model, from its distance
    spacing_mean = float(np.cbrt(np.prod(step)))
    weight = np.clip(0.5 - values / spacing_mean, 0.0, 1.0)
    inside = weight > 0.0
    deep = values < -_DEPTH * h
    if not deep.any():
        return []

    cells = pv.UnstructuredGrid({pv.CellType.TETRA: np.asarray(tets, dtype=np.int64)}, points)
    cells.point_data["_probe"] = np.zeros(len(points))

    def uncovered(mask: np.ndarray) -> np.ndarray:
        k, j, i = np.nonzero(mask)
        probe = pv.PolyData(origin + np.column_stack([i, j, k]) * step)
        valid = np.asarray(probe.sample(cells)["vtkValidPointMask"]).astype(bool)
        out = np.zeros_like(mask)
        out[k[~valid], j[~valid], i[~valid]] = True
        return out

    lost_deep = uncovered(deep)
    if lost_deep.sum() < _MIN_NODES:
        return []
    # the shallow inside nodes next to lost deep ones belong to the same lost material
    near = ndimage.binary_dilation(lost_deep, iterations=2) & inside & ~deep
    lost = lost_deep | (uncovered(near) if near.any() else near)
    labels, count = ndimage.label(lost, structure=np.ones((3, 3, 3), bool))
    regions = []
    for label in range(1, count + 1):
        member = labels == label
        if (member & lost_deep).sum() < _MIN_NODES:
            continue
        k, j, i = np.nonzero(member)
        center = origin + np.array([i.mean(), j.mean(), k.mean()]) * step
        thickness = -2.0 * float(values[member].min())
        volume = float(weight[member].sum() * np.prod(step))
        regions.append(LostRegion(tuple(float(c) for c in center), thickness, volume))
    regions.sort(key=lambda region: -region.volume)
    return regions


def lost_material_message(regions: list[LostRegion], h: float) -> str:
    """One line naming the largest lost regions and the ``h`` that would mesh them."""

    def place(region: LostRegion) -> str:
        center = ", ".join(f"{c:.4g}" for c in region.center)
        return f"about {region.volume:.3g} near ({center}), {region.thickness:.3g} thick"

    total = sum(region.volume for region in regions)
    shown = "; ".join(place(region) for region in regions[:3])
    more = f" and {len(regions) - 3} more" if len(regions) > 3 else ""
    thinnest = min(region.thickness for region in regions[:3])
    return (
        f"the mesh leaves out about {total:.3g} (volume) of the model where it is thinner than "
        f"h = {h:g} resolves: {shown}{more}; mesh with h <= {thinnest:.2g} (or a size field that "
        "is that fine there) to keep it"
    )
