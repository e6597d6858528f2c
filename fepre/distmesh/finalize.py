"""From the loop's final points to a valid tetrahedral solid.

Every point is first put where it belongs: points outside are projected onto the zero set (or
dropped when they cannot get there), points that collapsed onto one another (projection near
sharp edges and corners) are merged. The point set is then triangulated once and a subset of
its cells is chosen:

- the star of every interior node (a node off the zero set) is kept whole, so that only nodes
  on the zero set can ever be on the boundary; an interior node whose star reaches outside the
  domain (a cell with its centroid outside) is moved onto the zero set, or dropped, and the
  points are triangulated again;
- the other cells (all four nodes on the zero set: the boundary layer and walls thinner than
  about ``h``) are kept when their centroid is inside, except shallow caps (nodes' normals
  agree and centroid within ``geps h`` of the zero set: slivers lying on the surface);
- the choice is then repaired until its boundary is a closed 2-manifold
  (:func:`fepre.distmesh.topology.repair_selection`).

Co-planar points inside the point set (a box corner's prism, h thick walls) can give the
triangulation a flat cell; dropping it would leave a crack that the repair closes by cutting
cells away. The solid is first chosen from the backend's own triangulation, cracks and all: a
crack outside the part or on its surface (the flat cells of co-circular nodes on a rim) goes
with the outside cells. Only when that solid is not valid (not a closed 2-manifold, a boundary
node off the zero set, or a boundary face farther than ``0.25 h`` from it: a cut through the
part) are the flat cells kept, ordered like their neighbours, and flipped away (edge removal and
2-3 flips fill the same region with positive cells), and the solid chosen again; then the same
two with Qhull's triangulation when the backend is gmsh. (Qhull's full triangulation is only a
fallback: on the nodes of a cylinder, which settle in columns along its generators, it holds
stacks of slivers as long as the cylinder.)

Nothing moves after the triangulation, so every cell keeps its positive Delaunay volume, and
the boundary nodes are on the zero set by construction.
"""

from __future__ import annotations

import numpy as np

from ..errors import MeshingError
from ..placement import in_user_frame
from ..quality import signed_volumes
from .pit_fill import close_flat_voids
from .delaunay import sorted_cells, tetrahedralize
from .topology import boundary_faces, check_topology, nonmanifold_items, repair_selection

__all__ = ["final_mesh", "compact", "crease_nodes", "surface_gap"]

#: Delaunay backend used when the chosen one returns overlapping cells (valid on co-spherical points)
FALLBACK_BACKEND = "scipy"
#: cells whose centroid is farther outside than this (times h) are never added by the repair
_FAR_OUTSIDE = 0.25
#: the repair's bounds on the cells it may add (centroid outside, times h), tried in turn: a vertex
#: pinched between the stars of two interior nodes (a notch or gap narrower than h at a feature
#: tip) can need cells a little beyond _FAR_OUTSIDE; the unrestricted repair fills whole hull
#: regions (faces 1.3 h out on the decimated knight at D/25)
_BRIDGING_REACHES = (_FAR_OUTSIDE, 0.5)
#: rounds of "triangulate, then move or drop interior nodes whose star reaches outside"
_STAR_ROUNDS = 4
#: points closer than this (times h) are merged
_MERGE = 0.2
#: interior nodes at most this deep (times h) are moved onto the zero set, deeper ones dropped
_PROJECT_DEPTH = 0.5
#: rounds of "release the interior nodes that hold a pinch, triangulate and choose again" before
#: a closed choice over cells outside the part is refused
_RELEASE_ROUNDS = 3
#: rounds of flips that remove flat cells from inside the final triangulation
_FLAT_FLIP_ROUNDS = 6
#: cells on the zero set whose nodes' normals are all within about 60 degrees of each other
#: (cosine above this) lie on one side of the surface: caps, left out when shallow
_CAP_COSINE = 0.5


def compact(points: np.ndarray, tets: np.ndarray, *arrays: np.ndarray):
    """Drop unused points; returns (points, tets, *arrays) renumbered."""
    used = np.zeros(len(points), bool)
    used[tets.ravel()] = True
    new_index = np.cumsum(used) - 1
    return (points[used], new_index[tets], *(a[used] for a in arrays))


