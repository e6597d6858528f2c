"""What the quality stage may do to the boundary: keep every boundary vertex on its own surface.

Smoothing slides boundary vertices along the model's zero set (a candidate position is projected
onto it). Projection goes to the *nearest* surface, which across a narrow gap or a thin void is
another body's, and a vertex sliding far along a curved sheet can leave faces that cut through
the void. A :class:`SurfaceGuard` records, when the stage starts, each boundary vertex's patch
(:meth:`fepre.sdf.SDF.patch_labels`: the smooth piece of the surface it lies on) and normal, and
accepts a boundary move only when

* the new position lies on the same patch, or on one that continues it smoothly (normal within
  ``CREASE_ANGLE`` of the vertex's original normal);
* the straight path from the old to the new position stays near the surface (its midpoint
  within ``PATH_DEPTH * h`` of the zero set), so it never crosses a gap or a void;
* every boundary face around the vertex stays on the surface: its centroid no deeper than
  ``FACE_DEPTH * h`` (or than it was) and its normal no further from the model's normal than
  ``FACE_ANGLE`` (or than it was), so faces neither span a gap nor fold over their neighbours;
* no moved boundary face crosses another boundary face it did not cross before
  (:func:`folding_vertices`). The checks above are local to the vertex's own faces: where the
  part is thinner than the faces are wide (a wall 0.001-0.004 thick under faces 0.04 wide on
  demosthenes' base), the faces of both sides lie within ``FACE_DEPTH * h`` of the zero set
  with normals near the model's, and a move of 0.03 h along one side pushed a face through
  the other side's (issue 32).

The checks are local: they keep each move small and on its own piece of surface, which is
what lets a vertex cross a gap or a void in the first place (BACKGROUND.md section 10, root
cause 1).
"""

from __future__ import annotations

import numpy as np

from ..triangle_crossings import crossing_faces, pairs_cross
from .tet_topology import FACE_OF_TET, face_keys, faces_of_keys, in_sorted

__all__ = ["SurfaceGuard", "boundary_faces_of_cells", "folding_vertices", "CREASE_ANGLE", "PATH_DEPTH", "FACE_DEPTH", "FACE_ANGLE"]

#: A vertex may move onto another patch whose normal is within this many degrees of its own
#: (the crease angle of :func:`fepre.distmesh.finalize.crease_nodes`): a smooth continuation.
CREASE_ANGLE = 30.0
#: Largest distance (times h) of a move's midpoint from the zero set.
PATH_DEPTH = 0.1
#: Largest distance (times h) of a moved boundary face's centroid from the zero set, unless it
#: was farther before the move.
FACE_DEPTH = 0.1
#: Largest angle (degrees) between a moved boundary face's normal and the model's normal at its
#: centroid, unless it was larger before the move.
FACE_ANGLE = 45.0


def _unit(vectors: np.ndarray) -> np.ndarray:
    return vectors / np.maximum(np.linalg.norm(vectors, axis=-1, keepdims=True), 1e-300)


def boundary_faces_of_cells(
    tets: np.ndarray, cells: np.ndarray, boundary_face_keys: np.ndarray, n_points: int,
    boundary_vertices: np.ndarray | None = None,
) -> tuple[np.ndarray, np.ndarray]:
    """The boundary faces among the faces of ``cells`` (indices into ``tets``).

    ``boundary_vertices`` (N,) bool, when given, holds at least every vertex of a boundary
    face: only faces with three such vertices are looked up (most cells of a large mesh have
    none on the boundary). Returns ``(faces (F, 3), owner (F,))``: the faces oriented outwards
    (as in :data:`~fepre.distmesh.tet_topology.FACE_OF_TET`) and the index of each one's cell.
    """
    if boundary_vertices is not None:
        cells = cells[boundary_vertices[tets[cells]].sum(axis=1) >= 3]
    corners = tets[cells][:, FACE_OF_TET]  # (K, 4, 3)
    keys = face_keys(corners.reshape(-1, 3), n_points)
    on_surface = in_sorted(keys, boundary_face_keys).reshape(-1, 4)
    row, local = np.nonzero(on_surface)
    return corners[row, local], cells[row]


