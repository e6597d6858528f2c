"""Formats meshio writes correctly once given the right cell data: Gmsh 2.2, VTU, Nastran,
Medit, MED and Exodus.

Named sets travel as each format allows:

* Gmsh 2.2: physical groups (``gmsh:physical``; regions dim 3, boundaries dim 2, ids from 1)
  and their names in ``$PhysicalNames`` (meshio ``field_data`` name -> [id, dim]);
* VTU: the tagged grid of :mod:`fepre.export.grid` (tetrahedra only, the mesh's arrays, set
  names and boundary faces in field data), written by VTK;
* MED: element families (negative numbers) with group names (``cell_tags``); tetrahedra are
  written in MED's orientation, which is the opposite of VTK's;
* Nastran and Medit: integer property/reference ids only (regions 1..R on the tetrahedra,
  boundaries 1..B on the triangles); these formats hold no names.
"""

from __future__ import annotations

import importlib.util
from pathlib import Path

import numpy as np

from .data import ExportData

__all__ = ["write_gmsh22", "write_vtu", "write_nastran", "write_medit", "write_med", "write_exodus",
           "require_module", "named_field_data"]

# VTK -> MED node order (self-inverse): MED numbers tetrahedra with the opposite orientation.
MED_TETRA = np.array([0, 1, 3, 2])
MED_TETRA10 = np.array([0, 1, 3, 2, 4, 8, 7, 6, 5, 9])


def require_module(module: str, package: str, format_name: str) -> None:
    """Raise ImportError naming the package to install when a writer's backend is missing."""
    if importlib.util.find_spec(module) is None:
        raise ImportError(
            f"format {format_name!r} needs the Python package {package!r}, which is not installed; "
            f"install it with `pip install {package}`"
        )


def _types(data: ExportData) -> tuple[str, str]:
    return ("tetra10", "triangle6") if data.order == 2 else ("tetra", "triangle")


def named_field_data(data: ExportData) -> dict[str, np.ndarray]:
    """meshio/Gmsh style names: region -> [id, 3], boundary -> [id, 2] (ids from 1)."""
    fields = {name: np.array([i + 1, 3]) for i, name in enumerate(data.region_names)}
    fields.update({name: np.array([i + 1, 2]) for i, name in enumerate(data.boundary_names)})
    return fields


def _meshio_mesh(data: ExportData, cell_data: dict, **extra):
    import meshio

    volume, surface = _types(data)
    return meshio.Mesh(
        data.points,
        [(volume, data.cells), (surface, data.face_nodes)],
        cell_data=cell_data,
        **extra,
    )


def _tags(data: ExportData) -> list[np.ndarray]:
    return [data.region_ids + 1, data.faces.set_ids + 1]


def write_gmsh22(directory: Path, filename: str, data: ExportData) -> None:
    import meshio

    tags = _tags(data)
    mesh = _meshio_mesh(
        data, {"gmsh:physical": tags, "gmsh:geometrical": tags}, field_data=named_field_data(data)
    )
    meshio.write(directory / filename, mesh, file_format="gmsh22", binary=False)


def write_vtu(directory: Path, filename: str, data: ExportData) -> None:
    # VTK's own writer, of the grid fepre.export returns: the tetrahedra only, the mesh's arrays,
    # the set names and the boundary faces as field data (meshio's VTU writer drops field data).
    from .grid import file_grid, tagged_grid

    file_grid(tagged_grid(data, data.point_arrays, data.cell_arrays)).save(directory / filename, binary=True)


def write_nastran(directory: Path, filename: str, data: ExportData) -> None:
    import meshio

    # meshio prints coordinates with up to 17 characters into 16-character fields (it asserts on
    # negative numbers with 12 significant digits), so it writes the elements on zeroed nodes
    # and fepre writes the GRID* cards itself: large field, %16.9E (10 significant digits).
    volume, surface = _types(data)
    mesh = meshio.Mesh(
        np.zeros_like(data.points),
        [(volume, data.cells), (surface, data.face_nodes)],
        cell_data={"nastran:ref": _tags(data)},
    )
    meshio.write(directory / filename, mesh, file_format="nastran")
    target = directory / filename
    lines = target.read_text().splitlines(keepends=True)
    n_points = data.points.shape[0]
    header, body = lines[:2], lines[2 + 2 * n_points :]
    if not lines[2].startswith("GRID*") or body and body[0].startswith("*"):
        raise RuntimeError("unexpected layout of meshio's Nastran output")  # guards a meshio change
    table = np.empty((n_points, 5), dtype=object)
    table[:, 0] = np.arange(1, n_points + 1)
    table[:, 1] = ""
    table[:, 2:] = data.points
    grid = ("GRID*   %-16d%-16s%16.9E%16.9E\n*       %16.9E\n" * n_points) % tuple(table.ravel().tolist())
    target.write_text("".join(header) + grid + "".join(body))


def write_medit(directory: Path, filename: str, data: ExportData) -> None:
    import meshio

    mesh = _meshio_mesh(data, {"medit:ref": _tags(data)})
    meshio.write(directory / filename, mesh, file_format="medit")


def write_med(directory: Path, filename: str, data: ExportData) -> None:
    require_module("h5py", "h5py", "med")
    import meshio

    volume_families = -(data.region_ids + 1)
    face_families = -(len(data.region_names) + data.faces.set_ids + 1)
    permutation = MED_TETRA10 if data.order == 2 else MED_TETRA
    volume, surface = _types(data)
    mesh = meshio.Mesh(
        data.points,
        [(volume, data.cells[:, permutation]), (surface, data.face_nodes)],
        cell_data={"cell_tags": [volume_families, face_families]},
    )
    tags = {-(i + 1): [name] for i, name in enumerate(data.region_names)}
    tags.update({-(len(data.region_names) + i + 1): [n] for i, n in enumerate(data.boundary_names)})
    mesh.cell_tags = tags
    mesh.point_tags = {}
    meshio.write(directory / filename, mesh, file_format="med")


def write_exodus(directory: Path, filename: str, data: ExportData) -> None:
    require_module("netCDF4", "netCDF4", "exodus")
    import meshio

    point_sets = {name: data.face_set_nodes(i) for i, name in enumerate(data.boundary_names)}
    mesh = _meshio_mesh(data, {"region_id": _tags(data)}, point_sets=point_sets)
    meshio.write(directory / filename, mesh, file_format="exodus")
