"""The interfaces between regions: their nodes before meshing, their faces after."""

from __future__ import annotations

import dataclasses
import sys
import warnings

import numpy as np

from .partition import RegionSet

__all__ = ["interface_nodes", "interface_faces", "interface_node_mask", "onto_rim", "onto_interface_rim", "ON_INTERFACE", "RIM_ANGLE"]

#: A node lies on an interface when two regions' values are within this (times h) of zero.
ON_INTERFACE = 1e-3
#: Crease angle (degrees) down to which the curves where an interface meets the part's surface
#: get nodes of their own (the part's sharp features use the mesher's ``feature_angle``).
RIM_ANGLE = 10.0
#: Interface nodes this close (times h) under the part's surface are moved onto it (0.05 left a
#: node 0.07 h under a crop's face, where an interface met it at a shallow angle, on the whole
#: mesh's boundary: a fixed node off the zero set).
RIM_SNAP = 0.1
#: Rounds of the projections onto the rims of a pair's two regions in turn (a junction node)
RIM_ALTERNATIONS = 3


def interface_nodes(model, regions: RegionSet, h: float, bounds, options, progress: bool = False,
                    part_features=None, size=None) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Nodes and triangles of every interface between regions, about ``h`` apart.

    Each region but the last of :meth:`RegionSet.meshing_order` (smallest first) is meshed by
    DistMesh on its own (the part ``model & region``). Its fixed nodes are the interface nodes
    found so far that lie on it and the sharp features of the later regions' parts that lie on
    its interfaces with them (where a lattice meets a
    skin, the rim of each contact patch is a sharp edge of the lattice's part, not of the
    skin's). The boundary faces of its mesh on the interfaces with the later regions (nodes on
    both zero sets, centroid inside the model) are kept. With ``size`` (the whole mesh's
    relative size function, for a graded mesh) each region's own mesh is graded by it too, so
    the interfaces are laid at the sizes the cells beside them get. The rims (the creases where an
    interface meets the part's surface) are laid with ``features=False`` too: they bound the
    interface, and where one runs along a concave edge of the part (a shaft leaving a hub)
    without nodes on it, the cells there bridged the edge from one region's face to the other's.

    Returns
    -------
    nodes : (K, 3) float64
    triangles : (F, 3, 3) float64, oriented out of their region
    inner : (F,) int64, the region each triangle bounds
    """
    from scipy.spatial import cKDTree

    from ..distmesh.mesher import distmesh
    from ..distmesh.topology import boundary_faces
    from ..errors import MeshingError
    from ..features import features as detect_features

    nodes, triangles, inner = [np.zeros((0, 3))], [np.zeros((0, 3, 3))], [np.zeros(0, np.int64)]
    tol = ON_INTERFACE * h
    # a region that lies in the part by construction (a label image's region in its own part,
    # ``within``) is its own part: the intersection would double every evaluation, and the
    # feature search samples each part on a grid of h/4 (most of a label image's meshing time)
    parts = [region if getattr(region, "within", None) is model else model & region for region in regions.models]
    creases = [np.zeros((0, 3))] * len(parts)
    for j in range(len(parts)):
        # a rim (interface meeting the part's surface) is kept however shallow its crease
        found_j = detect_features(parts[j], h, angle=min(RIM_ANGLE, options.feature_angle), bounds=bounds, warn=False)
        creases[j] = _corners_first(found_j.corners, found_j.nodes)
        if not options.features:
            creases[j] = creases[j][np.abs(np.asarray(model(creases[j]))) <= tol] if len(creases[j]) else creases[j]
    if options.features:
        if part_features is None:
            part_features = detect_features(model, h, angle=options.feature_angle, bounds=bounds, warn=False)
        part_features = _corners_first(part_features.corners, part_features.nodes)
    else:
        part_features = np.zeros((0, 3))
    order = regions.meshing_order()
    # each region's own DistMesh keeps as features the creases down to RIM_ANGLE, as the nodes
    # fixed on them above are: a label image's flat cap meets its rod's side at a crease of 18
    # degrees between triangles (the rest of the 90 rounded over a voxel), and with the nodes
    # on it fixed but no feature curve there, a free node sat on the rounding 0.09 h under the
    # cap (256^3 speed phantom: the rod's worst angle 20.1 -> 22.5, the block's 25.3 -> 26.9)
    own_options = dataclasses.replace(options, feature_angle=min(RIM_ANGLE, options.feature_angle))
    for position, i in enumerate(order[:-1].tolist()):
        later = order[position + 1:]
        found = np.concatenate(nodes)
        laid = found[np.asarray(parts[i](found)) <= tol] if len(found) else found
        extra = [np.zeros((0, 3))]
        for j in [i] + later.tolist():
            candidates = creases[j]
            if len(candidates) == 0:
                continue
            values = np.abs(regions.values(candidates))
            shared = (values[:, i] <= tol) & (values[:, later].min(axis=1) <= tol) & (np.asarray(model(candidates)) <= tol)
            if j == i:  # the region's own shallow creases: only those on a rim
                shared &= np.abs(np.asarray(model(candidates))) <= tol
            extra.append(candidates[shared])
        # the whole part's own sharp features on this region's boundary (an edge of a skin's
        # inner face between patches where a lattice touches it), so the whole mesh keeps them
        if len(part_features):
            extra.append(part_features[np.abs(np.asarray(parts[i](part_features))) <= tol])
        extra = np.concatenate(extra)
        extra = extra[np.sort(np.unique(extra, axis=0, return_index=True)[1])]  # first copy, order kept
        if len(laid) and len(extra):
            extra = extra[cKDTree(laid).query(extra)[0] >= 0.5 * h]
        fixed = np.concatenate([laid, _thinned(extra, 0, 0.5 * h)])
        if progress:
            sys.stderr.write(f"distmesh: region {regions.names[i]!r} meshed on its own to lay its interfaces ...\n")
            sys.stderr.flush()
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")  # the whole mesh reports on itself
            try:
                mesh = distmesh(parts[i], h, bounds=bounds, fixed=fixed if len(fixed) else None, size=size,
                                options=own_options, check_resolution=False)
            except (MeshingError, ValueError) as exc:
                raise MeshingError(f"distmesh: region {regions.names[i]!r} could not be meshed to lay its interface nodes: {exc}") from exc
        points = np.array(mesh.points, dtype=np.float64)
        for j in later.tolist():
            points = snap_to_rims(points, model, regions, (i, j), h)
        values = np.abs(regions.values(points))
        shared = (values[:, later].min(axis=1) <= tol) & (values[:, i] <= tol) & (np.asarray(model(points)) <= tol)
        faces = boundary_faces(np.asarray(mesh.cells_dict[10], dtype=np.int64))
        faces = faces[shared[faces].all(axis=1)]
        faces = faces[np.asarray(model(points[faces].mean(axis=1))) < -tol]
        nodes.append(points[np.unique(faces)])
        triangles.append(points[faces])
        inner.append(np.full(len(faces), i, dtype=np.int64))
        if progress:
            sys.stderr.write(f"distmesh: {len(faces)} interface triangles, {len(np.unique(faces))} nodes\n")
            sys.stderr.flush()
    found, index = np.unique(np.concatenate(nodes), axis=0, return_index=True)
    return found[np.argsort(index)], np.concatenate(triangles), np.concatenate(inner)


def _corners_first(corners: np.ndarray, nodes: np.ndarray) -> np.ndarray:
    """Feature nodes with the corners first, so that thinning keeps a corner over a curve node."""
    if len(corners) == 0 or len(nodes) == 0:
        return np.concatenate([corners.reshape(-1, 3), nodes.reshape(-1, 3)])
    from scipy.spatial import cKDTree

    others = nodes[cKDTree(corners).query(nodes)[0] > 0.0]
    return np.concatenate([corners, others])


def _thinned(points: np.ndarray, keep_first: int, spacing: float) -> np.ndarray:
    """``points`` without those closer than ``spacing`` to a point kept before them (the first
    ``keep_first`` always stay): creases found on several parts, or a curve's end next to a
    corner, would otherwise make interface triangles a fraction of ``h`` wide."""
    from scipy.spatial import cKDTree

    if len(points) < 2:
        return points
    pairs = cKDTree(points).query_pairs(spacing, output_type="ndarray")
    if len(pairs) == 0:
        return points
    keep = np.ones(len(points), dtype=bool)
    for a, b in np.sort(pairs, axis=1)[np.lexsort((pairs.max(axis=1), pairs.min(axis=1)))].tolist():
        if keep[a] and keep[b] and b >= keep_first:  # a few pairs: the near-coincident creases
            keep[b] = False
    return points[keep]


def onto_rim(points: np.ndarray, model, region, h: float) -> tuple[np.ndarray, np.ndarray]:
    """Gauss-Newton steps of ``points`` onto the curve where the zero sets of ``model`` and
    ``region`` meet (the smallest step satisfying both, linearised); returns the points and
    whether each reached the curve (both values within ``1e-6 h``)."""
    moved = points.copy()
    for _ in range(12):
        f1, g1 = model.value_and_gradient(moved)
        f2, g2 = region.value_and_gradient(moved)
        a11, a12, a22 = (g1 * g1).sum(axis=1), (g1 * g2).sum(axis=1), (g2 * g2).sum(axis=1)
        det = a11 * a22 - a12 * a12
        det = np.where(np.abs(det) > 1e-12 * np.maximum(a11 * a22, 1e-300), det, np.inf)  # parallel: no curve
        c1 = (a22 * f1 - a12 * f2) / det
        c2 = (a11 * f2 - a12 * f1) / det
        moved = moved - c1[:, None] * g1 - c2[:, None] * g2
    reached = (np.abs(np.asarray(model(moved))) <= 1e-6 * h) & (np.abs(np.asarray(region(moved))) <= 1e-6 * h)
    return moved, reached


def onto_interface_rim(points: np.ndarray, model, regions: RegionSet, pair: tuple[int, int], h: float):
    """``points`` moved onto the rim of the interface between regions ``pair``: the curve where
    it meets the part's surface. :func:`onto_rim` with each region of the pair in turn (one of
    them, a part minus an insert say, is zero on the whole surface of the part, so alone it does
    not pin the curve); returns the points and whether each reached the rim (the part's zero set
    and both regions' to ``1e-6 h``)."""
    moved = points.copy()
    reached = np.zeros(len(points), dtype=bool)
    for k in pair:
        todo = np.flatnonzero(~reached)
        if todo.size == 0:
            break
        candidate, ok = onto_rim(points[todo], model, regions.models[k], h)
        values = np.abs(regions.values(candidate)[:, list(pair)])
        ok &= (values <= 1e-6 * h).all(axis=1)
        moved[todo[ok]] = candidate[ok]
        reached[todo[ok]] = True
    # a node on a line where three regions meet (a label image's junction, cut by its crop's
    # face) reaches, by one region's rim, the rim of that region with the third: the two rims in
    # turn put it where they cross, the pair's rim's end (a 1 mm crop of the MNI brain: a
    # junction node 0.003 h under the face stayed there, and the final mesh had it on its boundary)
    todo = np.flatnonzero(~reached)
    candidate = points[todo]
    for _ in range(RIM_ALTERNATIONS if todo.size else 0):
        for k in pair:
            candidate, _ = onto_rim(candidate, model, regions.models[k], h)
        values = np.abs(regions.values(candidate)[:, list(pair)])
        ok = (values <= 1e-6 * h).all(axis=1) & (np.abs(np.asarray(model(candidate))) <= 1e-6 * h)
        moved[todo[ok]] = candidate[ok]
        reached[todo[ok]] = True
        todo, candidate = todo[~ok], candidate[~ok]
        if todo.size == 0:
            break
    return moved, reached


def snap_to_rims(points: np.ndarray, model, regions: RegionSet, pair: tuple[int, int], h: float) -> np.ndarray:
    """``points`` with the nodes on the interface between regions ``pair`` that lie just inside
    the part (within ``RIM_SNAP h`` of its surface) moved onto the interface's rim.

    A region's own DistMesh leaves its surface nodes next to that curve a little off it; in the
    whole part's mesh such a node would sit just under the surface and make flat cells. A node is
    moved only if it reaches the rim within ``RIM_SNAP h`` of where it was."""
    values = np.asarray(model(points))
    on = (np.abs(regions.values(points)[:, list(pair)]) <= ON_INTERFACE * h).all(axis=1)
    near = np.flatnonzero((values < 0) & (values > -RIM_SNAP * h) & on)
    if near.size == 0:
        return points
    moved, reached = onto_interface_rim(points[near], model, regions, pair, h)
    snapped = reached & (np.linalg.norm(moved - points[near], axis=1) <= RIM_SNAP * h)
    points[near[snapped]] = moved[snapped]
    return points


def interface_faces(tets: np.ndarray, region_ids: np.ndarray, n_points: int):
    """Faces shared by cells of two regions.

    Returns
    -------
    faces : (F, 3) int64, oriented out of the first cell
    first, second : (F,) int64, the cells on either side (``region_ids[first] < region_ids[second]``)
    """
    from ..distmesh.tet_topology import FACE_OF_TET, face_neighbours

    neighbours = face_neighbours(tets, n_points)
    cell, local = np.nonzero(neighbours >= 0)
    other = neighbours[cell, local]
    keep = region_ids[cell] < region_ids[other]
    cell, local, other = cell[keep], local[keep], other[keep]
    return tets[cell[:, None], FACE_OF_TET[local]], cell, other


def interface_node_mask(tets: np.ndarray, region_ids: np.ndarray, n_points: int) -> np.ndarray:
    """(N,) bool: the node lies on a face between two regions."""
    faces, _, _ = interface_faces(tets, region_ids, n_points)
    mask = np.zeros(n_points, dtype=bool)
    mask[faces.ravel()] = True
    return mask
