"""Export tetrahedral meshes to FEA solvers, with named boundary and region sets.

fepre writes Abaqus/CalculiX ``.inp`` itself (C3D4/C3D10, ``*NSET``/``*ELSET``/``*SURFACE`` per
named set) and lets meshio write Gmsh 2.2, VTU, XDMF (dolfinx), Nastran, Medit, MED and Exodus
with the cell data each format needs for its named sets. A boundary face is in a named set when
its nodes lie on the set's SDF (or callable) zero set and it faces the same way
(:mod:`fepre.export.boundaries`); each set's area is in the returned grid
(:mod:`fepre.export.areas`); ``order=2`` adds
curved midside nodes (:mod:`fepre.export.quadratic`). Every write is atomic.

Examples
--------
>>> import fepre, tempfile, os
>>> from fepre import sdf
>>> mesh = fepre.distmesh(sdf.sphere(1.0), h=0.5)
>>> path = os.path.join(tempfile.mkdtemp(), "ball.inp")
>>> tagged = fepre.export(mesh, path, boundaries={"cap": sdf.sphere(1.0) & sdf.plane((0, 0, -1), (0, 0, 0.5))})
>>> tagged.field_data["boundary_names"].tolist()
['cap', 'boundary']
"""

from __future__ import annotations

import os
from pathlib import Path
from typing import Any, Callable, Mapping

import numpy as np

from ..callable_package import make_callable
from ..arguments import choice
from .abaqus import RESERVED_NAMES
from .atomic import staged_files
from .boundaries import (
    DEFAULT_ANGLE,
    DEFAULT_REGION,
    DEFAULT_TOLERANCE,
    BoundaryWarning,
    assign_boundaries,
    assign_regions,
    tag_boundaries,
    tag_regions,
)
from .data import ExportData
from .formats import FORMATS, Format, resolve_format
from .grid import RESERVED_FIELD_NAMES, boundary_faces, tagged_grid
from .interfaces import with_interfaces
from .meshio_formats import require_module
from .quadratic import quadratic_tetrahedra
from .sections import mesh_regions, sections
from .tetmesh import tetra_arrays

__all__ = ["export", "tag_boundaries", "tag_regions", "boundary_faces", "BoundaryWarning", "FORMATS", "Format"]

_ASCII_TREE = str.maketrans({"└": "`", "├": "|", "│": "|", "─": "-"})


def _check_name_clashes(region_names: list[str], boundary_names: list[str]) -> None:
    upper_regions = {n.upper(): n for n in region_names}
    for name in boundary_names:
        if name.upper() in upper_regions:
            raise ValueError(
                f"boundaries: name {name!r} is also a region name ({upper_regions[name.upper()]!r}); "
                f"formats such as Gmsh and MED keep one namespace, so use distinct names"
            )
    for name in region_names + boundary_names:
        if name.lower() in RESERVED_FIELD_NAMES:
            raise ValueError(f"set name {name!r} is reserved (fepre stores {', '.join(RESERVED_FIELD_NAMES)} in VTU files)")
        if name.upper() in RESERVED_NAMES:
            raise ValueError(f"set name {name!r} is reserved (fepre writes {', '.join(RESERVED_NAMES)})")


def _title(model: Any) -> tuple[str, str]:
    from .._version import __version__

    if model is None:
        return f"fepre {__version__} export", ""
    describe = getattr(model, "describe", None)
    label = describe() if callable(describe) else type(model).__name__
    tree = repr(model).translate(_ASCII_TREE).encode("ascii", "replace").decode("ascii")
    label = label.encode("ascii", "replace").decode("ascii")
    return f"fepre {__version__} export of model {label}", "model:\n" + tree