def _crowded(points: np.ndarray, priority: np.ndarray, radius: float) -> np.ndarray:
    """Mask of points to drop so that no two kept points are closer than ``radius``: of each
    close pair the point of lower ``priority`` goes (the later one on a tie)."""
    from scipy.spatial import cKDTree

    pairs = cKDTree(points).query_pairs(radius, output_type="ndarray")
    drop = np.zeros(len(points), bool)
    if len(pairs):
        a, b = pairs.min(axis=1), pairs.max(axis=1)
        drop[np.where(priority[a] >= priority[b], b, a)] = True
    return drop


class _PointSet:
    """Points, fixed flags and model values, kept in step while points move or go."""

    def __init__(self, model, points: np.ndarray, fixed: np.ndarray, h: float):
        self.model, self.h, self.tol = model, h, 1e-3 * h
        self.points, self.fixed = points.copy(), fixed.copy()
        self.values = model(self.points)

    @property
    def on_surface(self) -> np.ndarray:
        return np.abs(self.values) <= self.tol

    def copy(self) -> "_PointSet":
        twin = object.__new__(_PointSet)
        twin.model, twin.h, twin.tol = self.model, self.h, self.tol
        twin.points, twin.fixed, twin.values = self.points.copy(), self.fixed.copy(), self.values.copy()
        return twin

    def keep(self, mask: np.ndarray) -> None:
        self.points, self.fixed, self.values = self.points[mask], self.fixed[mask], self.values[mask]

    def project(self, index: np.ndarray) -> None:
        """Move ``points[index]`` onto the zero set; those that do not get there are dropped."""
        index = index[~self.fixed[index]]
        if len(index) == 0:
            return
        self.points[index] = self.model.project(self.points[index], iterations=30, tol=0.05 * self.tol, warn=False)
        self.values[index] = self.model(self.points[index])
        lost = np.zeros(len(self.points), bool)
        lost[index] = np.abs(self.values[index]) > self.tol
        self.keep(~lost)

    def release(self, index: np.ndarray, depth: float) -> None:
        """Interior nodes ``index`` leave the interior: those deeper than ``depth`` go, the others
        are moved onto the zero set; then close points are merged."""
        keep = np.ones(len(self.points), bool)
        keep[index[self.values[index] < -depth]] = False
        moved = np.zeros(len(self.points), bool)
        moved[index] = True
        self.keep(keep)
        self.project(np.flatnonzero(moved[keep]))
        self.merge()

    def merge(self) -> None:
        """Drop points closer than ``_MERGE h`` to another: fixed points stay, points on the
        zero set win over interior ones."""
        priority = 2 * self.fixed.astype(np.int8) + self.on_surface
        drop = _crowded(self.points, priority, _MERGE * self.h) & ~self.fixed
        if drop.any():
            self.keep(~drop)


def _valid_selection(points: np.ndarray, tets: np.ndarray) -> bool:
    """True when the cells ``tets`` form a valid solid (closed 2-manifold boundary)."""
    used_points, renumbered = compact(points, tets)
    return len(renumbered) > 0 and check_topology(renumbered, len(used_points)).ok


def _manifold(tets: np.ndarray, n_points: int) -> bool:
    """True when no face is shared by more than two cells (a triangulation without overlaps)."""
    from .tet_topology import face_neighbours

    try:
        face_neighbours(tets, n_points)
    except ValueError:
        return False
    return True


def _cracked(tets: np.ndarray, n_points: int) -> bool:
    """True when the cells' boundary is not one closed 2-manifold, the hull's: dropping a flat
    cell inside the point set (four co-planar points, e.g. the diagonal plane of a box corner's
    prism) leaves a crack whose faces meet four at an edge, or, when the flat cell stands alone,
    a void of no volume closed by its four faces (four interface nodes on one flat voxel step of
    a label image, in a rectangle)."""
    report = check_topology(tets, n_points)
    if report.overused_faces or report.nonmanifold_edges or report.pinched_vertices:
        return True
    return _shells(report.boundary_faces, n_points) > 1


