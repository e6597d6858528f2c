"""Cells of a region mesh: their region, cells that cross an interface, the per-region quality stage."""

from __future__ import annotations

import numpy as np

from .interface import ON_INTERFACE, interface_faces
from .partition import RegionSet

__all__ = ["cell_regions", "node_regions", "improve_regions", "region_quality_stage", "check_interfaces", "exposed_interface_faces",
           "final_region_mesh"]

#: Rounds of dropping the free nodes of cells that cross an interface and triangulating again.
REPAIR_ROUNDS = 6
#: Deepest centroid, in the face's longest edge, of a boundary face whose three nodes lie on a rim
#: (an interface and the part's surface): a chord across a wedge of a region thinner than that,
#: as a chord of a curved surface cuts off a cap. Deeper, a region's cell was removed.
RIM_CHORD_DEPTH = 0.25
#: Deepest centroid, in h, of a face on an interface with a cell on one side only that is kept
#: with a ResolutionWarning: a piece of a region thinner than that beyond it is not meshed, as the
#: plain mesh loses parts thinner than h. Deeper, a region's cells were removed (a MeshingError).
THIN_PIECE = 0.5
#: A feature node (not an interface node) of a cell crossing an interface is dropped before the
#: cell's free nodes when it lies within this (times h) of the interface.
FEATURE_DROP = 0.75


def node_regions(points: np.ndarray, regions: RegionSet, h: float) -> np.ndarray:
    """(N,) region of each node, -1 for a node on an interface (it belongs to both sides)."""
    owner = regions.region_of(points)
    owner[regions.on_interface(points, ON_INTERFACE * h)] = -1
    return owner


def cell_regions(points: np.ndarray, tets: np.ndarray, regions: RegionSet, h: float) -> tuple[np.ndarray, np.ndarray]:
    """Region of each cell and whether it crosses an interface, ``(region_ids, crossing)``.

    A cell belongs to the region of its nodes that are not on an interface; a cell whose nodes
    all lie on interfaces, to the region holding its centroid. A cell with nodes strictly inside
    two regions crosses an interface (``crossing``; its region is then one of the two).
    """
    owner = node_regions(points, regions, h)[tets]
    highest = owner.max(axis=1)
    lowest = np.where(owner >= 0, owner, len(regions.names)).min(axis=1)
    region_ids = highest.copy()
    on_interfaces = highest < 0
    if on_interfaces.any():
        region_ids[on_interfaces] = regions.region_of(points[tets[on_interfaces]].mean(axis=1))
    return region_ids, (highest >= 0) & (lowest != highest)


def final_region_mesh(model, points, fixed, h, geps, backend, previous, regions: RegionSet, kept: np.ndarray):
    """The final mesh of a region mesh: :func:`~fepre.distmesh.finalize.final_mesh`, then, while
    some cell has a node strictly inside another region than its own (it bridges a concave
    wedge where an interface meets the part's surface at a grazing angle, or joins a feature
    node of the part next to an interface), the node of each such cell nearest the interface is
    dropped and the points are triangulated again (a free node before a feature node). Nodes at
    the ``kept`` (K, 3) positions (the interface nodes and the user's fixed points) are never dropped.

    Returns ``points, tets, fixed, region_ids, dropped, crossing`` (the cells still crossing).
    """
    from scipy.spatial import cKDTree

    from ..distmesh.finalize import final_mesh

    kept_tree = cKDTree(kept) if len(kept) else None
    dropped = 0
    for repair in range(REPAIR_ROUNDS + 1):
        points, tets, fixed = final_mesh(model, points, fixed, h, geps, backend, previous)
        region_ids, crossing = cell_regions(points, tets, regions, h)
        if not crossing.any() or repair == REPAIR_ROUNDS:
            break
        droppable = ~fixed
        if kept_tree is not None and fixed.any():
            at_kept = kept_tree.query(points[fixed], distance_upper_bound=1e-9 * h)[0] <= 1e-9 * h
            droppable[np.flatnonzero(fixed)[~at_kept]] = True
        else:
            droppable |= fixed
        cells = tets[crossing]
        distance = regions.interface_distance(points[cells.ravel()])[0].reshape(cells.shape)
        # free nodes first; but a feature node of a piece of a region thinner than THIN_PIECE h (a
        # lip one voxel high where an inclusion pokes out of a block's face) before free nodes
        # farther from the interface: else each round drops a far node the next round replaces
        held = fixed[cells] & (distance > FEATURE_DROP * h)
        distance = np.where(droppable[cells], distance + np.where(held, 1e3 * h, 0.0), np.inf)
        nearest = cells[np.arange(len(cells)), np.argmin(distance, axis=1)]
        nearest = np.unique(nearest[droppable[nearest]])
        if nearest.size == 0:
            break
        keep = np.ones(len(points), dtype=bool)
        keep[nearest] = False
        points, fixed, previous = points[keep], fixed[keep], None
        dropped += nearest.size
    return points, tets, fixed, region_ids, dropped, crossing


