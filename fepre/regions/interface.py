"""The interfaces between regions: their nodes before meshing, their faces after."""

from __future__ import annotations

import warnings

import numpy as np

from .partition import RegionSet

__all__ = ["interface_nodes", "interface_faces", "interface_node_mask", "ON_INTERFACE"]

#: A node lies on an interface when two regions' values are within this (times h) of zero.
ON_INTERFACE = 1e-3


def interface_nodes(model, regions: RegionSet, h: float, bounds, options) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Nodes and triangles of every interface between regions, about ``h`` apart.

    Each region but the last of :meth:`RegionSet.meshing_order` (smallest first) is meshed by
    DistMesh on its own (the part ``model & region``). Its fixed nodes are the interface nodes
    found so far that lie on it and the sharp features of the later regions' parts that lie on
    its interfaces with them (where a lattice meets a
    skin, the rim of each contact patch is a sharp edge of the lattice's part, not of the
    skin's). The boundary faces of its mesh on the interfaces with the later regions (nodes on
    both zero sets, centroid inside the model) are kept.

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
    parts = [model & region for region in regions.models]
    creases = [np.zeros((0, 3))] * len(parts)
    if options.features:
        for j in regions.meshing_order()[1:].tolist():
            creases[j] = detect_features(parts[j], h, angle=options.feature_angle, bounds=bounds, warn=False).nodes
    order = regions.meshing_order()
    for position, i in enumerate(order[:-1].tolist()):
        later = order[position + 1:]
        found = np.concatenate(nodes)
        fixed = found[np.asarray(parts[i](found)) <= tol] if len(found) else found
        for j in later.tolist():
            candidates = creases[j]
            if len(candidates) == 0:
                continue
            values = np.abs(regions.values(candidates))
            shared = (values[:, i] <= tol) & (values[:, j] <= tol) & (np.asarray(model(candidates)) <= tol)
            candidates = candidates[shared]
            if len(fixed) and len(candidates):
                candidates = candidates[cKDTree(fixed).query(candidates)[0] >= 0.5 * h]
            fixed = np.concatenate([fixed, candidates])
        fixed = np.unique(fixed, axis=0)
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")  # the whole mesh reports on itself
            try:
                mesh = distmesh(parts[i], h, bounds=bounds, fixed=fixed if len(fixed) else None,
                                options=options, check_resolution=False)
            except (MeshingError, ValueError) as exc:
                raise MeshingError(f"distmesh: region {regions.names[i]!r} could not be meshed to lay its interface nodes: {exc}") from exc
        points = np.asarray(mesh.points, dtype=np.float64)
        values = np.abs(regions.values(points))
        shared = (values[:, later].min(axis=1) <= tol) & (values[:, i] <= tol) & (np.asarray(model(points)) <= tol)
        faces = boundary_faces(np.asarray(mesh.cells_dict[10], dtype=np.int64))
        faces = faces[shared[faces].all(axis=1)]
        faces = faces[np.asarray(model(points[faces].mean(axis=1))) < -tol]
        nodes.append(points[np.unique(faces)])
        triangles.append(points[faces])
        inner.append(np.full(len(faces), i, dtype=np.int64))
    found, index = np.unique(np.concatenate(nodes), axis=0, return_index=True)
    return found[np.argsort(index)], np.concatenate(triangles), np.concatenate(inner)


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