def _shells(faces: np.ndarray, n_points: int) -> int:
    """Number of connected pieces of the surface ``faces`` (faces joined at shared nodes)."""
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import connected_components

    if len(faces) == 0:
        return 0
    rows = np.repeat(np.arange(len(faces)), 3)
    graph = coo_matrix((np.ones(rows.size), (rows, faces.ravel())), shape=(len(faces), n_points)).tocsr()
    nodes = np.unique(faces)
    count, _ = connected_components((graph.T @ graph)[nodes][:, nodes], directed=False)
    return int(count)


def _orient_like_neighbours(tets: np.ndarray, flat: np.ndarray, neighbours: np.ndarray) -> np.ndarray:
    """Flat cells ordered so that each shares a face with a positive neighbour the opposite way
    round (as cells of one triangulation do); their volume cannot tell their orientation."""
    from .tet_topology import FACE_OF_TET

    tets = tets.copy()
    cells = np.flatnonzero(flat)
    across = neighbours[cells]  # (F, 4)
    usable = (across >= 0) & ~flat[np.maximum(across, 0)]
    has = usable.any(axis=1)
    cells, across, usable = cells[has], across[has], usable[has]
    local = np.argmax(usable, axis=1)
    other = across[np.arange(cells.size), local]
    mine = tets[cells[:, None], FACE_OF_TET[local]]  # (F, 3) as this cell sees its face
    theirs = tets[other][:, FACE_OF_TET]  # (F, 4, 3) the neighbour's four faces
    same_set = np.sort(theirs, axis=2) == np.sort(mine, axis=1)[:, None, :]
    face = theirs[np.arange(cells.size), np.argmax(same_set.all(axis=2), axis=1)]
    start = np.argmax(face == mine[:, :1], axis=1)
    following = face[np.arange(cells.size), (start + 1) % 3]
    same_way = following == mine[:, 1]  # both see the face turning the same way: one is reversed
    swap = cells[same_way]
    tets[swap] = tets[swap][:, [0, 2, 1, 3]]
    return tets


def _flip_flat_cells(points: np.ndarray, tets: np.ndarray, h: float) -> np.ndarray:
    """Replace the flat cells inside the point set by positive ones (edge removal, 2-3 flips, the
    quality stage's own), then drop the flat cells left, which lie on the hull."""
    from .flips import flip_round
    from .tet_shape import ShapeTargets
    from .tet_topology import edge_keys, face_neighbours, faces_on_boundary

    tiny = 1e-10 * h**3
    flat = np.abs(signed_volumes(points, tets)) <= tiny
    if not flat.any():
        return tets
    neighbours = face_neighbours(tets, len(points))
    tets = _orient_like_neighbours(tets, flat, neighbours)
    hull = faces_on_boundary(tets, neighbours)
    boundary_edges = np.unique(edge_keys(hull[:, [[0, 1], [1, 2], [2, 0]]].reshape(-1, 2), len(points)))
    targets = ShapeTargets()
    quality = targets.score(points[tets])
    for _ in range(_FLAT_FLIP_ROUNDS):
        tets, quality, applied, _ = flip_round(points, tets, quality, 0.0, boundary_edges, targets=targets)
        if applied == 0:
            break
    return tets[signed_volumes(points, tets) > tiny]


def _star_conflicts(points: _PointSet, tets: np.ndarray, centroid_values: np.ndarray) -> np.ndarray:
    """Interior nodes that must leave the interior: their star has a cell with its centroid
    outside, or they lie on the boundary of the kept cells (the convex hull)."""
    interior = ~points.on_surface
    forced = interior[tets].any(axis=1)
    bad = np.zeros(len(points.points), bool)
    bad[tets[forced & (centroid_values > 0)].ravel()] = True
    faces = boundary_faces(tets[forced]) if forced.any() else np.zeros((0, 3), np.int64)
    on_hull_side = faces[interior[faces].any(axis=1)]
    bad[on_hull_side.ravel()] = True
    return np.flatnonzero(bad & interior & ~points.fixed)


