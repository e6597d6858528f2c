"""Boundary faces of a tetrahedral mesh, named face sets and material regions.

A boundary face is a tetrahedron face that no other tetrahedron shares. It joins a named set
(an SDF, or any callable on (N, 3) points, zero on the set's surface) only if it lies on that
surface:

* each of its three nodes is within ``boundary_tolerance`` x h of the surface (``|value| <=
  1e-3 h`` by default; h is the face's mean edge length), so the far side of a part one element
  thick is never taken for it (and a flat boundary tetrahedron's face, all on the surface, is);
* its centroid is within that limit plus the sag of a triangle inscribed in a surface as curved
  as the function's gradients at the nodes say (0 on a plane; a face of a bore is kept, a face
  bridging a groove whose lips are on the surface is not);
* its normal is within ``boundary_angle`` of the function's gradient at the centroid, or of its
  opposite: the function's sign is not asked for (``lambda p: p[:, 2]`` names a part's bottom),
  unless faces on the surface face both ways (coplanar faces of a step, a Z-bracket's arms, a
  T-slot): then only those facing along the gradient are in the set, with a warning.

A face on two sets' surfaces (two names for one surface) goes to the one whose value at the
centroid is nearest zero, ties to the first name in the mapping, with a warning; faces on no
named set go to ``"boundary"``. A face with only some nodes on the surface (one that turns onto a
fillet, a chamfer or a rim next to a flat floor) is not on it: naming a face by its centroid
alone (fepre < 0.9, within a quarter of h) gave a floor plane the first row of a rounded edge's
faces, 11% of extra area and force. fepre's own meshes put boundary nodes on the model's surface
to well under 1e-3 h; a mesh made elsewhere (gmsh, pytetwild) may not, and a set most of whose
nearby parallel faces have no node on the surface gets a warning naming it and how far those
nodes lie, with the ``boundary_tolerance`` that would take them.

Regions select cells whose centroid has a negative value.
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass

from ..errors import warn_user
from typing import Any, Callable, Mapping

import numpy as np

from ..arguments import SET_NAME as _NAME, check_names, positive_float, shown  # noqa: F401  (re-exported: they were defined here)
from .tetmesh import tetra_arrays

__all__ = [
    "BoundaryWarning",
    "FaceSets",
    "boundary_faces",
    "assign_boundaries",
    "assign_regions",
    "tag_boundaries",
    "tag_regions",
    "DEFAULT_BOUNDARY",
    "DEFAULT_REGION",
]

DEFAULT_BOUNDARY = "boundary"
DEFAULT_REGION = "volume"
DEFAULT_TOLERANCE = 1e-3
#: largest boundary_tolerance: beyond it a face of a neighbouring surface can have every node "on" a set
MAX_TOLERANCE = 0.25
#: faces whose centroid is within NEAR x h of a set's surface are examined (and reported when missed)
NEAR = 0.25
DEFAULT_ANGLE = 60.0
#: faces next to a set turned off it by less than this (degrees) mean its edge is no crease
TANGENT_ANGLE = 20.0
#: a set whose faces have their nodes on its surface to this times h was meshed for that surface
#: (fepre puts them there to ~1e-12): parallel faces near it with no node on it are another
#: surface's (a journal's crown under an unbounded plane through a keyway's floor), not faces of a
#: mesh made elsewhere (gmsh's and pytetwild's bore nodes: 0.003-0.004 h off)
EXACT_NODES = 1e-6
#: a set left at the default tolerance whose missed parallel faces all lie within this times h of
#: its surface (their nodes on a tessellation's facets under an exact cylinder, or a mesh made
#: elsewhere: 0.002-0.004 h) takes them, with a warning: the tolerance that would take them
FACET_TOLERANCE = 0.02

# Faces in Abaqus/CalculiX order S1..S4 (1-2-3, 1-4-2, 2-4-3, 3-4-1), each written here with its
# nodes ordered so the right-hand normal points out of a positive-volume tetrahedron.
OUTWARD_FACES = np.array([[0, 2, 1], [0, 1, 3], [1, 2, 3], [0, 3, 2]], dtype=np.int64)
OPPOSITE_NODE = np.array([3, 2, 0, 1], dtype=np.int64)  # the node not on face S1..S4

class BoundaryWarning(UserWarning):
    """Named boundaries or regions that overlap or select nothing."""


@dataclass(frozen=True)
class FaceSets:
    """Boundary faces and the named set of each.

    Attributes
    ----------
    elements : (K,) int64
        Cell (0-based) owning each boundary face.
    local_faces : (K,) int64
        Face number 0..3 within its cell, in Abaqus order (0 is ``S1``).
    triangles : (K, 3) int64
        Node ids of each face, ordered so the normal points out of the solid.
    set_ids : (K,) int64
        Index into ``names`` of each face's set.
    names : list of str
        Set names; the named boundaries first in the caller's order, then ``"boundary"``, then
        the interfaces between regions (:func:`fepre.export.interfaces.with_interfaces`).
    interfaces : int
        How many of the last names are interfaces: faces inside the mesh, between two regions,
        given from the side of the region listed first.
    """

    elements: np.ndarray
    local_faces: np.ndarray
    triangles: np.ndarray
    set_ids: np.ndarray
    names: list[str]
    interfaces: int = 0

    @property
    def on_boundary(self) -> np.ndarray:
        """(K,) bool: the face is on the mesh's boundary (not on an interface)."""
        return self.set_ids < len(self.names) - self.interfaces


