"""The tagged grid: a mesh with its named sets in VTK arrays, as fepre returns it and writes VTU.

* cells: the tetrahedra only (``VTK_TETRA`` or ``VTK_QUADRATIC_TETRA``), nothing else;
* cell data ``"region_id"`` (index into field data ``"region_names"``) and the mesh's own cell
  arrays (quality measures, ``volume``);
* point data ``"boundary_id"`` (index into field data ``"boundary_names"``, -1 inside; a node on
  two sets shows the first) and the mesh's own point arrays (``sdf``, ``boundary``, ``feature``).
  For quadratic cells the midside nodes get values too (:func:`midside_values`): float arrays are
  interpolated linearly along the edge; ``boundary`` is 1 where the edge is an edge of a boundary
  face (an edge joining two boundary nodes through the interior is not); ``feature`` is 1 where
  the edge joins two feature nodes (1 or 2) along a crease of the boundary (its two boundary faces
  meet at more than ``CREASE_ANGLE`` degrees), so on the feature curve it follows, and 0
  elsewhere (a corner, 2, is always a corner node); any other integer array takes the smaller of
  its two ends' values;
* field data ``"boundary_faces"`` (K, 3): each boundary face as its tetrahedron (0-based), its
  face number 1..4 (Abaqus ``S1``..``S4``) and its set (index into ``"boundary_names"``), which
  :func:`boundary_faces` turns back into tagged triangles;
* field data ``"boundary_face_counts"`` and ``"boundary_areas"``: each set's number of faces and
  area (quadratic faces over their curved shape; :mod:`fepre.export.areas`).

A VTU file holds this grid with one change: the set names travel as integer field data
``name -> [index, dimension]`` (3 for regions, 2 for boundaries; Gmsh's and meshio's convention)
instead of the two string arrays, because meshio cannot read a VTU holding string arrays. A set
whose name is also the name of a point or cell array (the region ``volume`` and the cell array
``volume``, the set ``boundary`` and the point array ``boundary``) is written as ``<name>_set``,
so that no field data reuses an array's name. :func:`set_names` reads the names back from either
form.
"""

from __future__ import annotations

from typing import Any, Mapping

import numpy as np

from .areas import AREA_FIELD, COUNT_FIELD, set_areas
from .boundaries import OUTWARD_FACES
from .data import FACE_EDGE_NODES, ExportData

__all__ = ["tagged_grid", "boundary_faces", "set_names", "file_grid", "midside_values", "FACE_FIELD",
           "grid_set_areas", "FEPRE_ARRAYS", "RESERVED_FIELD_NAMES", "CREASE_ANGLE", "SET_SUFFIX"]

FACE_FIELD = "boundary_faces"
FEPRE_ARRAYS = ("region_id", "boundary_id")
RESERVED_FIELD_NAMES = (FACE_FIELD, "region_names", "boundary_names", COUNT_FIELD, AREA_FIELD)
#: boundary faces meeting at more than this (degrees) make a crease: the feature curves of a mesh
CREASE_ANGLE = 30.0
#: appended to a set name in a VTU's field data when a point or cell array has that name
SET_SUFFIX = "_set"


def _midside_values(values: np.ndarray, cells10: np.ndarray, n_corners: int) -> np.ndarray:
    """Corner values extended to the midside nodes of ``cells10`` by the mean of each edge's ends."""
    from .quadratic import TET10_EDGES

    extended = np.empty((cells10.max() + 1,) + values.shape[1:], dtype=np.float64)
    extended[:n_corners] = values
    ends = cells10[:, TET10_EDGES]  # (M, 6, 2)
    extended[cells10[:, 4:].ravel()] = 0.5 * (values[ends[..., 0]] + values[ends[..., 1]]).reshape(
        (-1,) + values.shape[1:]
    )
    return extended


def _crease_midside_nodes(data: ExportData) -> np.ndarray:
    """Midside nodes of the boundary edges whose two boundary faces meet at more than
    ``CREASE_ANGLE`` degrees."""
    triangles = data.face_nodes[data.faces.on_boundary]
    corners = data.points[triangles[:, :3]]
    normals = np.cross(corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0])
    normals /= np.maximum(np.linalg.norm(normals, axis=1, keepdims=True), np.finfo(float).tiny)
    midside = triangles[:, 3:].ravel()
    owner = np.repeat(np.arange(len(triangles)), 3)
    order = np.argsort(midside, kind="stable")
    midside, owner = midside[order], owner[order]
    pairs = np.flatnonzero(midside[1:] == midside[:-1])  # an edge shared by two boundary faces
    cosine = np.einsum("ij,ij->i", normals[owner[pairs]], normals[owner[pairs + 1]])
    return midside[pairs][cosine < np.cos(np.radians(CREASE_ANGLE))]


