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