def _caps(model, state: _PointSet, tets: np.ndarray, locked: np.ndarray) -> np.ndarray:
    """Cells with four nodes on the zero set whose normals all agree (within about 60 deg):
    flat caps on one side of the surface, unlike cells spanning a wall thinner than ``h``
    (opposite normals) or cutting a sharp edge."""
    caps = np.zeros(len(tets), bool)
    free = np.flatnonzero(~locked)
    if len(free) == 0:
        return caps
    nodes, inverse = np.unique(tets[free], return_inverse=True)
    _, gradient = model.value_and_gradient(state.points[nodes])
    normals = gradient / np.maximum(np.linalg.norm(gradient, axis=1), 1e-300)[:, None]
    corner = normals[inverse.reshape(-1, 4)]  # (F, 4, 3)
    cosines = np.einsum("fid,fjd->fij", corner, corner)
    caps[free] = cosines.min(axis=(1, 2)) > _CAP_COSINE
    return caps


def _star_rounds(model, state: _PointSet, previous, backend: str, h: float,
                 mend_cracks: bool) -> tuple[np.ndarray, np.ndarray]:
    """Triangulate ``state``'s points and move or drop the interior nodes whose star reaches
    outside, then triangulate again, for up to ``_STAR_ROUNDS`` rounds; the last triangulation
    and the model's values at its cells' centroids (which :func:`_choose` needs: one evaluation
    over every cell of the hull, 0.12 s of busted.STL's 1.4 s final mesh at D/50, not made twice).
    With ``mend_cracks`` a triangulation whose dropped flat cells left cracks is replaced by one
    with its flat cells flipped away."""
    tets = previous
    for round_ in range(_STAR_ROUNDS + 1):
        if tets is None or len(tets) == 0 or signed_volumes(state.points, tets).min() <= 1e-9 * h**3:
            tets = tetrahedralize(state.points, backend, h)
            if not _manifold(tets, len(state.points)):
                tets = tetrahedralize(state.points, FALLBACK_BACKEND, h)
            if mend_cracks and _cracked(tets, len(state.points)):
                # the backend's first, then Qhull's (a set's order changed with Python's hash seed:
                # the same part came out at 28.9 or 4.7 deg from one process to the next)
                for candidate in dict.fromkeys((backend, FALLBACK_BACKEND)):
                    whole = tetrahedralize(state.points, candidate, h, keep_flat=True)
                    if _manifold(whole, len(state.points)):
                        hull = float(np.abs(signed_volumes(state.points, whole)).sum())
                        whole = _flip_flat_cells(state.points, whole, h)
                        volumes = signed_volumes(state.points, whole)
                        # the flipped cells must tile the same hull: no crack, no overlap
                        if (
                            not _cracked(whole, len(state.points))
                            and volumes.min() > 0
                            and abs(float(volumes.sum()) - hull) <= 1e-9 * hull
                        ):
                            tets = whole
                            break
        centroid_values = model(state.points[tets].mean(axis=1))
        conflicts = _star_conflicts(state, tets, centroid_values)
        if len(conflicts) == 0 or round_ == _STAR_ROUNDS:
            break
        deep = conflicts[state.values[conflicts] < -_PROJECT_DEPTH * h]
        keep = np.ones(len(state.points), bool)
        keep[deep] = False
        shallow = np.setdiff1d(conflicts, deep)
        moved = np.zeros(len(state.points), bool)
        moved[shallow] = True
        state.keep(keep)
        moved = moved[keep]
        state.project(np.flatnonzero(moved))
        state.merge()
        tets = None

    return tets, centroid_values