def midside_values(name: str, values: np.ndarray, data: ExportData, n_corners: int) -> np.ndarray:
    """Point array ``name`` (one value per corner node) extended to the midside nodes of the
    quadratic cells of ``data``, by the rules of this module's docstring."""
    if values.dtype.kind == "f":
        return _midside_values(values, data.cells, n_corners)
    from .quadratic import TET10_EDGES

    extended = np.zeros((data.cells.max() + 1,) + values.shape[1:], dtype=values.dtype)
    extended[:n_corners] = values
    ends = data.cells[:, TET10_EDGES]  # (M, 6, 2)
    extended[data.cells[:, 4:].ravel()] = np.minimum(values[ends[..., 0]], values[ends[..., 1]]).reshape(
        (-1,) + values.shape[1:]
    )
    if name in ("boundary", "feature") and values.ndim == 1:
        kept = np.zeros(len(extended), dtype=bool)
        kept[:n_corners] = True
        if name == "boundary":
            kept[data.face_nodes[data.faces.on_boundary][:, 3:].ravel()] = True
        else:
            kept[_crease_midside_nodes(data)] = True
            extended[n_corners:] = np.minimum(extended[n_corners:], 1)
        extended[~kept] = 0
    return extended


def tagged_grid(
    data: ExportData,
    point_arrays: Mapping[str, np.ndarray] | None = None,
    cell_arrays: Mapping[str, np.ndarray] | None = None,
) -> Any:
    """The ``pv.UnstructuredGrid`` of ``data`` with its sets and the mesh's own arrays.

    ``point_arrays`` hold one value per corner node (the linear mesh's points).

    Examples
    --------
    >>> import fepre, tempfile, os
    >>> from fepre import sdf
    >>> mesh = fepre.distmesh(sdf.box(1.0), h=0.5)
    >>> grid = fepre.export(mesh, os.path.join(tempfile.mkdtemp(), "cube.vtu"),
    ...                     boundaries={"top": sdf.plane((0, 0, 1), (0, 0, 0.5))})
    >>> grid.field_data["boundary_faces"].shape[1], "sdf" in grid.point_data
    (3, True)
    """
    import pyvista as pv

    cell_type = pv.CellType.QUADRATIC_TETRA if data.order == 2 else pv.CellType.TETRA
    grid = pv.UnstructuredGrid({cell_type: data.cells}, data.points)
    n_corners = int(data.cells[:, :4].max()) + 1 if data.cells.size else 0
    for name, values in (point_arrays or {}).items():
        values = np.asarray(values)
        if name in FEPRE_ARRAYS or values.shape[:1] != (n_corners,):
            continue
        if data.order == 2:
            if values.dtype.kind not in "fiub":
                continue
            values = midside_values(name, values, data, n_corners)
        grid.point_data[name] = values
    for name, values in (cell_arrays or {}).items():
        values = np.asarray(values)
        if name not in FEPRE_ARRAYS and values.shape[:1] == (data.cells.shape[0],):
            grid.cell_data[name] = values
    grid.cell_data["region_id"] = data.region_ids
    boundary_id = np.full(data.points.shape[0], -1, dtype=np.int64)
    face_nodes = data.face_nodes
    ids = np.repeat(data.faces.set_ids, face_nodes.shape[1])
    order = np.argsort(-ids, kind="stable")  # smaller set index written last wins
    boundary_id[face_nodes.ravel()[order]] = ids[order]
    grid.point_data["boundary_id"] = boundary_id
    grid.field_data["region_names"] = np.array(data.region_names)
    grid.field_data["boundary_names"] = np.array(data.boundary_names)
    grid.field_data[FACE_FIELD] = np.column_stack(
        [data.faces.elements, data.faces.local_faces + 1, data.faces.set_ids]
    ).astype(np.int64)
    counts, areas = set_areas(data.points, data.face_nodes, data.faces.set_ids, len(data.boundary_names))
    grid.field_data[COUNT_FIELD] = counts
    grid.field_data[AREA_FIELD] = areas
    return grid


def file_grid(grid: Any) -> Any:
    """``grid`` with its set names as ``name -> [index, dimension]`` field data (for a VTU file)."""
    written = grid.copy(deep=False)
    regions, boundaries = set_names(grid)
    for key in ("region_names", "boundary_names"):
        written.field_data.remove(key)
    arrays = set(grid.point_data.keys()) | set(grid.cell_data.keys())
    for dimension, names in ((3, regions), (2, boundaries)):
        for index, name in enumerate(names):
            key = name + SET_SUFFIX if name in arrays else name
            written.field_data[key] = np.array([index, dimension], dtype=np.int64)
    return written