def boundary_faces(cells: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Faces used by one tetrahedron only: ``(elements, local_faces, outward triangles)``.

    Examples
    --------
    >>> import numpy as np
    >>> elements, local, triangles = boundary_faces(np.array([[0, 1, 2, 3]]))
    >>> local.tolist(), triangles.tolist()[0]
    ([0, 1, 2, 3], [0, 2, 1])
    """
    triangles = cells[:, OUTWARD_FACES].reshape(-1, 3)
    keys = np.sort(triangles, axis=1)
    order = np.lexsort((keys[:, 2], keys[:, 1], keys[:, 0]))
    sorted_keys = keys[order]
    same_as_next = np.all(sorted_keys[1:] == sorted_keys[:-1], axis=1)
    shared = np.zeros(order.size, dtype=bool)
    shared[1:] |= same_as_next
    shared[:-1] |= same_as_next
    unique_faces = np.sort(order[~shared])
    elements = unique_faces // 4
    local = unique_faces % 4
    return elements.astype(np.int64), local.astype(np.int64), triangles[unique_faces]


def _evaluate(function: Any, points: np.ndarray, parameter: str, name: str) -> np.ndarray:
    if not callable(function):
        raise TypeError(
            f"{parameter}[{name!r}] must be an SDF or a callable on (N, 3) points; got "
            f"{type(function).__name__}"
        )
    values = np.asarray(function(points), dtype=np.float64)
    if values.shape != (points.shape[0],):
        values = values.reshape(-1) if values.size == points.shape[0] else values
    if values.shape != (points.shape[0],):
        raise ValueError(
            f"{parameter}[{name!r}] must return one value per point, shape ({points.shape[0]},); "
            f"got shape {np.shape(values)}"
        )
    if not np.isfinite(values).all():
        raise ValueError(f"{parameter}[{name!r}] returned NaN or infinite values")
    return values


def _unit_gradient(function: Any, points: np.ndarray, step: np.ndarray, parameter: str, name: str) -> np.ndarray:
    """Unit gradient of ``function`` (an SDF's own, else central differences); 0 where flat."""
    gradient_method = getattr(function, "gradient", None)
    if callable(gradient_method) and callable(getattr(function, "value_and_gradient", None)):
        gradient = np.asarray(gradient_method(points), dtype=np.float64).reshape(-1, 3)
    else:
        gradient = np.empty_like(points)
        for axis in range(3):
            offset = np.zeros_like(points)
            offset[:, axis] = step
            plus = _evaluate(function, points + offset, parameter, name)
            minus = _evaluate(function, points - offset, parameter, name)
            gradient[:, axis] = (plus - minus) / (2.0 * step)
    norm = np.linalg.norm(gradient, axis=1)
    return np.divide(gradient, norm[:, None], out=np.zeros_like(gradient), where=norm[:, None] > 0)


def _as_mapping(value: Any, parameter: str) -> Mapping[str, Callable]:
    if value is None:
        return {}
    if not isinstance(value, Mapping):
        raise TypeError(f"{parameter} must be a dict name -> SDF (or callable); got {type(value).__name__}")
    return value


def _face_geometry(points: np.ndarray, cells: np.ndarray, elements: np.ndarray, local: np.ndarray,
                   triangles: np.ndarray):
    """Corners, centroids, mean edge lengths ``h``, unit normals and the height of each face's
    tetrahedron over it."""
    corners = points[triangles]
    centroids = corners.mean(axis=1)
    edges = np.linalg.norm(corners - np.roll(corners, 1, axis=1), axis=2)
    normals = np.cross(corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0])
    normals /= np.linalg.norm(normals, axis=1)[:, None]
    apex = points[cells[elements, OPPOSITE_NODE[local]]]
    height = np.abs(np.einsum("ij,ij->i", apex - corners[:, 0], normals))
    return corners, centroids, edges, normals, height


def _on_surface(function: Any, name: str, corners: np.ndarray, centroids: np.ndarray, edges: np.ndarray,
                normals: np.ndarray, limit: np.ndarray, min_cosine: float, candidates: np.ndarray) -> np.ndarray:
    """Which ``candidates`` (faces whose centroid is near the zero set) lie on it: every node within
    ``limit``, the centroid within ``limit`` plus the sag of a triangle inscribed in a surface of the
    curvature seen between its nodes, and the normal within the angle of the gradient, either way
    when all such faces face one way, the gradient's way when some face each way; and the faces
    left out for facing against it."""
    if not candidates.size:
        return candidates, candidates
    h = edges[candidates].mean(axis=1)
    nodes = corners[candidates].reshape(-1, 3)
    node_values = np.abs(_evaluate(function, nodes, "boundaries", name)).reshape(-1, 3)
    keep = np.all(node_values <= limit[candidates, None], axis=1)
    chosen = candidates[keep]
    if not chosen.size:
        return chosen, chosen
    h = h[keep]
    node_gradients = _unit_gradient(function, corners[chosen].reshape(-1, 3), np.repeat(1e-4 * h, 3),
                                    "boundaries", name).reshape(-1, 3, 3)
    turn = np.linalg.norm(node_gradients - np.roll(node_gradients, 1, axis=1), axis=2)  # |n_i - n_j|
    face_edges = edges[chosen]
    curvature = np.max(turn / face_edges, axis=1)
    # A quadratic surface through the three nodes sits at most curvature * sum(e^2) / 18 off the
    # face's centroid; twice that is allowed, so a face of a bore is kept, a face bridging a groove
    # (nodes on the surface, the middle far off it) is not.
    sag = 2.0 * curvature * np.sum(face_edges**2, axis=1) / 18.0
    centroid_values = np.abs(_evaluate(function, centroids[chosen], "boundaries", name))
    gradient = _unit_gradient(function, centroids[chosen], 1e-4 * h, "boundaries", name)
    cosine = np.einsum("ij,ij->i", gradient, normals[chosen])
    flat = ~np.any(gradient, axis=1)  # no direction to compare with: keep the face
    near = centroid_values <= limit[chosen] + sag
    along, against = near & (cosine >= min_cosine), near & (cosine <= -min_cosine)
    if along.any() and against.any():
        # coplanar faces facing both ways (a Z-bracket's step, a T-slot): the gradient's way only
        return chosen[along | (near & flat)], chosen[against]
    # one way only: the function's sign is not asked for (``lambda p: p[:, 2]`` names a bottom)
    return chosen[along | against | (near & flat)], chosen[:0]


def _checked_tolerances(boundary_tolerance: Any, boundary_angle: Any) -> tuple[float, float]:
    tolerance = positive_float(boundary_tolerance, "boundary_tolerance")
    if tolerance > MAX_TOLERANCE:
        raise ValueError(
            f"boundary_tolerance must be in (0, {MAX_TOLERANCE:g}] (how far a face's nodes may lie from a "
            f"set's surface, as a fraction of the local edge length h; default {DEFAULT_TOLERANCE:g}); "
            f"got {shown(boundary_tolerance)}"
        )
    angle = positive_float(boundary_angle, "boundary_angle")
    if angle > 90:
        raise ValueError(f"boundary_angle must be in (0, 90] degrees; got {shown(boundary_angle)}")
    return tolerance, angle


def assign_boundaries(
    points: np.ndarray,
    cells: np.ndarray,
    boundaries: Mapping[str, Callable] | None,
    boundary_tolerance: float = DEFAULT_TOLERANCE,
    boundary_angle: float = DEFAULT_ANGLE,
) -> FaceSets:
    """Find the boundary faces and give each one a set name (see the module docstring).

    Examples
    --------
    >>> import numpy as np
    >>> points = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1.0]])
    >>> sets = assign_boundaries(points, np.array([[0, 1, 2, 3]]), {"bottom": lambda p: p[:, 2]})
    >>> sets.names, sets.set_ids.tolist()
    (['bottom', 'boundary'], [0, 1, 1, 1])
    """
    boundaries = _as_mapping(boundaries, "boundaries")
    tolerance, angle = _checked_tolerances(boundary_tolerance, boundary_angle)
    check_names(list(boundaries), "boundaries")
    if tolerance != DEFAULT_TOLERANCE or not boundaries:
        return _assign(points, cells, boundaries, {}, tolerance, angle)[0]
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        sets, missed = _assign(points, cells, boundaries, {}, tolerance, angle)
    widened = {name: found for name, found in missed.items() if found[0] <= FACET_TOLERANCE}
    if not widened:
        for item in caught:
            warnings.warn_explicit(item.message, item.category, item.filename, item.lineno)
        return sets
    first = sets
    sets, _ = _assign(points, cells, boundaries, {name: found[0] for name, found in widened.items()}, tolerance, angle)
    for name, (wider, _, median) in widened.items():
        j = sets.names.index(name)
        warn_user(
            f"boundaries {name!r}: the faces along its surface have their nodes a median {median:.3g} h off it (h the "
            f"local edge length), not on it: a tessellated model's facets under an exact surface (a STEP file's, an "
            f"STL's), or a mesh made elsewhere. Taken with boundary_tolerance={wider:.3g} for this set: "
            f"{int(np.count_nonzero(sets.set_ids == j))} faces, against {int(np.count_nonzero(first.set_ids == j))} "
            f"at the default {DEFAULT_TOLERANCE:g} (pass boundary_tolerance to choose it yourself)",
            BoundaryWarning)
    return sets


def _assign(points: np.ndarray, cells: np.ndarray, boundaries: Mapping[str, Callable], tolerances: dict,
            tolerance: float, angle: float) -> tuple[FaceSets, dict]:
    """:func:`assign_boundaries` with ``tolerances`` for some sets (the others ``tolerance``);
    also returns the sets reported as missing their nearby parallel faces, with the tolerance
    that would take them, how many and how far (:func:`_warn_missed`)."""
    min_cosine = np.cos(np.radians(angle)) - 1e-12
    names = list(boundaries)
    elements, local, triangles = boundary_faces(cells)
    corners, centroids, edges, normals, height = _face_geometry(points, cells, elements, local, triangles)
    h = edges.mean(axis=1)
    limit = tolerance * h
    default_index = len(names)
    if DEFAULT_BOUNDARY in names:  # the user's own "boundary" set also takes the unmatched faces
        default_index = names.index(DEFAULT_BOUNDARY)
    set_ids = np.full(elements.size, default_index, dtype=np.int64)
    if names:
        distance = np.full((elements.size, len(names)), np.inf)
        near_faces = []
        for j, name in enumerate(names):
            values = np.abs(_evaluate(boundaries[name], centroids, "boundaries", name))
            candidates = np.flatnonzero(values <= NEAR * h)
            # faces reported as missed: not those of the far side of a part one element thick
            near_faces.append(candidates[values[candidates] <= 0.5 * height[candidates]])
            on, against = _on_surface(boundaries[name], name, corners, centroids, edges, normals,
                                      tolerances.get(name, tolerance) * h, min_cosine, candidates)
            distance[on, j] = values[on]
            if against.size:
                area = 0.5 * float(np.linalg.norm(np.cross(corners[against, 1] - corners[against, 0],
                                                            corners[against, 2] - corners[against, 0]), axis=1).sum())
                warn_user(
                    f"boundaries {name!r}: {against.size} face(s) on its surface (area {area:.4g}) face against its "
                    "function's gradient while others face along it; only those facing along it are in the set "
                    "(negate the function to take the others instead)", BoundaryWarning)
        best = np.argmin(distance, axis=1)  # first minimum: ties go to the first name
        nearest = distance[np.arange(best.size), best]
        matched = np.isfinite(nearest)
        set_ids[matched] = best[matched]
        _warn_overlaps(names, distance, best, nearest, limit)
        areas = 0.5 * np.linalg.norm(np.cross(corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0]), axis=1)
        missed = _warn_missed(names, boundaries, corners, normals, h, areas, distance, near_faces, tolerance,
                              angle, min_cosine, set_ids)
        _warn_tangent(names, boundaries, triangles, corners, normals, h, areas, set_ids, set(missed))
    else:
        missed = {}
    all_names = names if default_index < len(names) else names + [DEFAULT_BOUNDARY]
    return FaceSets(elements, local, triangles, set_ids, all_names), missed