def improve_regions(points, tets, region_ids, model, h, pinned, on_interface, seed, size=None, regions=None):
    """The quality stage on the whole mesh, each cell flipped only with cells of its region.

    The interface nodes are fixed and flips never join cells of two regions (the stage's
    ``labels``), so the faces between regions stay as they are (removing a flat cell on the
    part's surface may move the rim of an interface, never off the interface). Returns ``points,
    tets, region_ids`` (the stage may remove flat cells on the part's surface).
    """
    from ..distmesh.slivers import improve_arrays

    points, tets, info = improve_arrays(
        points, tets, model, h, fixed_mask=pinned | on_interface, size=size, seed=seed, labels=region_ids,
        node_regions=None if regions is None else (node_regions(points, regions, h), regions.region_of),
    )
    return points, tets, info["labels"]


def region_quality_stage(points, tets, region_ids, regions: RegionSet, model, h, pinned, on_interface, seed, size=None):
    """:func:`improve_regions`, then the interface nodes of cells still under the targets move
    along their interface (:func:`~fepre.regions.interface_smoothing.smooth_interface_nodes`)
    and the regions are improved once more. Only the last pass's warnings are shown."""
    import warnings

    from ..distmesh.tet_shape import ShapeTargets
    from .interface_smoothing import smooth_interface_nodes

    with warnings.catch_warnings(record=True) as first:
        warnings.simplefilter("always")
        points, tets, region_ids = improve_regions(points, tets, region_ids, model, h, pinned, on_interface, seed, size, regions)
    points, moves = smooth_interface_nodes(points, tets, region_ids, regions, model, h, ShapeTargets(), seed=seed, pinned=pinned)
    if not moves:
        shown = first
    else:
        with warnings.catch_warnings(record=True) as shown:
            warnings.simplefilter("always")
            points, tets, region_ids = improve_regions(points, tets, region_ids, model, h, pinned, on_interface, seed, size, regions)
    for record in shown:
        warnings.warn_explicit(record.message, record.category, record.filename, record.lineno)
    return points, tets, region_ids


def check_interfaces(points, tets, region_ids, regions: RegionSet, model, h) -> tuple[np.ndarray, np.ndarray]:
    """Check that regions meet only on interface faces and that those faces lie on the interfaces.

    Returns the interface faces and the pair of regions on either side of each. Raises
    ``MeshingError`` when a face between two regions has a node off the interface (more than
    ``ON_INTERFACE h``) or a face of the part's surface has all its nodes on an interface
    more than :data:`THIN_PIECE` h inside the part (a region's cell removed next to the interface).
    """
    from ..errors import MeshingError

    faces, first, second = interface_faces(tets, region_ids, len(points))
    on = regions.on_interface(points, ON_INTERFACE * h)
    off = ~on[faces].all(axis=1)
    if off.any():
        worst = faces[off][0]
        raise MeshingError(
            f"distmesh: {int(off.sum())} face(s) between regions have a node off the interface "
            f"(e.g. at {np.round(points[worst[~on[worst]][0]], 6).tolist()}); the interface is not resolved at h={h:g}"
        )
    exposed, depth = exposed_interface_faces(points, tets, model, h, on)
    deep = depth > THIN_PIECE * h
    if deep.any():
        where = np.round(points[exposed[deep][0]].mean(axis=0), 6).tolist()
        raise MeshingError(
            f"distmesh: {int(deep.sum())} face(s) on an interface have a cell on one side only (e.g. at {where}, "
            f"{depth[deep][0]:.3g} inside the part: a region's cells next to the interface were removed, where a "
            f"region is about one element thick); the interfaces are not resolved at h={h:g} (try a smaller h)")
    return faces, np.column_stack([region_ids[first], region_ids[second]])


def exposed_interface_faces(points, tets, model, h, on_interface: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Faces on an interface with a cell on one side only, and how deep inside the part each lies.

    A boundary face whose nodes all lie on an interface (``on_interface``, (N,) bool) and whose
    centroid lies more than 0.1 h inside the part, and deeper than a chord across a rim
    (:data:`RIM_CHORD_DEPTH`), exposes a piece of a region that is not meshed. Returns the (F, 3)
    faces and their centroids' (F,) depth below the part's surface.
    """
    from ..distmesh.topology import boundary_faces

    outer = boundary_faces(tets)
    outer = outer[on_interface[outer].all(axis=1)]
    depth = -np.asarray(model(points[outer].mean(axis=1)), np.float64)
    exposed = (depth > 0.1 * h) & (depth > _chord_depth(points, outer, model, h))
    return outer[exposed], depth[exposed]


def _chord_depth(points, faces, model, h) -> np.ndarray:
    """(F,) deepest centroid allowed for each face: :data:`RIM_CHORD_DEPTH` of its longest edge
    for a face whose nodes all lie on the part's surface (a chord across a rim), 0 otherwise."""
    corners = points[faces]
    longest = np.linalg.norm(corners - np.roll(corners, 1, axis=1), axis=2).max(axis=1)
    on_surface = (np.abs(np.asarray(model(corners.reshape(-1, 3)), np.float64)) <= ON_INTERFACE * h).reshape(-1, 3).all(axis=1)
    return np.where(on_surface, RIM_CHORD_DEPTH * longest, 0.0)
