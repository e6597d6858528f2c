"""Read a triangle mesh (a file or a PyVista surface) into plain vertex and face arrays."""

from __future__ import annotations

import os
from pathlib import Path
from typing import Any

import numpy as np

__all__ = ["read_triangles", "MeshInputError"]


class MeshInputError(ValueError):
    """A triangle mesh given as a model cannot be used: unreadable, empty, not finite, or with
    no inside. The message names the file (or ``PolyData``) and the problem."""


def _describe(source: Any) -> str:
    return str(source) if isinstance(source, (str, os.PathLike)) else type(source).__name__


def _as_polydata(source: Any, name: str):
    import pyvista as pv

    if isinstance(source, (str, os.PathLike)):
        path = Path(source)
        if not path.exists():
            raise MeshInputError(f"mesh file {path} does not exist")
        if path.is_dir():
            raise MeshInputError(f"mesh file {path} is a directory; give an STL, OBJ, PLY or other surface file")
        if path.stat().st_size == 0:
            from .cad_files import CAD_SUFFIXES

            kind = ("a STEP or BREP file that holds the part's solids" if path.suffix.lower() in CAD_SUFFIXES else
                    "an STL, OBJ, PLY or other surface file that holds the part's triangles")
            raise MeshInputError(f"mesh file {path} is empty (0 bytes); give {kind}")
        import warnings

        from ...vtk_messages import vtk_messages_kept

        own = _read_own_format(path)
        if own is not None:
            return own
        if path.suffix.lower() == ".stl":
            _check_binary_stl_length(path)
        if path.suffix.lower() == ".ply":
            _check_binary_ply_length(path)
        with warnings.catch_warnings(record=True) as caught, vtk_messages_kept():
            warnings.simplefilter("always")
            try:
                data = pv.read(path)
            except Exception as exc:  # readers raise anything from ValueError to VTK errors
                raise MeshInputError(f"mesh file {path} could not be read ({type(exc).__name__}: {exc})") from None
        failed = [w for w in caught if "error" in str(w.message).lower() or "fail" in str(w.message).lower()]
        if (data is None or (failed and data.n_points == 0)) and path.suffix.lower() == ".obj":
            data = _read_obj(path)
        if data is None or (failed and data.n_points == 0):
            raise MeshInputError(f"mesh file {path} could not be read (the reader failed: not a valid {path.suffix} "
                                 f"file?{_ascii_stl_cut_short(path)})")
    elif isinstance(source, pv.DataSet):
        data = source
    else:
        raise TypeError(
            f"source must be a path to a surface mesh file or a pyvista.PolyData; got {type(source).__name__}"
        )
    if isinstance(data, pv.MultiBlock):
        data = data.combine()
    if not isinstance(data, pv.PolyData):
        data = data.extract_surface(algorithm="dataset_surface")
    return data


def _check_binary_stl_length(path: Path) -> None:
    """A binary STL holds 84 bytes and then 50 per triangle, as many as its header counts; a file
    of another length that is not ASCII STL (no ``facet`` near its start) was cut short or
    padded. VTK's reader reads what is there without a word (a file cut after 10 of 1000
    triangles read as an open surface: "has no inside, volume -0.0376")."""
    size = path.stat().st_size
    with open(path, "rb") as stream:
        head = stream.read(1024)
    if size < 84 or b"facet" in head.lower():
        return
    count = int(np.frombuffer(head[80:84], dtype="<u4")[0])
    if size != 84 + 50 * count:
        holds = (size - 84) / 50
        raise MeshInputError(
            f"mesh file {path} is a damaged binary STL: its header counts {count} triangles "
            f"({84 + 50 * count} bytes), but the file has {size} bytes ({holds:.4g} triangles); "
            "it was cut short or is not an STL file"
        )


#: bytes of the PLY format's scalar types
_PLY_SIZES = {"char": 1, "uchar": 1, "int8": 1, "uint8": 1, "short": 2, "ushort": 2, "int16": 2, "uint16": 2,
              "int": 4, "uint": 4, "int32": 4, "uint32": 4, "float": 4, "float32": 4, "double": 8, "float64": 8}