def _choose(model, state: _PointSet, tets: np.ndarray, geps: float, h: float,
            centroid_values: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The cells of the solid: every interior node's star, the cells inside but shallow caps,
    repaired to a closed 2-manifold; and, when no repair within the bridging bounds closes it,
    the interior nodes whose stars hold a defect left by the last of them (:func:`_holding`)."""
    on_surface = state.on_surface
    locked = ~on_surface[tets].all(axis=1)
    volumes = signed_volumes(state.points, tets)
    selected = locked | ((centroid_values < 0) & ~(_caps(model, state, tets, locked) & (centroid_values > -geps * h)))
    # cost of a change ~ the volume put on the wrong side (half the cell when its centroid is
    # on the zero set, more as the centroid goes deeper on the other side)
    scale = np.cbrt(np.abs(volumes)) + 1e-300
    outside_share = np.clip(0.5 + centroid_values / (2.0 * scale), 0.0, 1.0)
    add_cost = volumes * outside_share + 1e-12 * volumes
    remove_cost = volumes * (1.0 - outside_share) + 1e-12 * volumes
    # a chord across a concave surface puts a centroid at most about h^2 / (8 R) outside: cells
    # farther out bridge a concave region: a second repair never adds them, and of the two
    # repairs the valid one that puts less volume on the wrong side wins
    repaired = repair_selection(tets, selected, locked, add_cost, remove_cost, len(state.points))
    held = np.zeros(0, np.int64)
    for reach in _BRIDGING_REACHES:
        bridging = (centroid_values > reach * h) & ~selected
        if not bridging.any():
            break
        strict = repair_selection(tets, selected, locked, np.where(bridging, np.inf, add_cost), remove_cost, len(state.points))
        if not _valid_selection(state.points, tets[strict]):
            # a pinch the stars of interior nodes hold on both sides: fill a little farther out,
            # unless the unrestricted repair is one the validation would take (on a faceted head
            # the 0.5 h one was valid too but left a 1.2 deg cell the quality stage kept)
            held = _holding(state, tets, strict & locked, boundary_faces(tets[strict]))
            if _acceptable(model, state, tets[repaired], h):
                break
            continue

        def misplaced(choice: np.ndarray) -> float:
            return float(add_cost[choice & ~selected].sum() + remove_cost[~choice & selected].sum())

        if misplaced(strict) < misplaced(repaired) or not _valid_selection(state.points, tets[repaired]):
            repaired = strict
        held = np.zeros(0, np.int64)
        break
    return tets[repaired], held


def _acceptable(model, state: _PointSet, tets: np.ndarray, h: float) -> bool:
    """True when ``tets`` are a closed solid with no boundary face centroid farther than the
    validation stage's bound (:data:`fepre.distmesh.validate.CENTROID_BOUND` h) from the zero set."""
    from .validate import CENTROID_BOUND

    if not _valid_selection(state.points, tets):
        return False
    faces = boundary_faces(tets)
    return bool(np.abs(model(state.points[faces].mean(axis=1))).max() <= CENTROID_BOUND * h)


def _holding(state: _PointSet, tets: np.ndarray, kept_stars: np.ndarray, faces: np.ndarray) -> np.ndarray:
    """Free interior nodes of the cells ``kept_stars`` (stars of interior nodes, kept whole) at
    the non-manifold edges and pinched vertices of the boundary ``faces``: the repair can neither
    carve those stars nor, within its bounds, fill between them."""
    from .topology import nonmanifold_items

    bad_edges, pinched = nonmanifold_items(faces, len(state.points))
    defect = np.zeros(len(state.points), bool)
    defect[bad_edges.ravel()] = True
    defect[pinched] = True
    cells = tets[kept_stars & defect[tets].any(axis=1)]
    nodes = np.unique(cells)
    return nodes[~state.on_surface[nodes] & ~state.fixed[nodes]]


def _valid_solid(model, state: _PointSet, tets: np.ndarray, h: float) -> bool:
    """True when ``tets`` form a valid solid whose boundary nodes are on the zero set and whose
    boundary faces are chords of the surface (a cut through the part or a face across a
    concave region lies farther than ``_FAR_OUTSIDE h`` from it)."""
    if len(tets) == 0 or not _valid_selection(state.points, tets):
        return False
    faces = boundary_faces(tets)
    nodes = np.unique(faces)
    if np.abs(state.values[nodes]).max() > state.tol:
        return False
    return bool(np.abs(model(state.points[faces].mean(axis=1))).max() <= _FAR_OUTSIDE * h)


def _drop_far_cells(model, state: _PointSet, tets: np.ndarray, h: float, size, absolute: bool) -> np.ndarray | None:
    """The closed solid ``tets`` without its cells outside the part: the cells on the zero set
    whose centroid is farther out than ``_FAR_OUTSIDE h`` (Delaunay hull cells across a concave
    region) go, the selection is repaired to a closed 2-manifold never adding them back, and the
    result is kept only if it passes the validation stage's distance check (else None)."""
    from .validate import far_boundary

    centroid_values = model(state.points[tets].mean(axis=1))
    locked = ~state.on_surface[tets].all(axis=1)  # the stars of interior nodes stay whole
    far = (centroid_values > _FAR_OUTSIDE * h) & ~locked
    if not far.any():
        return None
    volumes = signed_volumes(state.points, tets)
    keep = repair_selection(tets, ~far, locked, np.where(far, np.inf, volumes), volumes, len(state.points))
    repaired = tets[keep]
    if len(repaired) == 0 or not _valid_selection(state.points, repaired):
        return None
    if far_boundary(state.points, boundary_faces(repaired), model, h, size, absolute):
        return None
    return repaired


def _attempts(model, state: _PointSet, previous, backend: str, h: float, geps: float):
    """Triangulate ``state``'s points and choose a solid, trying the backend's triangulation, then
    with its cracks mended, then Qhull's (the same two); ``(trial, chosen, valid, held)``: the
    point set and cells of the first valid solid, else of the backend's mended attempt (or the
    closed choice that stopped the attempts), and the interior nodes holding its defects.

    The backend's own triangulation comes first, even when dropping its flat cells left cracks: a
    crack outside the part, or on its surface, is left out with the outside cells. (Qhull's full
    triangulation of points in columns on a cylinder, e.g. a stepped shaft's, holds stacks of
    slivers as long as the cylinder.) When the solid chosen from it is not valid, the cracks are
    mended by flipping the flat cells away and the choice is made again. When both choices are
    closed and both refused, the one whose boundary lies nearer the zero set
    (:func:`surface_gap`) is returned (the mended one on a tie): where the cracks
    lie on a flat face of the part, mending fills them with slivers outside it that the repair
    keeps (tower_holes.obj at D/50: 895 cells under faces up to 20 h long on its flat base,
    1,292 cells under 25 deg after the quality stage, against 109).
    """
    attempts = [(backend, False), (backend, True)]
    if backend != FALLBACK_BACKEND:  # another triangulation of the same points
        attempts += [(FALLBACK_BACKEND, False), (FALLBACK_BACKEND, True)]
    mended = None  # the backend's mended choice: reported when no attempt gives a valid solid
    closed = None  # the backend's own choice when it is closed but refused, and its gap
    for number, (triangulator, mend_cracks) in enumerate(attempts):
        trial = state.copy()
        tets, centroid_values = _star_rounds(model, trial, previous if number < 2 else None, triangulator, h,
                                             mend_cracks=mend_cracks)
        chosen, held = _choose(model, trial, tets, geps, h, centroid_values)
        if _valid_solid(model, trial, chosen, h):
            return trial, chosen, True, held
        if number == 1:
            mended = (trial, chosen, held)
        # a closed solid refused only for a face far from the surface: another triangulation of
        # the same points is the same Delaunay one but for ties, and mending changes nothing
        # where nothing is cracked, so the same face comes back (a gyroid block's four attempts
        # took 20 s, all alike)
        if number < 2 and _valid_selection(trial.points, chosen):
            if number == 0 and not _cracked(tets, len(trial.points)):
                return trial, chosen, False, held
            gap = surface_gap(model, trial.points, chosen)
            if number == 0:
                closed = (gap, (trial, chosen, False, held))
            elif closed is None or gap <= closed[0]:
                return trial, chosen, False, held
            else:  # mending made it worse (cracks on the surface): the backend's own choice
                return closed[1]
    if closed is not None:
        return closed[1]
    return mended[0], mended[1], False, mended[2]


def surface_gap(model, points: np.ndarray, tets: np.ndarray) -> float:
    """How far the boundary of the cells ``tets`` lies from the model's zero set: the sum over
    boundary faces of area times ``|sdf|`` at the centroid (about the volume between the two).

    Of two closed choices that :func:`_valid_solid` refused, the final mesh keeps the one of
    smaller gap: mending the cracks of coplanar nodes on a flat face of the part fills them
    with slivers outside it, which the repair keeps under faces many ``h`` long.

    Examples
    --------
    >>> import numpy as np
    >>> from fepre import sdf
    >>> cell = np.array([[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]])
    >>> round(surface_gap(sdf.sphere(10.0), cell, np.array([[0, 1, 2, 3]])), 2)  # faces ~9.5 deep
    22.45
    """
    faces = boundary_faces(tets)
    corners = points[faces]
    area = 0.5 * np.linalg.norm(np.cross(corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0]), axis=1)
    return float(area @ np.abs(model(corners.mean(axis=1))))