def folding_vertices(old: np.ndarray, new: np.ndarray, boundary_face_keys: np.ndarray, moved: np.ndarray) -> np.ndarray:
    """The ``moved`` vertices (indices) of boundary faces that cross, at the ``new`` positions
    (N, 3), a boundary face they did not cross at the ``old`` ones: the moves to undo so that
    the boundary does not fold over itself.

    Only the boundary faces near a face with a moved vertex are tested
    (:func:`~fepre.triangle_crossings.crossing_faces` on them); a pair that crossed before the
    moves is left alone.

    Examples
    --------
    Two faces 0.01 apart (a thin wall's sides); moving vertex 0 to the other side folds them:

    >>> import numpy as np
    >>> from fepre.distmesh.tet_topology import face_keys
    >>> old = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 0.01], [1, 0, 0.01], [0, 1, 0.01]], float)
    >>> keys = np.sort(face_keys(np.array([[0, 1, 2], [3, 4, 5]]), 6))
    >>> new = old.copy(); new[0, 2] = 0.02; new[0, :2] = 0.2
    >>> folding_vertices(old, new, keys, np.array([0])).tolist()
    [0]
    """
    n = new.shape[0]
    from scipy.spatial import cKDTree

    moved = np.asarray(moved, dtype=np.int64)
    if moved.size == 0 or boundary_face_keys.size == 0:
        return np.zeros(0, dtype=np.int64)
    is_moved = np.zeros(n, dtype=bool)
    is_moved[moved] = True
    faces = faces_of_keys(boundary_face_keys, n)
    changed = np.flatnonzero(is_moved[faces].any(axis=1))
    if changed.size == 0:
        return np.zeros(0, dtype=np.int64)
    # the faces that can meet a changed one (centres within twice the largest radius), as
    # surface_refine's crossing check does; their crossing pairs that hold a changed face
    corners = new[faces]
    centres = corners.mean(axis=1)
    reach = 2.0 * float(np.linalg.norm(corners - centres[:, None], axis=2).max())
    subset = _near_cells(centres, changed, reach)
    near = cKDTree(centres[changed]).query_ball_point(centres[subset], reach, return_length=True) > 0
    subset = subset[near]
    pairs = subset[crossing_faces(new, faces[subset])]
    pairs = pairs[is_moved[faces[pairs]].any(axis=(1, 2))]
    if len(pairs):
        pairs = pairs[~pairs_cross(old, faces, pairs)]
    vertices = faces[pairs].ravel()
    return np.unique(vertices[is_moved[vertices]])


#: a grid cell and its 26 neighbours, as offsets
_NEIGHBOUR_CELLS = np.array([[i, j, k] for i in (-1, 0, 1) for j in (-1, 0, 1) for k in (-1, 0, 1)], dtype=np.int64)


def _near_cells(centres: np.ndarray, changed: np.ndarray, reach: float) -> np.ndarray:
    """The indices (increasing) of the ``centres`` in the grid cells, ``reach`` wide, holding or
    touching a cell that holds a ``changed`` centre: a superset of those within ``reach`` of
    one, found without a tree query of every centre (the quality stage's rounds asked all of a
    boundary's 30k face centres each time a few vertices moved)."""
    if not reach > 0:
        return np.arange(len(centres))
    width = reach * (1.0 + 1e-6)  # within reach: at most one cell apart along each axis
    origin = centres.min(axis=0)
    cell = np.floor((centres - origin) / width).astype(np.int64)
    span = cell.max(axis=0) + 3
    wanted = (cell[changed][:, None, :] + 1 + _NEIGHBOUR_CELLS).reshape(-1, 3)

    def key(cells: np.ndarray) -> np.ndarray:
        return (cells[:, 0] * span[1] + cells[:, 1]) * span[2] + cells[:, 2]

    return np.flatnonzero(np.isin(key(cell + 1), np.unique(key(wanted))))


