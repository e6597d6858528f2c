"""fepre's own Abaqus/CalculiX ``.inp`` writer.

meshio's Abaqus writer names 10-node tetrahedra ``C3D10MH``, writes no ``*SURFACE`` and prints
coordinates wider than the 20 characters CalculiX reads per field. This writer emits:

* ``*HEADING`` naming fepre and the model (the model tree follows as ``**`` comments);
* ``*NODE, NSET=NALL`` with ``%.12e`` coordinates (at most 20 characters);
* ``*ELEMENT, TYPE=C3D4`` or ``C3D10, ELSET=EALL`` (element id = cell index + 1, node order of
  VTK which C3D10 shares), then one ``*ELSET`` per region;
* for every named boundary a ``*NSET`` of its nodes and an element-face ``*SURFACE`` (``S1``..``S4``);
  likewise for every interface between two regions (``interface_<a>_<b>``, faces of region ``a``'s
  elements);
* with ``materials=``, one ``*MATERIAL`` (named after its region, ``*ELASTIC`` E, nu) and one
  ``*SOLID SECTION`` per region;
* for a periodic cell (:func:`fepre.distmesh` with ``periodic=``), three reference nodes after the
  mesh's (``*NSET`` ``PBC_REF`` and ``PBC_REFX``, ``PBC_REFY``, ``PBC_REFZ``; their displacements
  are the cell's periods times the columns of the macroscopic displacement gradient), a node
  ``PBC_ANCHOR`` to hold against rigid translation, the nodes on the faces (and the anchor) as
  ``PBC_FACES``, and the ``*EQUATION`` constraints tying each upper-face node to its partner
  (:mod:`fepre.periodic.equations`).

Without ``materials=`` the file holds the mesh only (no material or step), ready for
``*INCLUDE, INPUT=part.inp``; with it, a job needs only its steps.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from .data import ExportData

__all__ = ["write_inp", "RESERVED_NAMES"]

RESERVED_NAMES = ("NALL", "EALL", "PBC_REF", "PBC_REFX", "PBC_REFY", "PBC_REFZ", "PBC_ANCHOR", "PBC_FACES")
IDS_PER_LINE = 16


def _rows(fmt: str, table: np.ndarray) -> str:
    """Format every row of ``table`` with ``fmt`` in one C-level ``%`` operation."""
    if table.shape[0] == 0:
        return ""
    return (fmt * table.shape[0]) % tuple(table.ravel().tolist())


def _id_lines(ids: np.ndarray) -> str:
    """1-based ids, ``IDS_PER_LINE`` per line, comma separated."""
    ids = np.asarray(ids, dtype=np.int64)
    full = ids.size // IDS_PER_LINE * IDS_PER_LINE
    text = _rows(", ".join(["%d"] * IDS_PER_LINE) + "\n", ids[:full].reshape(-1, IDS_PER_LINE))
    if full < ids.size:
        text += ", ".join(map(str, ids[full:].tolist())) + "\n"
    return text


def inp_text(data: ExportData) -> str:
    """The whole ``.inp`` file as a string."""
    n_nodes = data.points.shape[0]
    element_type = "C3D10" if data.order == 2 else "C3D4"
    parts = ["*HEADING\n", data.title.replace("\n", " ")[:200], "\n"]
    for line in data.model_text.splitlines():
        parts.append(f"** {line}\n")
    parts.append(
        f"** {n_nodes} nodes, {data.cells.shape[0]} {element_type} elements, regions "
        f"{', '.join(data.region_names)}; boundaries {', '.join(data.boundary_names)}\n"
    )
    parts.append("*NODE, NSET=NALL\n")
    node_table = np.column_stack([np.arange(1, n_nodes + 1, dtype=np.float64), data.points])
    parts.append(_rows("%d, %.12e, %.12e, %.12e\n", node_table))
    parts.append(f"*ELEMENT, TYPE={element_type}, ELSET=EALL\n")
    element_table = np.column_stack([np.arange(1, data.cells.shape[0] + 1), data.cells + 1])
    parts.append(_rows(", ".join(["%d"] * element_table.shape[1]) + "\n", element_table))
    for index, name in enumerate(data.region_names):
        parts.append(f"*ELSET, ELSET={name}\n")
        parts.append(_id_lines(np.flatnonzero(data.region_ids == index) + 1))
    faces = data.faces
    for index, name in enumerate(data.boundary_names):
        members = faces.set_ids == index
        if not members.any():
            continue
        parts.append(f"*NSET, NSET={name}\n")
        parts.append(_id_lines(data.face_set_nodes(index) + 1))
        parts.append(f"*SURFACE, NAME={name}, TYPE=ELEMENT\n")
        surface = np.column_stack([faces.elements[members] + 1, faces.local_faces[members] + 1])
        parts.append(_rows("%d, S%d\n", surface))
    if data.sections is not None:
        from .sections import section_text

        parts.append(section_text(data.sections))
    if data.periodic is not None:
        parts.append(_periodic_text(data))
    return "".join(parts)


def _periodic_text(data: ExportData) -> str:
    from ..periodic.equations import equation_text

    n = data.points.shape[0]
    cell = data.periodic
    references = (n + 1, n + 2, n + 3)
    lines = ["** periodic cell: lower corner %s, periods %s\n" % (cell.lower.tolist(), cell.period.tolist())]
    lines.append("*NODE, NSET=PBC_REF\n")
    for k, node in enumerate(references):
        position = cell.upper + 0.5 * cell.period * np.eye(3)[k]
        lines.append("%d, %.12e, %.12e, %.12e\n" % (node, *position))
    for k, node in enumerate(references):
        lines.append(f"*NSET, NSET=PBC_REF{'XYZ'[k]}\n{node}\n")
    anchor = periodic_anchor(data)
    lines.append(f"*NSET, NSET=PBC_ANCHOR\n{anchor + 1}\n")
    on_faces = cell.on_planes(data.points, 1e-9 * float(cell.period.max())).any(axis=1)
    on_faces[anchor] = True
    lines.append("*NSET, NSET=PBC_FACES\n" + _id_lines(np.flatnonzero(on_faces) + 1))
    lines.append(equation_text(data.constraints, n, references))
    return "".join(lines)


def periodic_anchor(data: ExportData) -> int:
    """The first node (0-based) that no periodic constraint makes dependent."""
    dependent = np.zeros(data.points.shape[0], bool)
    dependent[data.constraints.dependent] = True
    return int(np.argmin(dependent))


def write_inp(directory: Path, filename: str, data: ExportData) -> None:
    """Write ``directory / filename``."""
    with open(directory / filename, "w", encoding="ascii", newline="\n") as handle:
        handle.write(inp_text(data))