def set_names(grid: Any) -> tuple[list[str], list[str]]:
    """Region and boundary set names of a tagged grid: from its string arrays ``"region_names"`` and
    ``"boundary_names"`` or from ``name -> [index, dimension]`` entries (a fepre VTU, Gmsh style;
    ``<name>_set`` is the set ``<name>`` when the grid has a point or cell array ``<name>``).

    Examples
    --------
    >>> import pyvista as pv, numpy as np
    >>> grid = pv.UnstructuredGrid()
    >>> grid.field_data["top"] = np.array([0, 2]); grid.field_data["core"] = np.array([0, 3])
    >>> set_names(grid)
    (['core'], ['top'])
    """
    field = grid.field_data
    found: dict[int, dict[int, str]] = {3: {}, 2: {}}
    for dimension, key in ((3, "region_names"), (2, "boundary_names")):
        if key in field:
            found[dimension] = {i: str(name) for i, name in enumerate(np.asarray(field[key]).tolist())}
    arrays = set(grid.point_data.keys()) | set(grid.cell_data.keys())
    for name in field.keys():
        if name in RESERVED_FIELD_NAMES:
            continue
        value = np.asarray(field[name])
        if value.shape == (2,) and value.dtype.kind in "iu" and int(value[1]) in found:
            stem = name[: -len(SET_SUFFIX)] if name.endswith(SET_SUFFIX) else None
            found[int(value[1])].setdefault(int(value[0]), stem if stem in arrays else name)
    return tuple([found[d][i] for i in sorted(found[d])] for d in (3, 2))  # type: ignore[return-value]


def boundary_faces(grid: Any) -> Any:
    """The named boundary faces of a tagged grid (from :func:`fepre.export`, a fepre VTU or .inp).

    Returns a ``pv.PolyData`` of outward triangles (the corners of each face) with cell data
    ``"boundary_id"``, ``"element"`` and ``"element_face"`` and field data ``"boundary_names"``,
    as :func:`fepre.export.tag_boundaries` gives them.

    Examples
    --------
    >>> import fepre, tempfile, os, pyvista as pv
    >>> from fepre import sdf
    >>> mesh = fepre.distmesh(sdf.box(1.0), h=0.5)
    >>> path = os.path.join(tempfile.mkdtemp(), "cube.vtu")
    >>> _ = fepre.export(mesh, path, boundaries={"top": sdf.plane((0, 0, 1), (0, 0, 0.5))})
    >>> faces = fepre.export.boundary_faces(pv.read(path))
    >>> round(float(faces.extract_cells(faces["boundary_id"] == 0).area), 6)
    1.0
    """
    import pyvista as pv

    if not isinstance(grid, pv.UnstructuredGrid):
        raise TypeError(f"grid must be a pyvista.UnstructuredGrid; got {type(grid).__name__}")
    names = set_names(grid)[1]
    if FACE_FIELD not in grid.field_data or not names:
        raise ValueError(
            f"grid has no field data {FACE_FIELD!r} and boundary names: it was not written by "
            f"fepre.export (a fepre VTU or .inp); use fepre.export.tag_boundaries to name faces"
        )
    table = np.asarray(grid.field_data[FACE_FIELD], dtype=np.int64).reshape(-1, 3)
    cells = np.asarray(grid.cell_connectivity).reshape(grid.n_cells, -1)[:, :4]
    if table.size and (table[:, 0].max() >= grid.n_cells or table[:, 1].min() < 1 or table[:, 1].max() > 4):
        raise ValueError(f"grid's field data {FACE_FIELD!r} names cells or faces the grid does not have")
    triangles = np.take_along_axis(cells[table[:, 0]], OUTWARD_FACES[table[:, 1] - 1], axis=1)
    faces = pv.PolyData.from_regular_faces(np.asarray(grid.points), triangles)
    faces.cell_data["boundary_id"] = table[:, 2]
    faces.cell_data["element"] = table[:, 0]
    faces.cell_data["element_face"] = table[:, 1]
    faces.field_data["boundary_names"] = np.array(names)
    return faces


def grid_set_areas(grid: Any) -> dict[str, tuple[int, float]]:
    """``{set name: (faces, area)}`` of a tagged grid (from :func:`fepre.export`, a fepre VTU or
    ``.inp``), the boundary sets only; quadratic faces over their curved shape.

    Examples
    --------
    >>> import fepre, tempfile, os
    >>> from fepre import sdf
    >>> mesh = fepre.distmesh(sdf.box(1.0), h=0.5)
    >>> grid = fepre.export(mesh, os.path.join(tempfile.mkdtemp(), "cube.vtu"),
    ...                     boundaries={"top": sdf.plane((0, 0, 1), (0, 0, 0.5))})
    >>> {name: (n, round(a, 9)) for name, (n, a) in grid_set_areas(grid).items()}["top"][1]
    1.0
    """
    names = set_names(grid)[1]
    if FACE_FIELD not in grid.field_data or not names:
        return {}
    table = np.asarray(grid.field_data[FACE_FIELD], dtype=np.int64).reshape(-1, 3)
    cells = np.asarray(grid.cell_connectivity).reshape(grid.n_cells, -1)
    local = OUTWARD_FACES if cells.shape[1] == 4 else np.hstack([OUTWARD_FACES, FACE_EDGE_NODES])
    faces = np.take_along_axis(cells[table[:, 0]], local[table[:, 1] - 1], axis=1)
    counts, areas = set_areas(np.asarray(grid.points), faces, table[:, 2], len(names))
    return {name: (int(counts[i]), float(areas[i])) for i, name in enumerate(names)}