def _check_binary_ply_length(path: Path) -> None:
    """A binary PLY holds at least what its header declares: each element's count times its
    properties' bytes, a list at least its count and, in a ``face`` element, three indices (all
    of them when every face has as many). A shorter file was cut short: VTK's reader crashed the
    process on one (horse.ply cut to 300 kB: a segmentation fault, no message)."""
    with open(path, "rb") as stream:
        head = stream.read(65536)
    if b"end_header" not in head:
        return
    text, _ = head.split(b"end_header", 1)
    start = len(text) + len(b"end_header") + (2 if head[len(text) + 10:len(text) + 12] == b"\r\n" else 1)
    lines = [line.split() for line in text.decode("latin-1").splitlines()]
    fmt = next((line[1] for line in lines if line[:1] == ["format"] and len(line) > 1), "ascii")
    if fmt == "ascii":
        _check_ascii_ply_lines(path, lines, start)
        return
    elements: list[list] = []  # [name, count, fixed bytes, [(count bytes, item bytes)]]
    for line in lines:
        try:
            if line[:1] == ["element"]:
                elements.append([line[1], int(line[2]), 0, []])
            elif line[:1] == ["property"] and elements:
                if line[1] == "list":
                    elements[-1][3].append((_PLY_SIZES[line[2]], _PLY_SIZES[line[3]]))
                else:
                    elements[-1][2] += _PLY_SIZES[line[1]]
        except (IndexError, KeyError, ValueError):
            return  # a header this check does not know: the reader's own errors stand
    size, least = path.stat().st_size, 0
    for name, count, fixed, lists in elements:
        per_item = 3 if name == "face" else 0
        least += count * (fixed + sum(c + per_item * i for c, i in lists))
    exact = _uniform_faces_end(path, elements, start)
    needed = exact if exact is not None else start + least
    if size < needed:
        declared = " and ".join(f"{count:,} '{name}'" for name, count, _, _ in elements) + " elements"
        raise MeshInputError(
            f"mesh file {path} is a damaged binary PLY: its header declares {declared} (at least {needed} bytes), "
            f"but the file has {size} bytes; it was cut short"
        )


def _check_ascii_ply_lines(path: Path, header: list, start: int) -> None:
    """An ASCII PLY holds a line for every item its header declares, the last one whole (a
    ``face``'s count and that many indices); a file cut short reached numpy's errors ("cannot
    reshape array of size 1786 into shape (4)")."""
    try:
        counts = [(line[1], int(line[2])) for line in header if line[:1] == ["element"]]
    except (IndexError, ValueError):
        return
    body = path.read_bytes()[start:].rstrip()
    rows = body.count(b"\n") + 1 if body else 0
    declared = sum(count for _, count in counts)
    whole = rows >= declared
    if whole and rows == declared and declared and counts[-1][0] == "face":
        last = body[body.rfind(b"\n") + 1:].split()
        whole = bool(last) and last[0].isdigit() and len(last) >= 1 + int(last[0])
    if not whole:
        listed = " and ".join(f"{count:,} '{name}'" for name, count in counts) + " elements"
        raise MeshInputError(
            f"mesh file {path} is a damaged ASCII PLY: its header declares {listed}, one line each "
            f"({declared:,} lines), but the file ends in line {rows:,} of them; it was cut short"
        )


def _uniform_faces_end(path: Path, elements: list, start: int) -> int | None:
    """Where a binary PLY whose last element is ``face`` (one list, every face as long as the
    first) ends, after the elements before it of fixed size; None when that cannot be told."""
    if not elements or elements[-1][0] != "face" or len(elements[-1][3]) != 1 or elements[-1][2]:
        return None
    if any(lists for _, _, _, lists in elements[:-1]):
        return None
    offset = start + sum(count * fixed for _, count, fixed, _ in elements[:-1])
    count, (count_bytes, item_bytes) = elements[-1][1], elements[-1][3][0]
    if count_bytes != 1 or count == 0:
        return None
    with open(path, "rb") as stream:
        stream.seek(offset)
        first = stream.read(1)
    if not first:
        return offset + 1
    stride = 1 + first[0] * item_bytes
    size = path.stat().st_size
    counts = np.memmap(path, dtype=np.uint8, mode="r", offset=offset)[: max(0, size - offset)][::stride]
    if counts.size < count:  # too few records: cut short whatever the rest holds
        return offset + count * stride
    return offset + count * stride if bool((counts[:count] == first[0]).all()) else None


def _ascii_stl_cut_short(path: Path) -> str:
    """``"; ..."`` naming an ASCII STL that ends before its ``endsolid`` line (cut short), else ''."""
    if path.suffix.lower() != ".stl":
        return ""
    with open(path, "rb") as stream:
        head = stream.read(1024).lower()
        stream.seek(max(0, path.stat().st_size - 1024))
        tail = stream.read().lower()
    if head.lstrip().startswith(b"solid") and b"facet" in head and b"endsolid" not in tail:
        return "; it is an ASCII STL with no 'endsolid' line at its end: cut short"
    return ""