class SurfaceGuard:
    """The patches and normals of the boundary vertices when the quality stage started.

    Parameters
    ----------
    model : fepre.sdf.SDF
    h : float
        Edge length; sets the depth tolerances.
    points : (N, 3) float array
    boundary : (N,) bool
        The boundary vertices (on the zero set).

    Examples
    --------
    >>> import numpy as np
    >>> from fepre import sdf
    >>> part = sdf.box((4, 4, 1), center=(0, 0, 0)) | sdf.box((4, 4, 1), center=(0, 0, 1.6))
    >>> points = np.array([[0.0, 0.0, 0.5], [0.0, 0.0, 1.1]])   # top of one box, bottom of the other
    >>> guard = SurfaceGuard(part, 1.0, points, np.array([True, True]))
    >>> guard.moves_allowed(np.array([0, 0]), points[[0, 0]], np.array([[0.3, 0.0, 0.5], [0.0, 0.0, 1.1]])).tolist()
    [True, False]
    """

    def __init__(self, model, h: float, points: np.ndarray, boundary: np.ndarray):
        self.model = model
        self.h = float(h)
        n = points.shape[0]
        self.labels = np.full(n, -1, dtype=np.int64)
        self.normals = np.zeros((n, 3))
        self.add(np.flatnonzero(boundary), points)
        #: ``local_size((K, 3)) -> (K,)``, the mesh's edge length in a graded mesh (None: ``h``
        #: everywhere); the depth tolerances scale with it
        self.local_size = None
        #: (owner (N,), region_of) of a mesh of several regions: a vertex with an owner (>= 0)
        #: must stay in that region (``region_of(points) -> (K,)``); see :meth:`in_own_region`
        self.regions = None

    def length(self, points: np.ndarray) -> np.ndarray:
        """The edge length that scales the depth tolerances at ``points`` (K, 3): ``h``, or the
        local size of a graded mesh (never below ``h``)."""
        if self.local_size is None:
            return np.full(points.shape[0], self.h)
        return np.maximum(self.h, np.asarray(self.local_size(points), dtype=float))

    def in_own_region(self, vertices: np.ndarray, new: np.ndarray) -> np.ndarray:
        """Mask (K,): ``new`` positions that keep each vertex in its own material region (all
        True without regions, or for a vertex on an interface)."""
        if self.regions is None or vertices.size == 0:
            return np.ones(vertices.size, dtype=bool)
        owner, region_of = self.regions
        own = owner[vertices]
        allowed = own < 0
        check = np.flatnonzero(~allowed)
        if check.size:
            allowed[check] = region_of(new[check]) == own[check]
        return allowed

    def add(self, vertices: np.ndarray, points: np.ndarray) -> None:
        """Record ``vertices`` (which just became boundary vertices) at ``points[vertices]``."""
        if vertices.size == 0:
            return
        _, labels = self.model.patch_labels(points[vertices])
        _, gradient = self.model.value_and_gradient(points[vertices])
        self.labels[vertices] = labels
        self.normals[vertices] = _unit(gradient)

    def moves_allowed(self, vertices: np.ndarray, old: np.ndarray, new: np.ndarray) -> np.ndarray:
        """Mask (K,) of the moves of boundary ``vertices`` from ``old`` to ``new`` (K, 3)
        positions (on the zero set) that stay on the vertex's own patch or a smooth
        continuation of it, along a path near the surface."""
        if vertices.size == 0:
            return np.zeros(0, dtype=bool)
        _, labels = self.model.patch_labels(new)
        allowed = labels == self.labels[vertices]
        within = self.in_own_region(vertices, new)
        other = np.flatnonzero(~allowed & within)
        if other.size:
            _, gradient = self.model.value_and_gradient(new[other])
            cosine = np.einsum("ij,ij->i", _unit(gradient), self.normals[vertices[other]])
            allowed[other] = cosine >= np.cos(np.radians(CREASE_ANGLE))
        allowed &= within
        check = np.flatnonzero(allowed)
        if check.size:
            middle = 0.5 * (old[check] + new[check])
            allowed[check] = np.abs(self.model(middle)) <= PATH_DEPTH * self.length(middle)
        return allowed

    def faces_allowed(self, old: np.ndarray | None, new: np.ndarray) -> np.ndarray:
        """Mask (K,) of boundary faces, given by their corners before ``old`` and after ``new``
        a change (K, 3, 3, outward), that stay on the surface: centroid within
        ``FACE_DEPTH * h`` of the zero set and normal within ``FACE_ANGLE`` of the model's, or
        no worse than before on either count (``old=None``: new faces, no exemption)."""
        if new.shape[0] == 0:
            return np.zeros(0, dtype=bool)
        both = new if old is None else np.concatenate([old, new])
        values, gradient = self.model.value_and_gradient(both.mean(axis=1))
        normals = _unit(np.cross(both[:, 1] - both[:, 0], both[:, 2] - both[:, 0]))
        cosine = np.einsum("ij,ij->i", normals, _unit(gradient))
        depth = np.abs(values)
        depth_limit = FACE_DEPTH * self.length(new.mean(axis=1))
        cosine_limit = np.full(new.shape[0], np.cos(np.radians(FACE_ANGLE)))
        if old is not None:
            k = old.shape[0]
            depth_limit = np.maximum(depth[:k], depth_limit)
            cosine_limit = np.minimum(cosine[:k], cosine_limit)
            depth, cosine = depth[k:], cosine[k:]
        return (depth <= depth_limit) & (cosine >= cosine_limit)

    def replacements_allowed(self, old: np.ndarray, new: np.ndarray, slack: float = 1.0) -> np.ndarray:
        """Mask (K,) of the changes of the surface where the boundary faces ``new[k]`` (K, P, 3, 3,
        outward) replace the faces ``old[k]`` (K, J, 3, 3) as a whole (a topological change):
        every new centroid within ``FACE_DEPTH * h`` of the zero set, or within ``slack`` times
        the farthest old one, and every new normal within ``FACE_ANGLE`` of the model's, or no
        further than the worst old one."""
        def measures(corners):
            flat = corners.reshape(-1, 3, 3)
            values, gradient = self.model.value_and_gradient(flat.mean(axis=1))
            normals = np.cross(flat[:, 1] - flat[:, 0], flat[:, 2] - flat[:, 0])
            cosine = np.einsum("ij,ij->i", _unit(normals), _unit(gradient))
            return np.abs(values).reshape(corners.shape[:2]), cosine.reshape(corners.shape[:2])

        count = new.shape[0]
        if count == 0:
            return np.zeros(0, dtype=bool)
        depth_limit = FACE_DEPTH * self.length(new.reshape(-1, 3, 3).mean(axis=1)).reshape(new.shape[:2]).min(axis=1)
        cosine_limit = np.full(count, np.cos(np.radians(FACE_ANGLE)))
        if old.shape[1]:
            depth, cosine = measures(old)
            depth_limit = np.maximum(depth_limit, slack * depth.max(axis=1))
            cosine_limit = np.minimum(cosine_limit, cosine.min(axis=1))
        depth, cosine = measures(new)
        return (depth <= depth_limit[:, None]).all(axis=1) & (cosine >= cosine_limit[:, None]).all(axis=1)
