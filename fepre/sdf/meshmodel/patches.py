"""Smooth pieces of a triangle surface, split at its sharp edges.

A CAD part's STL keeps its sharp edges as edges between triangles whose normals differ by a large
angle; a tessellated cylinder's facets differ by a few degrees. Cutting the surface at edges
sharper than ``angle`` (and at boundary and non-manifold edges) leaves its smooth pieces: the
"patches" that :func:`fepre.features` finds creases and corners between, as it does for the
primitives of a CSG model.
"""

from __future__ import annotations

import threading

import numpy as np
from scipy import sparse
from scipy.sparse import csgraph

from .bvh import TriangleTree
from .tables import edge_table, manifold_pairs

__all__ = ["segment_patches", "PatchPlanes"]


#: Patches of fewer triangles than this, holding under ``SMALL_PATCH_AREA`` of the surface's
#: area, join the neighbour they meet at the smallest angle: marching-cubes surfaces hold
#: slivers whose normals are off by more than the crease angle from all their neighbours.
SMALL_PATCH_TRIANGLES = 8
SMALL_PATCH_AREA = 1e-3


def segment_patches(
    faces: np.ndarray,
    normals: np.ndarray,
    angle: float,
    areas: np.ndarray | None = None,
    filled: np.ndarray | None = None,
) -> tuple[np.ndarray, int]:
    """Patch label of each triangle (F,) and the number of patches.

    Two triangles sharing an edge (and only those two) belong to one patch when their normals
    differ by at most ``angle`` degrees. Zero-area triangles join their neighbours, and so do
    small patches (see ``SMALL_PATCH_TRIANGLES``) when ``areas`` are given.

    ``filled`` (F,) bool marks triangles that close a hole. They never bridge two patches of the
    input: a faired patch over a hole that cut a sharp edge is smooth towards both sides, and
    joining them would erase the edge. A filled piece joins the one patch it meets smoothly, or
    stays a patch of its own (so the sharp edge ends at its rim).
    """
    count = len(faces)
    if count == 0:
        return np.zeros(0, np.int64), 0
    edges, face_edge, forward = edge_table(faces)
    a, b, _, _ = manifold_pairs(face_edge, forward, len(edges))
    cosine = np.einsum("ij,ij->i", normals[a], normals[b])
    degenerate = ~(np.any(normals[a] != 0, axis=1) & np.any(normals[b] != 0, axis=1))
    smooth = (cosine >= np.cos(np.radians(angle))) | degenerate
    same = smooth if filled is None else smooth & (filled[a] == filled[b])
    graph = sparse.coo_matrix((np.ones(int(same.sum())), (a[same], b[same])), shape=(count, count))
    patches, labels = csgraph.connected_components(graph.tocsr(), directed=False)
    if filled is not None and filled.any():
        labels, patches = _join_fills(labels, patches, a[smooth & ~same], b[smooth & ~same], filled)
    if areas is not None and patches > 1:
        labels, patches = _absorb_small(labels, patches, a, b, cosine, areas)
    return labels.astype(np.int64), int(patches)


def _join_fills(labels, patches, a, b, filled):
    """Relabel each filled piece to the one input patch it meets across the smooth edges
    ``a``-``b`` (one filled, one input triangle), if it meets exactly one."""
    fill = np.where(filled[a], labels[a], labels[b])
    patch = np.where(filled[a], labels[b], labels[a])
    pairs = np.unique(np.column_stack([fill, patch]), axis=0)
    fills, counts = np.unique(pairs[:, 0], return_counts=True)
    single = np.isin(pairs[:, 0], fills[counts == 1])
    target = np.arange(patches)
    target[pairs[single, 0]] = pairs[single, 1]
    kept, labels = np.unique(target[labels], return_inverse=True)
    return labels, len(kept)


def _absorb_small(labels, patches, a, b, cosine, areas):
    """Join each small patch to the neighbouring patch across its flattest edge."""
    sizes = np.bincount(labels, minlength=patches)
    patch_area = np.bincount(labels, weights=areas, minlength=patches)
    small = (sizes < SMALL_PATCH_TRIANGLES) & (patch_area < SMALL_PATCH_AREA * areas.sum())
    group = flattest_neighbour_groups(labels, patches, small, a, b, cosine)
    if group is None:
        return labels, patches
    return group[labels], int(group.max()) + 1


def flattest_neighbour_groups(labels: np.ndarray, patches: int, small: np.ndarray, a: np.ndarray, b: np.ndarray,
                              cosine: np.ndarray) -> np.ndarray | None:
    """Groups (patches,) of the patches when each ``small`` one is linked to the neighbour it
    meets across its flattest edge (``a``-``b``: the triangles across each manifold edge,
    ``cosine`` of their normals), numbered from 0; None when no small patch has a neighbour."""
    la, lb = labels[a], labels[b]
    across = la != lb
    # each crossing edge seen from both sides: (patch, neighbour, cosine)
    own = np.concatenate([la[across], lb[across]])
    other = np.concatenate([lb[across], la[across]])
    flat = np.concatenate([cosine[across], cosine[across]])
    pick = small[own]
    own, other, flat = own[pick], other[pick], flat[pick]
    if len(own) == 0:
        return None
    order = np.lexsort((-flat, own))
    first = np.ones(len(order), dtype=bool)
    first[1:] = own[order][1:] != own[order][:-1]
    chosen = order[first]
    links = sparse.coo_matrix((np.ones(len(chosen)), (own[chosen], other[chosen])), shape=(patches, patches))
    return csgraph.connected_components(links.tocsr(), directed=False)[1]


class PatchPlanes:
    """Each patch as a smooth function: the signed distance to the plane of the patch's
    triangle closest to the point (exact on a planar patch, the facet's plane on a tessellated
    curved one)."""

    def __init__(self, vertices: np.ndarray, faces: np.ndarray, normals: np.ndarray, labels: np.ndarray) -> None:
        self.vertices = vertices
        self.faces = faces
        self.normals = normals
        self.labels = labels
        order = np.argsort(labels, kind="stable")
        self._order = order
        self._starts = np.searchsorted(labels[order], np.arange(int(labels.max()) + 2 if len(labels) else 1))
        self._trees: dict[int, object] = {}
        self._lock = threading.Lock()

    def __getstate__(self) -> dict:
        state = self.__dict__.copy()
        state["_trees"] = {}
        del state["_lock"]
        return state

    def __setstate__(self, state: dict) -> None:
        self.__dict__.update(state)
        self._lock = threading.Lock()

    def _members(self, label: int) -> np.ndarray:
        return self._order[self._starts[label] : self._starts[label + 1]]

    def _tree(self, label: int):
        tree = self._trees.get(label)
        if tree is None:
            with self._lock:
                tree = self._trees[label] = TriangleTree(self.vertices, self.faces[self._members(label)])
        return tree

    def values(self, labels: np.ndarray, points: np.ndarray) -> np.ndarray:
        """Plane values of each point's patch (negative on the solid's side)."""
        result = np.empty(len(points))
        for label in np.unique(labels):  # one query per patch, not per point
            rows = np.flatnonzero(labels == label)
            _, local, _, _ = self._tree(int(label)).query(points[rows])
            face = self._members(int(label))[local]
            result[rows] = np.einsum("ij,ij->i", points[rows] - self.vertices[self.faces[face, 0]], self.normals[face])
        return result