def _warn_overlaps(names, distance, best, nearest, limit) -> None:
    within = np.isfinite(distance)
    ties = within & (distance <= (nearest + 1e-6 * limit)[:, None])
    ties[np.arange(best.size), best] = False
    for j, name in enumerate(names):
        overlapping = ties[:, j]
        if overlapping.any():
            winners = np.unique(best[overlapping])
            warn_user(
                f"boundaries {name!r} and {', '.join(repr(names[w]) for w in winners)} overlap "
                f"on {int(overlapping.sum())} faces; they go to the first name in the dict",
                BoundaryWarning)


def _warn_tangent(names, boundaries, triangles, corners, normals, h, areas, set_ids, reported) -> None:
    """Warn about sets whose edge is no crease: faces next to the set, outside it, turned off its
    plane by under ``TANGENT_ANGLE`` (a fillet leaving the surface tangentially). No mesh node lies
    on that tangent line, so the set ends up to a row of faces short of it."""
    n = int(triangles.max()) + 1 if triangles.size else 0
    pairs = np.sort(triangles[:, [[0, 1], [1, 2], [2, 0]]], axis=2)  # (K, 3, 2)
    keys = pairs[..., 0] * n + pairs[..., 1]  # (K, 3)
    for j, name in enumerate(names):
        inside = set_ids == j
        if not inside.any() or name in reported:
            continue
        edge_keys, uses = np.unique(keys[inside].ravel(), return_counts=True)
        rim = edge_keys[uses == 1]
        owner = np.repeat(np.flatnonzero(inside), 3)[np.isin(keys[inside].ravel(), rim)]
        rim_keys = keys[inside].ravel()[np.isin(keys[inside].ravel(), rim)]
        outside = np.flatnonzero(~inside)
        hits = np.isin(keys[outside], rim)  # (K_out, 3)
        neighbour = outside[hits.any(axis=1)]
        if not neighbour.size:
            continue
        # each neighbour against the set face across its shared edge
        shared = keys[neighbour][hits[hits.any(axis=1)]]
        first = np.repeat(neighbour, hits[hits.any(axis=1)].sum(axis=1))
        order = np.argsort(rim_keys)
        across = owner[order][np.searchsorted(rim_keys[order], shared)]
        cosine = np.abs(np.einsum("ij,ij->i", normals[first], normals[across]))
        tangent = np.unique(first[cosine > np.cos(np.radians(TANGENT_ANGLE))])
        band = float(areas[tangent].sum())
        total = float(areas[inside].sum())
        if band > 1e-3 * total:
            off = np.abs(_evaluate(boundaries[name], corners[tangent].reshape(-1, 3), "boundaries", name))
            farthest = float(np.median(off.reshape(-1, 3).max(axis=1) / h[tangent]))
            warn_user(
                f"boundaries {name!r}: along {tangent.size} faces of its edge the part's surface turns off it "
                f"by under {TANGENT_ANGLE:g} degrees, their farthest nodes a median {farthest:.3g} h from it: "
                f"either a fillet leaves it tangentially (no mesh node lies on the tangent line; put nodes "
                f"there for an exact set) or the mesh's nodes lie only near it (pass a boundary_tolerance "
                f"above that). The set's area {total:.6g} may be short by up to {band:.3g}, those faces' area",
                BoundaryWarning)