def export(
    mesh: Any,
    path: str | os.PathLike,
    *,
    format: str | None = None,
    order: int = 1,
    boundaries: Mapping[str, Callable] | None = None,
    regions: Mapping[str, Callable] | None = None,
    model: Any = None,
    overwrite: bool = True,
    boundary_tolerance: float = DEFAULT_TOLERANCE,
    boundary_angle: float = DEFAULT_ANGLE,
    default_region: str = DEFAULT_REGION,
    materials: Mapping[str, Any] | None = None,
    interfaces: bool | None = None,
) -> Any:
    """Write a tetrahedral mesh for a solver, with named boundary and region sets.

    Parameters
    ----------
    mesh : pyvista.UnstructuredGrid
        Linear tetrahedra (``VTK_TETRA``) of positive volume, e.g. from :func:`fepre.distmesh`.
    path : str or path-like
        Output file. Its directory must exist. XDMF also writes ``<stem>.h5``,
        ``<stem>_facets.xdmf`` and ``<stem>_facets.h5`` beside it.
    format : str, optional
        One of ``fepre.export.FORMATS`` (abaqus, gmsh22, vtu, xdmf, nastran, medit, med, exodus;
        aliases calculix, gmsh); default from the extension.
    order : {1, 2}
        2 writes 10-node tetrahedra; boundary midside nodes are projected onto ``model`` (curved)
        where that keeps every Jacobian positive, straight midpoints otherwise or without a model.
    boundaries : dict name -> SDF or callable on (N, 3) points, optional
        A boundary face joins a set only if it lies on the set's zero set: its three nodes within
        ``boundary_tolerance`` x h of it (h the face's mean edge length), its centroid too (up to
        the sag of a face inscribed in a curved surface), its normal within ``boundary_angle`` of
        the function's gradient or of its opposite, of the gradient only where faces on the
        surface face both ways (:mod:`fepre.export.boundaries`). A face on two sets' surfaces
        goes to the nearer at its centroid, ties to the first name; the rest form
        ``"boundary"``. Each set becomes a face set (``*SURFACE``, physical surface, facet tag)
        and a node set; its face count and area are in the returned grid.
    regions : dict name -> SDF or callable, optional
        Cells whose centroid value is negative (first match wins) form a region (``*ELSET``,
        physical volume, cell tag); the rest form ``default_region``. Without it, a mesh with
        cell data ``region_id`` and field data ``region_names`` (``fepre.distmesh(...,
        regions=)``) keeps its regions.
    model : SDF, optional
        The part's model: named in file headers and used for curved midside nodes.
    overwrite : bool
        If False, refuse (FileExistsError) to replace an existing file.
    boundary_tolerance : float
        How far (a fraction of the local edge length h) a face's nodes may lie from a set's zero
        set, in (0, 0.25]; default 1e-3 (fepre's meshes put boundary nodes on the model far
        closer). A mesh made elsewhere whose nodes lie only near the model needs more: a
        ``BoundaryWarning`` says how far they lie and what value takes them.
    boundary_angle : float
        Largest angle (degrees) between a face's normal and the boundary function's gradient for
        the face to join that boundary (keeps faces next to sharp edges on their own side).
    default_region : str
        Name of the region of cells in no named region.
    materials : dict region name -> (E, nu) or {"E": ..., "nu": ...}, optional
        Isotropic elastic material of every region, written to an Abaqus/CalculiX file as one
        ``*MATERIAL`` and one ``*SOLID SECTION`` per region (other formats carry no materials).
    interfaces : bool, optional
        Write the faces between each pair of regions as a face set ``interface_<a>_<b>``
        (``*SURFACE`` on the side of region ``a``, physical surface, facet tag). Default: for a
        mesh that carries its regions (a conformal mesh from ``fepre.distmesh(...,
        regions=)``), not for regions given here.

    Returns
    -------
    pyvista.UnstructuredGrid
        The written mesh (``VTK_QUADRATIC_TETRA`` for order 2) with the input mesh's arrays, cell
        data ``"region_id"``, point data ``"boundary_id"`` (-1 inside), field data
        ``"region_names"``/``"boundary_names"``, ``"boundary_faces"`` (element, face 1..4, set
        of each boundary face; :func:`boundary_faces` gives them as triangles) and
        ``"boundary_face_counts"``/``"boundary_areas"`` (faces and area of each set, quadratic
        faces over their curved shape; :mod:`fepre.export.areas`). A VTU file holds
        this grid, except that the set names travel as integer field data ``name -> [index,
        dimension]`` (meshio cannot read string arrays): :func:`fepre.export.grid.set_names`
        reads them back from either form (:mod:`fepre.export.grid`). For order 2 also ``"curved_midside_nodes"`` (on the model surface) and
        ``"straightened_midside_nodes"`` (put back at midpoints to keep Jacobians valid). A periodic
        mesh (``fepre.distmesh(..., periodic=)``) keeps ``"periodic_lower"``/``"periodic_period"``
        and gains ``"periodic_anchor"``; its ``.inp`` holds the periodic ``*EQUATION`` constraints
        and three reference nodes (:mod:`fepre.export.abaqus`).
        :func:`tag_boundaries` gives the tagged boundary faces for viewing.

    Examples
    --------
    >>> import fepre, tempfile, os
    >>> from fepre import sdf
    >>> ball = sdf.sphere(1.0)
    >>> mesh = fepre.distmesh(ball, h=0.5)
    >>> out = fepre.export(mesh, os.path.join(tempfile.mkdtemp(), "ball.msh"), order=2, model=ball)
    >>> int(out.field_data["straightened_midside_nodes"][0]) < int(out.field_data["curved_midside_nodes"][0])
    True
    """
    path, fmt = _checked_target(path, format, order, overwrite, model)
    points, cells = tetra_arrays(mesh)
    faces, region_ids, region_names = _named_sets(
        mesh, points, cells, boundaries, regions, boundary_tolerance, boundary_angle, default_region, interfaces
    )
    section_table = sections(materials, region_names, fmt.name)
    midside = None
    if order == 2:
        quadratic = quadratic_tetrahedra(points, cells, faces.triangles[faces.on_boundary], model)
        points, cells = quadratic.points, quadratic.cells
        midside = (quadratic.curved, quadratic.straightened)
    title, model_text = _title(model)
    periodic, constraints = _periodic(mesh, points, cells)
    data = ExportData(
        points, cells, region_ids, region_names, faces, title, model_text,
        point_arrays={name: np.asarray(mesh.point_data[name]) for name in mesh.point_data.keys()},
        cell_arrays={name: np.asarray(mesh.cell_data[name]) for name in mesh.cell_data.keys()},
        periodic=periodic, constraints=constraints, sections=section_table,
    )
    with staged_files(path, fmt.outputs(path.name), overwrite) as stage:
        fmt.writer(stage, path.name, data)
    return _written_grid(data, midside, periodic)


