"""XDMF for FEniCSx/dolfinx: cells and facet tags in separate files, as dolfinx expects.

``part.xdmf`` holds the tetrahedra with cell data ``"region_id"`` (regions 1..R); ``part_facets.xdmf``
holds the boundary triangles on the same nodes with cell data ``"boundary_id"`` (1..B). Both carry
HDF5 sidecars (``part.h5``, ``part_facets.h5``) and name their ids in an ``Information`` element
that meshio reads back as ``field_data`` (name -> [id, dim]).

In dolfinx::

    with XDMFFile(comm, "part.xdmf", "r") as f:
        mesh = f.read_mesh(name="Grid"); cell_tags = f.read_meshtags(mesh, name="Grid")
    mesh.topology.create_connectivity(2, 3)
    with XDMFFile(comm, "part_facets.xdmf", "r") as f:
        facet_tags = f.read_meshtags(mesh, name="Grid")
"""

from __future__ import annotations

import xml.etree.ElementTree as ET
from pathlib import Path

from .data import ExportData
from .meshio_formats import require_module

__all__ = ["write_xdmf", "xdmf_outputs", "facets_name"]


def facets_name(filename: str) -> str:
    stem, _, suffix = filename.rpartition(".")
    return f"{stem}_facets.{suffix}"


def xdmf_outputs(filename: str) -> list[str]:
    """Every file the XDMF writer produces for ``filename``."""
    facets = facets_name(filename)
    return [filename, filename.rpartition(".")[0] + ".h5", facets, facets.rpartition(".")[0] + ".h5"]


def _add_names(path: Path, names: dict[str, tuple[int, int]]) -> None:
    tree = ET.parse(path)
    grid = tree.getroot().find("Domain/Grid")
    info = ET.SubElement(grid, "Information", Name="Information", Value=str(len(names)))
    info.text = "<main>" + "".join(
        f'<map key="{name}" dim="{dim}">{tag}</map>' for name, (tag, dim) in names.items()
    ) + "</main>"
    tree.write(path, xml_declaration=True, encoding="utf-8")


def write_xdmf(directory: Path, filename: str, data: ExportData) -> None:
    require_module("h5py", "h5py", "xdmf")
    import meshio

    volume, surface = ("tetra10", "triangle6") if data.order == 2 else ("tetra", "triangle")
    cells = meshio.Mesh(data.points, [(volume, data.cells)], cell_data={"region_id": [data.region_ids + 1]})
    facets = meshio.Mesh(
        data.points, [(surface, data.face_nodes)], cell_data={"boundary_id": [data.faces.set_ids + 1]}
    )
    meshio.write(directory / filename, cells, file_format="xdmf")
    meshio.write(directory / facets_name(filename), facets, file_format="xdmf")
    _add_names(directory / filename, {n: (i + 1, 3) for i, n in enumerate(data.region_names)})
    _add_names(directory / facets_name(filename), {n: (i + 1, 2) for i, n in enumerate(data.boundary_names)})
