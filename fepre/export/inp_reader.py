"""Read Abaqus/CalculiX ``.inp`` meshes of tetrahedra back, with their element and face sets.

VTK's AVS UCD reader also claims ``.inp`` and returns an empty grid for an Abaqus file; fepre
registers this reader with PyVista (entry point ``pyvista.readers.override``), so
``pv.read("part.inp")`` gives the tagged grid of :mod:`fepre.export.grid`.

Read: ``*NODE``; ``*ELEMENT`` of types C3D4 and C3D10 (any C3D4*/C3D10* variant; continuation
lines allowed); ``*ELSET`` (id lists, ``GENERATE``, other sets' names) as regions;
``*SURFACE, TYPE=ELEMENT`` (element or element set, face ``S1``..``S4``) as boundary sets. Other
keywords (materials, steps, ``*NSET``) are skipped; ``*INCLUDE`` is refused with its file named.
"""

from __future__ import annotations

import os
import re
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from .boundaries import OUTWARD_FACES, FaceSets
from .data import ExportData
from .grid import tagged_grid

__all__ = ["read_inp"]

_COMMENT = re.compile(r"^\s*\*\*.*$", flags=re.M)
_KEYWORD_LINE = re.compile(r"^\s*\*", flags=re.M)
_TETRA_NODES = {"C3D4": 4, "C3D10": 10}


def _blocks(text: str) -> list[tuple[str, dict[str, str], str]]:
    """(keyword, options, data text) of every keyword block, comments dropped."""
    blocks = []
    for chunk in _KEYWORD_LINE.split(_COMMENT.sub("", text))[1:]:
        head, _, body = chunk.partition("\n")
        fields = [f.strip() for f in head.split(",")]
        options = {}
        for field in fields[1:]:
            key, _, value = field.partition("=")
            options[key.strip().upper()] = value.strip()
        blocks.append((fields[0].upper(), options, body))
    return blocks


def _words(body: str) -> list[str]:
    return [w for w in body.replace("\n", ",").replace(" ", "").replace("\t", "").split(",") if w]


def _numbers(body: str, path: Path, keyword: str) -> np.ndarray:
    try:
        return np.array(_words(body), dtype=np.float64)
    except ValueError:
        raise ValueError(f"{path}: *{keyword} holds a value that is not a number") from None


def read_inp(path: str | os.PathLike, **reader_options: Any) -> Any:
    """Read a tetrahedral Abaqus/CalculiX ``.inp`` mesh (as fepre writes it) into a tagged grid.

    Parameters
    ----------
    path : str or path-like
    **reader_options
        Ignored: :func:`pyvista.read` passes its own options (such as ``progress_bar``) on.

    Returns
    -------
    pyvista.UnstructuredGrid
        ``VTK_TETRA`` or ``VTK_QUADRATIC_TETRA`` cells with cell data ``"region_id"`` (one region
        per ``*ELSET`` other than ``EALL``), point data ``"boundary_id"``, field data
        ``"region_names"``, ``"boundary_names"``, ``"boundary_faces"`` (one set per element
        ``*SURFACE``) and each set's ``"boundary_face_counts"`` and ``"boundary_areas"``;
        :func:`fepre.export.boundary_faces` gives the faces as triangles.

    Examples
    --------
    >>> import fepre, tempfile, os, pyvista as pv
    >>> from fepre import sdf
    >>> path = os.path.join(tempfile.mkdtemp(), "cube.inp")
    >>> _ = fepre.export(fepre.distmesh(sdf.box(1.0), h=0.5), path,
    ...                  boundaries={"top": sdf.plane((0, 0, 1), (0, 0, 0.5))})
    >>> grid = pv.read(path)
    >>> grid.field_data["boundary_names"].tolist()
    ['top', 'boundary']
    """
    path = Path(os.fspath(path))
    parsed = _parse(path)
    points, ids, cells = _mesh_arrays(parsed, path)
    sets = _ElementSets(path, ids, parsed.elsets)
    region_ids, region_names = _regions(sets)
    faces = _face_sets(sets, parsed.surfaces, cells)
    data = ExportData(points, cells, region_ids, region_names, faces, f"read from {path.name}")
    return tagged_grid(data)


