"""Boundary faces of a tetrahedral mesh, named face sets and material regions.

A boundary face is a tetrahedron face that no other tetrahedron shares. Each one goes to the
named set whose function (an SDF, or any callable on (N, 3) points) is nearest to zero at the
face centroid, provided that ``|value|`` is at most ``boundary_tolerance`` times the face's mean
edge length (and at most half the height of its tetrahedron over the face, so a face is never
taken by the opposite side of a part one element thick) and the face is parallel to that zero set (its normal within ``boundary_angle`` of
the function's gradient, so a coarse face next to a sharp edge is not taken by the neighbouring
side); ties go to the first name in the mapping; faces near no named set go to ``"boundary"``.
Regions select cells whose centroid has a negative value.
"""

from __future__ import annotations

from ..errors import warn_user
from dataclasses import dataclass
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
DEFAULT_TOLERANCE = 0.25
DEFAULT_ANGLE = 60.0

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


def assign_boundaries(
    points: np.ndarray,
    cells: np.ndarray,
    boundaries: Mapping[str, Callable] | None,
    boundary_tolerance: float = DEFAULT_TOLERANCE,
    boundary_angle: float = DEFAULT_ANGLE,
) -> FaceSets:
    """Find the boundary faces and give each one a set name (see the module docstring)."""
    boundaries = _as_mapping(boundaries, "boundaries")
    tolerance = positive_float(boundary_tolerance, "boundary_tolerance")
    angle = positive_float(boundary_angle, "boundary_angle")
    if angle > 90:
        raise ValueError(f"boundary_angle must be in (0, 90] degrees; got {shown(boundary_angle)}")
    min_cosine = np.cos(np.radians(angle)) - 1e-12
    names = list(boundaries)
    check_names(names, "boundaries")
    elements, local, triangles = boundary_faces(cells)
    corners = points[triangles]
    centroids = corners.mean(axis=1)
    edges = np.linalg.norm(corners - np.roll(corners, 1, axis=1), axis=2).mean(axis=1)
    normals = np.cross(corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0])
    normals /= np.linalg.norm(normals, axis=1)[:, None]
    apex = points[cells[elements, OPPOSITE_NODE[local]]]
    height = np.abs(np.einsum("ij,ij->i", apex - corners[:, 0], normals))
    limit = np.minimum(tolerance * edges, 0.5 * height)
    default_index = len(names)
    if DEFAULT_BOUNDARY in names:  # the user's own "boundary" set also takes the unmatched faces
        default_index = names.index(DEFAULT_BOUNDARY)
    set_ids = np.full(elements.size, default_index, dtype=np.int64)
    if names:
        distance = np.column_stack(
            [np.abs(_evaluate(boundaries[n], centroids, "boundaries", n)) for n in names]
        )
        for j, name in enumerate(names):
            near = np.flatnonzero(distance[:, j] <= limit)
            if near.size:
                gradient = _unit_gradient(boundaries[name], centroids[near], 1e-4 * edges[near], "boundaries", name)
                cosine = np.abs(np.einsum("ij,ij->i", gradient, normals[near]))
                flat = ~np.any(gradient, axis=1)  # no direction to compare with: keep the face
                distance[near[(cosine < min_cosine) & ~flat], j] = np.inf
        best = np.argmin(distance, axis=1)  # first minimum: ties go to the first name
        nearest = distance[np.arange(best.size), best]
        matched = nearest <= limit
        set_ids[matched] = best[matched]
        within = distance <= limit[:, None]
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
        empty = [n for j, n in enumerate(names) if not np.any(set_ids == j)]
        if empty:
            warn_user(
                f"boundaries {', '.join(map(repr, empty))} match no boundary face (none within "
                f"boundary_tolerance={tolerance:g} x local edge length and boundary_angle={angle:g} "
                f"degrees)",
                BoundaryWarning)
    all_names = names if default_index < len(names) else names + [DEFAULT_BOUNDARY]
    return FaceSets(elements, local, triangles, set_ids, all_names)


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