def _read_own_format(path: Path):
    """The PolyData of an OFF file, a PLY file of triangle strips (formats VTK misses), the
    boundary of a volume mesh file or the tessellated solids of a CAD file, else None."""
    import pyvista as pv

    from .cad_files import CAD_SUFFIXES, FACE_SUFFIXES, read_cad_surface
    from .formats import ply_has_strips, read_off, read_ply_strips
    from .volume_files import VOLUME_SUFFIXES, read_volume_boundary

    suffix = path.suffix.lower()
    try:
        if suffix in VOLUME_SUFFIXES:
            return read_volume_boundary(path)
        if suffix in CAD_SUFFIXES:
            return read_cad_surface(path)
        if suffix in FACE_SUFFIXES:
            raise ValueError("an IGES file holds faces, not solids; export the part as STEP (or STL) instead")
        if suffix == ".off":
            return _polygon_surface(*read_off(path))
        if suffix == ".ply" and ply_has_strips(path):
            vertices, triangles = read_ply_strips(path)
            return pv.PolyData.from_regular_faces(vertices, triangles) if len(triangles) else pv.PolyData(vertices)
    except (ValueError, OSError, UnicodeError) as exc:
        raise MeshInputError(f"mesh file {path} could not be read: {exc}") from None
    return None


def _read_obj(path: Path):
    """An OBJ file VTK's reader failed on, read by :func:`.formats.read_obj`."""
    from .formats import read_obj

    try:
        return _polygon_surface(*read_obj(path))
    except (ValueError, OSError) as exc:
        raise MeshInputError(f"mesh file {path} could not be read: {exc}") from None


def _polygon_surface(vertices: np.ndarray, polygons: list[np.ndarray]):
    """A PolyData of ``polygons`` (index arrays; those under three vertices left out)."""
    import pyvista as pv

    polygons = [p for p in polygons if len(p) >= 3]
    if not polygons:
        return pv.PolyData(vertices)
    sizes = np.fromiter(map(len, polygons), dtype=np.int64, count=len(polygons))
    faces = np.empty(len(polygons) + int(sizes.sum()), dtype=np.int64)
    heads = np.cumsum(sizes + 1) - sizes - 1
    corner = np.ones(len(faces), dtype=bool)
    corner[heads] = False
    faces[heads], faces[corner] = sizes, np.concatenate(polygons)
    return pv.PolyData(vertices, faces=faces)


def read_triangles(source: Any) -> tuple[np.ndarray, np.ndarray, str]:
    """Vertices (V, 3) float64, triangles (F, 3) int64 and a name for messages.

    Polygons and triangle strips are triangulated; lines and vertices are ignored. Files are read
    by VTK's readers (STL, OBJ, PLY, VTK formats), except OFF, PLY triangle strips and OBJ files
    VTK's reader fails on (:mod:`fepre.sdf.meshmodel.formats`), volume meshes (their boundary)
    and STEP and BREP files (tessellated, :mod:`fepre.sdf.meshmodel.cad_files`).

    Raises
    ------
    MeshInputError
        The file is missing or unreadable, holds no triangles, or has non-finite coordinates.
    """
    name = _describe(source)
    data = _as_polydata(source, name)
    if np.asarray(data.faces).size == 0 and data.n_strips == 0:
        raise MeshInputError(
            f"{name} holds no surface faces (points {data.n_points}, cells {data.n_cells}, none of them polygons)"
        )
    if not data.is_all_triangles:
        data = data.triangulate()
    faces = np.asarray(data.faces)
    faces = faces.reshape(-1, 4)
    if not np.all(faces[:, 0] == 3):
        raise MeshInputError(f"{name} could not be triangulated")
    vertices = np.asarray(data.points, dtype=np.float64)
    triangles = faces[:, 1:].astype(np.int64)
    if triangles.min() < 0 or triangles.max() >= len(vertices):
        outside = triangles[(triangles < 0) | (triangles >= len(vertices))]
        raise MeshInputError(
            f"{name} has {len(np.unique(outside))} face corner(s) that refer to no vertex: it has "
            f"{len(vertices)} vertices, and a face refers to vertex index {int(outside[0])} (counting from 0); "
            "the file is damaged or truncated"
        )
    used = np.unique(triangles)
    bad = ~np.isfinite(vertices[used]).all(axis=1)
    if bad.any():
        first = int(used[np.argmax(bad)])
        raise MeshInputError(
            f"{name} has {int(bad.sum())} vertices with non-finite coordinates (NaN or inf), "
            f"for example vertex {first} at {vertices[first].tolist()}"
        )
    return vertices, triangles, name