def final_mesh(
    model,
    points: np.ndarray,
    fixed: np.ndarray,
    h: float,
    geps: float,
    backend: str,
    previous: np.ndarray | None = None,
    size=None,
    absolute: bool = False,
):
    """Triangulate ``points`` and choose the cells of a valid solid.

    ``backend`` triangulates. Nodes on sharp features lie exactly on lines and planes,
    co-spherical sets on which gmsh can return overlapping cells: such a triangulation (and a
    ``previous`` one) is refused and the points are triangulated by ``FALLBACK_BACKEND``
    (Qhull) instead.

    ``previous`` is a triangulation of (nearly) the same points, the loop's last one (canonical
    cells in any order): it is reused when no point had to move or go and every cell is still
    positive. Returns
    ``(points, tets, fixed)`` with only the points used. Raises ``MeshingError`` when no valid
    solid can be chosen: a closed choice that ``_valid_solid`` refused (the last attempt's, or
    the backend's mended one) is returned only if its boundary passes the validation stage's
    distance check, or once its cells far outside are dropped and the selection repaired
    (``_drop_far_cells``) so that it does (:func:`fepre.distmesh.validate.mesh_defects`, in the local size given by
    ``size`` and ``absolute``); a solid closed over hull cells outside the part is refused.
    """
    state = _PointSet(model, points, fixed, h)
    n_before = len(state.points)
    state.project(np.flatnonzero(state.values > 0))
    state.merge()
    changed = len(state.points) != n_before or not np.array_equal(state.points, points)
    if changed or previous is None:  # sorted only when it is used (0.5 s at 2.6M cells)
        previous = None
    else:
        previous = sorted_cells(previous, len(state.points))
        previous = previous if _manifold(previous, len(state.points)) else None

    for release in range(_RELEASE_ROUNDS + 1):
        trial, chosen, valid, held = _attempts(model, state, previous, backend, h, geps)
        if valid or not len(chosen) or not _valid_selection(trial.points, chosen):
            break
        # closed and manifold but refused by _valid_solid: returned only if the validation
        # stage would take it (a face a little past _FAR_OUTSIDE h), never over hull cells
        from .validate import defects_message, far_boundary

        far = far_boundary(trial.points, boundary_faces(chosen), model, h, size, absolute)
        if far:
            repaired = _drop_far_cells(model, trial, chosen, h, size, absolute)
            if repaired is not None:
                far, chosen = [], repaired
        if not far:
            break
        if release == _RELEASE_ROUNDS or len(held) == 0:
            # the cells outside close over a part the points were too sparse for: a thin-walled
            # enclosure at D/25 (walls 2 thick, h = 4.9) was told "try a smaller h" three times
            surface = model.project(np.asarray([far[0].place], dtype=np.float64), warn=False)[0]
            raise MeshingError(
                "DistMesh could not choose a valid solid from the final triangulation: the closed "
                f"choice keeps cells outside the part ({defects_message(far)}); {_finer_at(model, surface, h)}")
        # the interior nodes whose stars hold the pinches go onto the zero set (or, when deep, go)
        # and the points are triangulated again
        state, previous = trial, None
        state.release(held, _PROJECT_DEPTH * h)
    state, tets = trial, chosen
    if len(tets) == 0:
        raise MeshingError("DistMesh produced no tetrahedra inside the domain; try a smaller h")
    tets = close_flat_voids(state.points, tets, h)
    points_out, tets, fixed_out = compact(state.points, tets, state.fixed)
    report = check_topology(tets, len(points_out))
    boundary = np.unique(report.boundary_faces)
    off = np.abs(model(points_out[boundary])) > state.tol
    if not report.ok or off.any():
        where, advice = "", "try a smaller h"
        if report.nonmanifold_edges or report.pinched_vertices:
            edges, pinched = nonmanifold_items(report.boundary_faces, len(points_out))
            node = pinched[0] if len(pinched) else edges[0, 0]
            pinch = ", ".join(f"{v:.6g}" for v in in_user_frame(points_out[node]))
            where = (f", a pinch at ({pinch}), where the cells chosen "
                     "meet along an edge or at a point: parts of the surface closer than h there, or a concave "
                     "region bridged")
            advice = _finer_at(model, points_out[node], h)
        if off.any():  # a fixed node off the zero set is an interior node to the choice
            node = boundary[off][int(np.argmax(np.abs(model(points_out[boundary[off]]))))]
            kind = "a fixed node" if fixed_out[node] else "a node"
            farthest = ", ".join(f"{v:.6g}" for v in in_user_frame(points_out[node]))
            where += f", the farthest {kind} at ({farthest})"
        raise MeshingError(
            "DistMesh could not choose a valid solid from the final triangulation "
            f"({report.nonmanifold_edges} non-manifold edges, {report.pinched_vertices} pinched vertices, "
            f"{int(off.sum())} boundary nodes off the zero set{where}); {advice}"
        )
    return points_out, tets, fixed_out