def _exact_set(boundary, name: str, corners: np.ndarray, h: np.ndarray) -> bool:
    """Whether a set's faces (``corners`` (K, 3, 3)) have their nodes on its surface to
    ``EXACT_NODES`` h (the median face's farthest node): a mesh made for that surface."""
    if not corners.size:
        return False
    nodes = np.abs(_evaluate(boundary, corners.reshape(-1, 3), "boundaries", name)).reshape(-1, 3).max(axis=1)
    return bool(np.median(nodes / h) <= EXACT_NODES)


def _warn_missed(names, boundaries, corners, normals, h, areas, distance, near_faces, tolerance, angle,
                 min_cosine, set_ids) -> dict:
    """Warn about sets that match no face, and about sets most of whose nearby, parallel faces have
    no node on the surface (a mesh made elsewhere, whose nodes lie only near the model); return the
    latter: name -> (the boundary_tolerance that takes them, how many, their median offset in h)."""
    empty, reported = [], {}
    for j, name in enumerate(names):
        taken = float(areas[set_ids == j].sum())
        near = near_faces[j][~np.isfinite(distance[near_faces[j], j])]
        offset = np.empty(0)
        if near.size:
            nodes = np.abs(_evaluate(boundaries[name], corners[near].reshape(-1, 3), "boundaries", name))
            nodes = nodes.reshape(-1, 3) / h[near, None]
            gradient = _unit_gradient(boundaries[name], corners[near].mean(axis=1), 1e-4 * h[near], "boundaries", name)
            parallel = np.abs(np.einsum("ij,ij->i", gradient, normals[near])) >= min_cosine
            off = parallel & (nodes.min(axis=1) > tolerance)  # no node of the face on the surface
            missed = float(areas[near[off]].sum())
            if off.any() and missed > taken and not _exact_set(boundaries[name], name, corners[set_ids == j], h[set_ids == j]):
                offset = nodes[off].max(axis=1)
        if offset.size:
            wider = min(MAX_TOLERANCE, float(np.quantile(offset, 0.9)) * 1.5)
            reported[name] = (wider, int(offset.size), float(np.median(offset)))
            warn_user(
                f"boundaries {name!r}: {int(np.count_nonzero(set_ids == j))} faces have their nodes on its "
                f"surface (within boundary_tolerance={tolerance:g} h), but {offset.size} parallel faces near it "
                f"have none: their nodes lie a median {float(np.median(offset)):.3g} h from it (h the local edge "
                f"length). A mesh made elsewhere, or one of a model whose surface only comes near the set's (a "
                f"triangle mesh's facets under an exact cylinder), has its nodes only near it; pass boundary_tolerance="
                f"{wider:.3g} to take them (in a model file: "
                f"`boundary_tolerance = ...`)",
                BoundaryWarning)
        elif not np.any(set_ids == j):
            empty.append(name)
    if empty:
        warn_user(
            f"boundaries {', '.join(map(repr, empty))} match no boundary face (none with its nodes within "
            f"boundary_tolerance={tolerance:g} x local edge length of the surface and its normal within "
            f"boundary_angle={angle:g} degrees of the surface's)",
            BoundaryWarning)
    return reported


