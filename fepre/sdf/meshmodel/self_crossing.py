"""Whether a triangle surface passes through itself: triangles that share no vertex and cross.

A closed, consistently oriented piece can still cross itself (a graphics model whose tail passes
into its leg). Its triangles inside the other part's solid then bound nothing, and the repair
must drop them (:mod:`.repair`). The candidates are found by descending the surface's
bounding-volume hierarchy (:class:`.bvh.TriangleTree`) with each triangle's box, in parallel; the
tests are the segment-triangle tests of :mod:`fepre.triangle_crossings`. On a million triangles
this takes about a third of the time of a k-d tree of bounding spheres, most of it the tree,
which the model's distance queries then reuse.
"""

from __future__ import annotations

import numpy as np
from numba import njit, prange

from ...kernel_threads import kernel_threads
from ...triangle_crossings import FLAT, segment_crosses_triangle
from ._bvh_kernel import _STACK
from .bvh import TriangleTree

__all__ = ["crossing_triangles", "crossing_partners"]


@njit(cache=True, inline="always")
def _cross(a, b, tol):  # pragma: no cover - compiled
    for e in range(3):
        if segment_crosses_triangle(a[e], a[(e + 1) % 3], b[0], b[1], b[2], tol):
            return True
        if segment_crosses_triangle(b[e], b[(e + 1) % 3], a[0], a[1], a[2], tol):
            return True
    return False


@njit(cache=True, parallel=True)
def _partner_search(lower, upper, triangles, spheres, corners, width, leaf_start, subset, later, first, starts,
                    out):  # pragma: no cover - compiled
    """For each ``subset`` triangle (tree order), the triangles sharing no vertex with it that
    it crosses (only those after it in tree order with ``later``; the first found only with
    ``first``): counted into ``starts[k + 1]`` when ``out`` is empty, else written from
    ``starts[k]``."""
    for k in prange(subset.shape[0]):
        i = subset[k]
        tri = triangles[i]
        lo0, lo1, lo2 = min(tri[0, 0], tri[1, 0], tri[2, 0]), min(tri[0, 1], tri[1, 1], tri[2, 1]), min(tri[0, 2], tri[1, 2], tri[2, 2])
        up0, up1, up2 = max(tri[0, 0], tri[1, 0], tri[2, 0]), max(tri[0, 1], tri[1, 1], tri[2, 1]), max(tri[0, 2], tri[1, 2], tri[2, 2])
        stack = np.empty(_STACK, dtype=np.int64)
        stack[0] = 1
        top = 1
        found = 0
        while top > 0 and not (first and found):
            top -= 1
            node = stack[top]
            if (lower[node, 0] > up0 or upper[node, 0] < lo0 or lower[node, 1] > up1 or upper[node, 1] < lo1
                    or lower[node, 2] > up2 or upper[node, 2] < lo2):
                continue
            if node < width:
                stack[top] = 2 * node
                stack[top + 1] = 2 * node + 1
                top += 2
                continue
            for t in range(max(leaf_start[node - width], i + 1) if later else leaf_start[node - width],
                           leaf_start[node - width + 1]):
                if t == i:
                    continue
                shared = False
                for a in range(3):
                    for b in range(3):
                        if corners[i, a] == corners[t, b]:
                            shared = True
                if shared:
                    continue
                size = spheres[i, 3] + spheres[t, 3]
                if _cross(tri, triangles[t], FLAT * size * size * size):
                    if out.shape[0]:
                        out[starts[k] + found] = t
                    found += 1
                    if first:
                        break
        if not out.shape[0]:
            starts[k + 1] = found


def crossing_partners(vertices: np.ndarray, faces: np.ndarray, subset: np.ndarray,
                      tree: TriangleTree | None = None) -> tuple[np.ndarray, np.ndarray]:
    """The triangles that each of ``subset`` crosses (sharing no vertex with it), as a
    compressed list: partners of ``subset[k]`` are ``partners[starts[k]:starts[k + 1]]``.

    Examples
    --------
    >>> import numpy as np
    >>> vertices = np.array([[0, 0, 0], [2, 0, 0], [0, 2, 0], [0.5, 0.5, -1], [0.5, 0.5, 1], [3, 3, 0]], float)
    >>> starts, partners = crossing_partners(vertices, np.array([[0, 1, 2], [3, 4, 5]]), np.array([0]))
    >>> starts.tolist(), partners.tolist()
    ([0, 1], [1])
    """
    vertices = np.asarray(vertices, dtype=np.float64)
    faces = np.asarray(faces, dtype=np.int64)
    subset = np.asarray(subset, dtype=np.int64)
    starts = np.zeros(len(subset) + 1, np.int64)
    if len(faces) < 2 or len(subset) == 0:
        return starts, np.zeros(0, np.int64)
    tree = TriangleTree(vertices, faces) if tree is None else tree
    rank = np.empty(len(faces), np.int64)
    rank[tree.order] = np.arange(len(faces))
    arguments = (tree.box_lower, tree.box_upper, tree.triangles, tree.spheres, np.ascontiguousarray(faces[tree.order]),
                 tree.width, tree.leaf_start, np.ascontiguousarray(rank[subset]), False, False, starts)
    with kernel_threads(len(subset), 2e-7):
        _partner_search(*arguments, np.zeros(0, np.int64))
        np.cumsum(starts, out=starts)
        found = np.zeros(int(starts[-1]), np.int64)
        _partner_search(*arguments, found)
    return starts, tree.order[found]


def crossing_triangles(vertices: np.ndarray, faces: np.ndarray, tree: TriangleTree | None = None, *,
                       both: bool = False) -> np.ndarray:
    """Triangles that cross another triangle of the surface with which they share no vertex.

    Each crossing pair is found once: the flag is on one of its two triangles (the one the tree
    visits first), so the result is empty exactly when the surface does not cross itself. With
    ``both``, every triangle of a crossing pair is returned (about twice the work).

    Parameters
    ----------
    vertices : (V, 3) float array
    faces : (F, 3) int array
    tree : TriangleTree, optional
        The surface's hierarchy, if it is already built (else one is built).
    both : bool
        Return both triangles of each crossing pair.

    Returns
    -------
    (K,) int array
        Indices into ``faces``, sorted.

    Examples
    --------
    >>> import numpy as np
    >>> vertices = np.array([[0, 0, 0], [2, 0, 0], [0, 2, 0], [0.5, 0.5, -1], [0.5, 0.5, 1], [3, 3, 0]], float)
    >>> crossing_triangles(vertices, np.array([[0, 1, 2], [3, 4, 5]])).size
    1
    >>> crossing_triangles(vertices, np.array([[0, 1, 2], [3, 4, 5]]), both=True).tolist()
    [0, 1]
    """
    vertices = np.asarray(vertices, dtype=np.float64)
    faces = np.asarray(faces, dtype=np.int64)
    if len(faces) < 2:
        return np.zeros(0, np.int64)
    tree = TriangleTree(vertices, faces) if tree is None else tree
    counts = np.zeros(len(faces) + 1, np.int64)
    with kernel_threads(len(faces), 2e-7):
        _partner_search(tree.box_lower, tree.box_upper, tree.triangles, tree.spheres, np.ascontiguousarray(faces[tree.order]),
                        tree.width, tree.leaf_start, np.arange(len(faces)), not both, True, counts, np.zeros(0, np.int64))
    return np.sort(tree.order[counts[1:] > 0])