def _finer_at(model, point: np.ndarray, h: float) -> str:
    """Advice for a pinch at ``point`` (on the surface): the h that puts two elements across the
    thinner of the wall and the gap there, measured along the model's normal (a gmsh gear's STEP
    at D/25, its teeth 2.8 wide at h = 5.6, was told "try a smaller h")."""
    from ..sizing.rays import ray_lengths
    from .thin_cells import _unit_gradient

    at = np.asarray(point, dtype=np.float64)[None]
    normal, usable = _unit_gradient(model, at)
    if not usable[0]:
        return "try a smaller h"
    across = min(float(ray_lengths(model, at, -normal, True, 4.0 * h, h / 64.0)[0]),
                 float(ray_lengths(model, at, normal, False, 4.0 * h, h / 64.0)[0]))
    if not np.isfinite(across) or across >= 2.0 * h:
        return "try a smaller h"
    fine = 0.5 * across
    return (f"the part is {across:.3g} across there (wall or gap, along its normal): try h <= {fine:.3g} (two "
            f"elements across), or h=({fine:.3g}, {h:.4g}) (the automatic size field: that fine only where needed)")


def crease_nodes(model, points: np.ndarray, tets: np.ndarray, h: float, angle: float = 30.0) -> np.ndarray:
    """Mask of boundary nodes on a sharp edge or corner of the model.

    The model's gradient is taken just outside the node (``0.05 h``) along the normal of each
    of its boundary faces: on a smooth surface these gradients agree; where two surfaces of a
    CSG part meet at a crease, the points fall on different sides of it and the gradients
    differ by the crease angle. Nodes where two of them differ by more than ``angle`` degrees
    are creases. (Sliding such a node along the surface and projecting it back rounds the
    crease off.)
    """
    faces = boundary_faces(tets)
    crease = np.zeros(len(points), bool)
    if len(faces) == 0:
        return crease
    a, b, c = (points[faces[:, k]] for k in range(3))
    normals = np.cross(b - a, c - a)
    normals /= np.maximum(np.linalg.norm(normals, axis=1), 1e-300)[:, None]
    node = faces.ravel()
    probe = points[node] + 0.05 * h * np.repeat(normals, 3, axis=0)
    _, gradient = model.value_and_gradient(probe)
    gradient /= np.maximum(np.linalg.norm(gradient, axis=1), 1e-300)[:, None]
    # per node, the angle between each probe's gradient and the node's mean probe gradient
    mean = np.stack([np.bincount(node, gradient[:, k], len(points)) for k in range(3)], axis=1)
    mean /= np.maximum(np.linalg.norm(mean, axis=1), 1e-300)[:, None]
    cosine = np.einsum("ij,ij->i", gradient, mean[node])
    lowest = np.ones(len(points))
    np.minimum.at(lowest, node, cosine)
    crease[lowest < np.cos(np.radians(0.5 * angle))] = True
    return crease