def _checked_target(path: Any, format: str | None, order: Any, overwrite: Any, model: Any):
    """The output path and its format, once the arguments that decide what is written are
    checked (before any work)."""
    if not isinstance(path, (str, os.PathLike)):
        raise TypeError(f"path must be a str or os.PathLike; got {type(path).__name__}")
    path = Path(os.fspath(path))
    fmt = resolve_format(path, format)
    if isinstance(order, bool):
        raise TypeError("order must be 1 or 2; got a bool")
    choice(order, "order", (1, 2))
    if order not in fmt.orders:
        raise ValueError(f"order: format {fmt.name!r} supports order {fmt.orders}; got {order}")
    if not isinstance(overwrite, bool):
        raise TypeError(f"overwrite must be True or False; got {overwrite!r}")
    if model is not None and order == 2 and not callable(getattr(model, "project", None)):
        raise TypeError(f"model must be a fepre SDF (with .project) for order=2; got {type(model).__name__}")
    if fmt.backend is not None:
        require_module(*fmt.backend, fmt.name)
    return path, fmt


def _named_sets(mesh, points, cells, boundaries, regions, boundary_tolerance, boundary_angle, default_region, interfaces):
    """The boundary (and interface) face sets and the cells' regions: ``(faces, region_ids,
    region_names)``."""
    faces = assign_boundaries(points, cells, boundaries, boundary_tolerance, boundary_angle)
    carried = regions is None and "region_id" in mesh.cell_data and "region_names" in mesh.field_data
    if carried:
        region_ids, region_names = mesh_regions(mesh, len(cells))
    else:
        region_ids, region_names = assign_regions(points, cells, regions, default_region)
    if interfaces is not None and not isinstance(interfaces, bool):
        raise TypeError(f"interfaces must be True, False or None; got {interfaces!r}")
    if carried if interfaces is None else interfaces:
        faces = with_interfaces(faces, cells, region_ids, region_names)
    _check_name_clashes(region_names, faces.names)
    return faces, region_ids, region_names


def _written_grid(data: ExportData, midside: tuple[int, int] | None, periodic: Any):
    """The grid :func:`export` returns: the written mesh with its sets and the quadratic and
    periodic figures."""
    grid = tagged_grid(data, data.point_arrays, data.cell_arrays)
    if midside is not None:
        grid.field_data["curved_midside_nodes"] = np.array([midside[0]])
        grid.field_data["straightened_midside_nodes"] = np.array([midside[1]])
    if periodic is not None:
        from .abaqus import periodic_anchor

        grid.field_data["periodic_lower"] = periodic.lower
        grid.field_data["periodic_period"] = periodic.period
        grid.field_data["periodic_anchor"] = np.array([periodic_anchor(data)])
    return grid


def _periodic(mesh: Any, points: np.ndarray, cells: np.ndarray):
    """The periodic cell of ``mesh`` (field data from ``fepre.distmesh(..., periodic=)``) and the
    constraints over the written nodes, or ``(None, None)``."""
    field = mesh.field_data
    if "periodic_lower" not in field or "periodic_period" not in field:
        return None, None
    from ..periodic.cell import PeriodicCell
    from ..periodic.equations import periodic_constraints

    cell = PeriodicCell(np.asarray(field["periodic_lower"], dtype=np.float64).reshape(3),
                        np.asarray(field["periodic_period"], dtype=np.float64).reshape(3))
    return cell, periodic_constraints(points, cells, cell, 1e-9 * float(cell.period.max()))


make_callable(__name__, export)