def assign_regions(
    points: np.ndarray,
    cells: np.ndarray,
    regions: Mapping[str, Callable] | None,
    default_region: str = DEFAULT_REGION,
) -> tuple[np.ndarray, list[str]]:
    """Region index of each cell (first region whose value at the centroid is < 0) and names."""
    regions = _as_mapping(regions, "regions")
    names = list(regions)
    check_names(names + ([default_region] if default_region not in names else []), "regions")
    centroids = points[cells].mean(axis=1)
    default_index = names.index(default_region) if default_region in names else len(names)
    region_ids = np.full(cells.shape[0], default_index, dtype=np.int64)
    unassigned = np.ones(cells.shape[0], dtype=bool)
    for j, name in enumerate(names):
        inside = (_evaluate(regions[name], centroids, "regions", name) < 0) & unassigned
        region_ids[inside] = j
        unassigned &= ~inside
    empty = [n for j, n in enumerate(names) if not np.any(region_ids == j)]
    if empty:
        warn_user(
            f"regions {', '.join(map(repr, empty))} contain no cell centroid", BoundaryWarning)
    all_names = names if default_index < len(names) else names + [default_region]
    used = np.unique(region_ids)
    if default_index == len(names) and default_index not in used and names:
        all_names = names  # every cell is in a named region
    return region_ids, all_names