@dataclass
class _Parsed:
    """The blocks of a ``.inp`` file that fepre reads, as found (ids, not yet indices)."""

    node_ids: list[np.ndarray] = field(default_factory=list)
    coordinates: list[np.ndarray] = field(default_factory=list)
    element_ids: list[np.ndarray] = field(default_factory=list)
    connectivity: list[np.ndarray] = field(default_factory=list)
    width: int | None = None  # nodes per element
    elsets: dict[str, list[np.ndarray | str]] = field(default_factory=dict)  # ids, or other sets' names
    surfaces: dict[str, list[tuple[Any, Any]]] = field(default_factory=dict)  # (elements or set name, face)


def _parse(path: Path) -> _Parsed:
    """Every ``*NODE``, tetrahedral ``*ELEMENT``, ``*ELSET`` and element ``*SURFACE`` block."""
    parsed = _Parsed()
    for keyword, options, body in _blocks(path.read_text(encoding="ascii", errors="replace")):
        if keyword == "INCLUDE":
            raise ValueError(f"{path}: *INCLUDE of {options.get('INPUT', '?')!r} is not followed; read that file")
        if keyword == "NODE" and body.strip():
            table = _numbers(body, path, keyword).reshape(-1, 4)
            parsed.node_ids.append(table[:, 0].astype(np.int64))
            parsed.coordinates.append(table[:, 1:])
        elif keyword == "ELEMENT":
            _read_elements(parsed, options, body, path)
        elif keyword == "ELSET" and "ELSET" in options:
            _read_elset(parsed.elsets.setdefault(options["ELSET"], []), options, body)
        elif keyword == "SURFACE" and options.get("TYPE", "ELEMENT").upper() == "ELEMENT" and "NAME" in options:
            _read_surface(parsed.surfaces.setdefault(options["NAME"], []), options["NAME"], body, path)
    return parsed


def _read_elements(parsed: _Parsed, options: dict[str, str], body: str, path: Path) -> None:
    kind = options.get("TYPE", "").upper()
    count = next((n for prefix, n in _TETRA_NODES.items() if kind.startswith(prefix)), None)
    if count is None:
        raise ValueError(f"{path}: element type {kind or '(none)'!r} is not a tetrahedron (C3D4 or C3D10)")
    if parsed.width is not None and parsed.width != count:
        raise ValueError(f"{path}: mixes C3D4 and C3D10 elements; fepre reads one kind per file")
    parsed.width = count
    table = _numbers(body, path, "ELEMENT").reshape(-1, count + 1).astype(np.int64)
    parsed.element_ids.append(table[:, 0])
    parsed.connectivity.append(table[:, 1:])
    if "ELSET" in options:
        parsed.elsets.setdefault(options["ELSET"], []).append(table[:, 0])


def _read_elset(members: list[np.ndarray | str], options: dict[str, str], body: str) -> None:
    words = _words(body)
    if "GENERATE" in options:
        numbers = np.array(words, dtype=np.int64).reshape(-1, 3)
        members.extend(np.arange(a, b + 1, c) for a, b, c in numbers.tolist())
    else:
        numeric = [w for w in words if w.lstrip("-").isdigit()]
        members.append(np.array(numeric, dtype=np.int64))
        members.extend(w for w in words if not w.lstrip("-").isdigit())


def _read_surface(entries: list[tuple[Any, Any]], name: str, body: str, path: Path) -> None:
    words = np.array(_words(body), dtype=object).reshape(-1, 2) if body.strip() else np.zeros((0, 2), object)
    labels = np.char.upper(words[:, 1].astype(str))
    bad = ~np.isin(labels, ["S1", "S2", "S3", "S4"])
    if bad.any():
        raise ValueError(f"{path}: *SURFACE {name}: face {labels[bad][0]!r} is not S1..S4")
    numeric = np.char.isdigit(words[:, 0].astype(str))
    faces_of = np.char.lstrip(labels, "S").astype(np.int64)
    if numeric.any():
        entries.append((words[numeric, 0].astype(np.int64), faces_of[numeric]))
    entries.extend((str(owner), int(face)) for owner, face in zip(words[~numeric, 0], faces_of[~numeric]))


def _mesh_arrays(parsed: _Parsed, path: Path) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Points sorted by node id, element ids, and cells as indices into the points."""
    if not parsed.node_ids or not parsed.element_ids:
        raise ValueError(f"{path}: no *NODE or no tetrahedral *ELEMENT block; not a tetrahedral mesh")
    node_ids_all, points = np.concatenate(parsed.node_ids), np.vstack(parsed.coordinates)
    order = np.argsort(node_ids_all, kind="stable")
    node_ids_all, points = node_ids_all[order], points[order]
    ids, cells = np.concatenate(parsed.element_ids), np.vstack(parsed.connectivity)
    position = np.searchsorted(node_ids_all, cells)
    if np.any(position >= node_ids_all.size) or np.any(node_ids_all[np.minimum(position, node_ids_all.size - 1)] != cells):
        raise ValueError(f"{path}: an element names a node that no *NODE block defines")
    return points, ids, position


class _ElementSets:
    """Element ids to cell indices, and the members of named element sets (sets may name sets)."""

    def __init__(self, path: Path, ids: np.ndarray, elsets: dict[str, list[np.ndarray | str]]):
        self.path, self.ids, self.elsets = path, ids, elsets

    def index(self, element_ids_wanted: np.ndarray, what: str) -> np.ndarray:
        ids = self.ids
        sorter = np.argsort(ids, kind="stable")
        where = np.searchsorted(ids, element_ids_wanted, sorter=sorter)
        where = sorter[np.minimum(where, ids.size - 1)]
        if np.any(ids[where] != element_ids_wanted):
            raise ValueError(f"{self.path}: {what} names an element that no *ELEMENT block defines")
        return where

    def members(self, name: str, seen: tuple[str, ...] = ()) -> np.ndarray:
        if name not in self.elsets or name in seen:
            raise ValueError(f"{self.path}: element set {name!r} is not defined")
        parts = [m if isinstance(m, np.ndarray) else self.members(m, seen + (name,)) for m in self.elsets[name]]
        return np.concatenate(parts) if parts else np.zeros(0, dtype=np.int64)


def _regions(sets: _ElementSets) -> tuple[np.ndarray, list[str]]:
    """One region per ``*ELSET`` but ``EALL`` (first set wins), the rest in one more."""
    region_names = [name for name in sets.elsets if name.upper() != "EALL"]
    region_ids = np.full(sets.ids.size, -1, dtype=np.int64)
    for index, name in enumerate(region_names):
        cells_in = sets.index(sets.members(name), f"*ELSET {name}")
        unassigned = cells_in[region_ids[cells_in] < 0]
        region_ids[unassigned] = index
    if np.any(region_ids < 0):
        region_ids[region_ids < 0] = len(region_names)
        region_names.append("EALL" if "EALL" in {n.upper() for n in sets.elsets} else "volume")
    return region_ids, region_names


def _face_sets(sets: _ElementSets, surfaces: dict[str, list[tuple[Any, Any]]], cells: np.ndarray) -> FaceSets:
    """The element faces of every ``*SURFACE``, outward, as one set each."""
    face_elements, face_numbers, face_sets = [], [], []
    for index, (name, entries) in enumerate(surfaces.items()):
        for owner, face in entries:  # one numeric block per *SURFACE line group, one entry per element set
            if isinstance(owner, np.ndarray):
                members, numbers = sets.index(owner, f"*SURFACE {name}"), face - 1
            else:
                members = sets.index(sets.members(owner), f"*SURFACE {name}")
                numbers = np.full(members.size, face - 1)
            face_elements.append(members)
            face_numbers.append(numbers)
            face_sets.append(np.full(members.size, index))
    elements = np.concatenate(face_elements) if face_elements else np.zeros(0, dtype=np.int64)
    local = np.concatenate(face_numbers) if face_numbers else np.zeros(0, dtype=np.int64)
    triangles = np.take_along_axis(cells[elements][:, :4], OUTWARD_FACES[local], axis=1)
    return FaceSets(elements, local, triangles, np.concatenate(face_sets) if face_sets else local.copy(), list(surfaces))