def tag_boundaries(
    mesh: Any,
    boundaries: Mapping[str, Callable] | None = None,
    *,
    boundary_tolerance: float = DEFAULT_TOLERANCE,
    boundary_angle: float = DEFAULT_ANGLE,
) -> "pv.PolyData":  # noqa: F821
    """The boundary faces of ``mesh`` as a ``pv.PolyData`` tagged with their named set.

    Cell data ``"boundary_id"`` (index into field data ``"boundary_names"``), ``"element"`` (the
    owning tetrahedron, 0-based) and ``"element_face"`` (1..4, Abaqus ``S1``..``S4``).

    Examples
    --------
    >>> import pyvista as pv, numpy as np
    >>> grid = pv.UnstructuredGrid({pv.CellType.TETRA: np.array([[0, 1, 2, 3]])},
    ...                            np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1.0]]))
    >>> faces = tag_boundaries(grid, {"bottom": lambda p: p[:, 2]}, boundary_tolerance=0.1)
    >>> faces["boundary_id"].tolist(), faces.field_data["boundary_names"].tolist()
    ([0, 1, 1, 1], ['bottom', 'boundary'])
    """
    import pyvista as pv

    points, cells = tetra_arrays(mesh)
    sets = assign_boundaries(points, cells, boundaries, boundary_tolerance, boundary_angle)
    faces = pv.PolyData.from_regular_faces(points, sets.triangles)
    faces.cell_data["boundary_id"] = sets.set_ids
    faces.cell_data["element"] = sets.elements
    faces.cell_data["element_face"] = sets.local_faces + 1
    faces.field_data["boundary_names"] = np.array(sets.names)
    return faces


def tag_regions(
    mesh: Any,
    regions: Mapping[str, Callable] | None = None,
    *,
    default_region: str = DEFAULT_REGION,
) -> "pv.UnstructuredGrid":  # noqa: F821
    """A copy of ``mesh`` with cell data ``"region_id"`` and field data ``"region_names"``.

    Examples
    --------
    >>> import pyvista as pv, numpy as np
    >>> grid = pv.UnstructuredGrid({pv.CellType.TETRA: np.array([[0, 1, 2, 3]])},
    ...                            np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1.0]]))
    >>> tagged = tag_regions(grid, {"core": lambda p: p[:, 0] - 1})
    >>> tagged["region_id"].tolist(), tagged.field_data["region_names"].tolist()
    ([0], ['core'])
    """
    points, cells = tetra_arrays(mesh)
    region_ids, names = assign_regions(points, cells, regions, default_region)
    tagged = mesh.copy()
    tagged.cell_data["region_id"] = region_ids
    tagged.field_data["region_names"] = np.array(names)
    return tagged
