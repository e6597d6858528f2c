"""Surface files that VTK's readers miss: OFF polygons, PLY triangle strips, OBJ files it fails on.

``pv.read`` (VTK's readers) reads STL (ASCII and binary, several solids), OBJ (polygons, negative
indices, groups), PLY faces (``vertex_indices`` or ``vertex_index``, extra properties) and the VTK
formats. Two common cases it does not:

- OFF (Geomview's Object File Format, common in geometry processing data sets): VTK has no reader,
  and meshio's reads triangles only. :func:`read_off` reads polygons, comments and the ``C``/``N``/
  ``ST`` header variants (extra columns after a vertex's coordinates or a face's indices are
  skipped).
- PLY files whose surface is stored as triangle strips (an element ``tristrips`` with one list
  ``vertex_indices``, strips separated by -1, as Stanford's scanned models are): VTK reads the
  points and no faces. :func:`read_ply_strips` reads them with plyfile (the reference reader of the
  format, any element) and unrolls the strips.
- OBJ files VTK's reader fails on, as Rhino writes them: an empty material name after
  ``usemtl``, faces continued over lines ending in a backslash. :func:`read_obj` reads vertices and
  polygons (``v/vt/vn`` corners, negative indices) and skips everything else.
"""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np

__all__ = ["read_obj", "read_off", "read_ply_strips", "ply_has_strips", "strip_triangles"]

#: OFF headers with 3D vertices: texture coordinates (ST), colours (C), normals (N) follow them
OFF_HEADERS = {f"{st}{c}{n}OFF" for st in ("", "ST") for c in ("", "C") for n in ("", "N")}


def strip_triangles(indices: np.ndarray) -> np.ndarray:
    """Triangles (F, 3) of triangle strips given as one index list with -1 between strips.

    The k-th triangle of a strip is ``(s[k], s[k+1], s[k+2])`` for even k and
    ``(s[k+1], s[k], s[k+2])`` for odd k, so that all keep the first one's orientation; the
    degenerate triangles strips use to turn (a repeated index) are dropped.

    Examples
    --------
    >>> strip_triangles(np.array([0, 1, 2, 3, -1, 4, 5, 6])).tolist()
    [[0, 1, 2], [2, 1, 3], [4, 5, 6]]
    """
    a = np.asarray(indices, dtype=np.int64).ravel()
    if len(a) < 3:
        return np.zeros((0, 3), np.int64)
    start = np.arange(len(a) - 2)
    valid = (a[start] >= 0) & (a[start + 1] >= 0) & (a[start + 2] >= 0)
    # position of each strip's first index: one past the last -1 before it
    restart = np.where(a < 0, np.arange(len(a)), -1)
    strip_start = np.maximum.accumulate(restart) + 1
    odd = ((start - strip_start[start]) % 2).astype(bool)
    first = np.where(odd, a[start + 1], a[start])
    second = np.where(odd, a[start], a[start + 1])
    triangles = np.stack([first, second, a[start + 2]], axis=1)[valid]
    distinct = (triangles[:, 0] != triangles[:, 1]) & (triangles[:, 1] != triangles[:, 2]) & (triangles[:, 0] != triangles[:, 2])
    return triangles[distinct]


def ply_has_strips(path: str | os.PathLike) -> bool:
    """Whether the PLY file's header declares a ``tristrips`` element and no ``face`` element."""
    with open(path, "rb") as stream:
        header = stream.read(65536).split(b"end_header", 1)[0]
    elements = [line.split()[1] for line in header.splitlines() if line.startswith(b"element ") and len(line.split()) > 1]
    return b"tristrips" in elements and b"face" not in elements


def read_ply_strips(path: str | os.PathLike) -> tuple[np.ndarray, np.ndarray]:
    """Vertices (V, 3) and triangles (F, 3) of a PLY file whose surface is triangle strips.

    Raises
    ------
    ValueError
        The file has no ``vertex`` element with ``x``, ``y``, ``z``, or no list in ``tristrips``, or
        ends before its elements do.
    """
    from plyfile import PlyData, PlyParseError

    try:
        data = PlyData.read(str(path))
    except PlyParseError as exc:  # a file cut short: "early end-of-file" in an element
        raise ValueError(f"not a readable PLY file ({exc})") from None
    names = [element.name for element in data.elements]
    if "vertex" not in names or not {"x", "y", "z"} <= set(data["vertex"].data.dtype.names):
        raise ValueError(f"no 'vertex' element with x, y, z properties (elements: {names})")
    vertex = data["vertex"].data
    vertices = np.stack([np.asarray(vertex[k], dtype=np.float64) for k in "xyz"], axis=1)
    strips = data["tristrips"].data
    lists = [name for name in strips.dtype.names if strips.dtype[name] == object]
    if not lists:
        raise ValueError(f"the 'tristrips' element has no list of vertex indices")
    key = "vertex_indices" if "vertex_indices" in lists else lists[0]
    pieces = [np.append(np.asarray(row, dtype=np.int64), -1) for row in strips[key]]
    flat = np.concatenate(pieces) if pieces else np.zeros(0, np.int64)
    return vertices, strip_triangles(flat)


def _numbers(lines: list[str], start: int, count: int) -> tuple[list[list[str]], int]:
    rows = []
    while len(rows) < count:
        if start >= len(lines):
            raise ValueError(f"the file ends after {len(rows)} of {count} rows")
        words = lines[start].split("#", 1)[0].split()
        start += 1
        if words:
            rows.append(words)
    return rows, start


def read_off(path: str | os.PathLike) -> tuple[np.ndarray, list[np.ndarray]]:
    """Vertices (V, 3) and polygons (each an index array) of an OFF file.

    Raises
    ------
    ValueError
        The header is not OFF (or COFF, NOFF, CNOFF, STOFF, ...), the counts are missing, a face
        names a vertex that does not exist, or the file ends early.
    """
    text = Path(path).read_text(encoding="utf-8", errors="replace")
    lines = text.splitlines()
    position = 0
    while position < len(lines) and not lines[position].split("#", 1)[0].strip():
        position += 1
    if position == len(lines):
        raise ValueError(f"empty file")
    words = lines[position].split("#", 1)[0].split()
    position += 1
    if words[0] not in OFF_HEADERS:
        raise ValueError(f"not an OFF file (the first word is {words[0]!r}, expected OFF, COFF, NOFF, STOFF, ...)")
    counts = words[1:]
    if len(counts) < 2:
        if not any(line.split("#", 1)[0].strip() for line in lines[position:]):
            raise ValueError("the vertex and face counts are missing after the OFF header")
        rows, position = _numbers(lines, position, 1)
        counts = rows[0]
    try:
        n_vertices, n_faces = int(counts[0]), int(counts[1])
    except (ValueError, IndexError):
        raise ValueError(f"the vertex and face counts are missing after the OFF header") from None
    rows, position = _numbers(lines, position, n_vertices)
    try:
        vertices = np.array([[float(v) for v in row[:3]] for row in rows], dtype=np.float64).reshape(-1, 3)
    except ValueError as exc:
        raise ValueError(f"a vertex line is not three numbers ({exc})") from None
    rows, position = _numbers(lines, position, n_faces)
    polygons = []
    for row in rows:
        size = int(row[0])
        polygon = np.array(row[1 : 1 + size], dtype=np.int64)
        if len(polygon) != size or (polygon < 0).any() or (polygon >= n_vertices).any():
            raise ValueError(f"face {' '.join(row)} names vertices outside 0..{n_vertices - 1} or too few")
        polygons.append(polygon)
    return vertices, polygons


def read_obj(path: str | os.PathLike) -> tuple[np.ndarray, list[np.ndarray]]:
    """Vertices (V, 3) and polygons (each an index array) of a Wavefront OBJ file.

    Lines ending in a backslash continue on the next; a face corner ``v/vt/vn`` is its vertex
    index, counted from 1 or, when negative, back from the latest vertex. Other statements
    (groups, materials, texture coordinates, normals, lines, points) are skipped.

    Raises
    ------
    ValueError
        A vertex line is not three numbers, or a face names a vertex that does not exist.

    Examples
    --------
    >>> import tempfile, os
    >>> text = "v 0 0 0\\nv 1 0 0\\nv 0 1 0\\nusemtl \\nf 1/1/1 \\\\\\n 2/2/2 -1\\n"
    >>> with tempfile.TemporaryDirectory() as folder:
    ...     path = os.path.join(folder, "t.obj")
    ...     _ = open(path, "w").write(text)
    ...     vertices, polygons = read_obj(path)
    >>> len(vertices), polygons[0].tolist()
    (3, [0, 1, 2])
    """
    text = Path(path).read_text(encoding="utf-8", errors="replace").replace("\\\r\n", " ").replace("\\\n", " ")
    vertices: list[list[float]] = []
    polygons = []
    for number, line in enumerate(text.splitlines(), 1):
        words = line.split("#", 1)[0].split()
        if not words:
            continue
        if words[0] == "v":
            try:
                vertices.append([float(w) for w in words[1:4]])
            except ValueError:
                raise ValueError(f"line {number}: a vertex is not three numbers: {line.strip()[:80]!r}") from None
            if len(vertices[-1]) != 3:
                raise ValueError(f"line {number}: a vertex is not three numbers: {line.strip()[:80]!r}")
        elif words[0] in ("f", "fo"):
            try:
                corners = np.array([int(w.split("/", 1)[0]) for w in words[1:]], dtype=np.int64)
            except ValueError:
                raise ValueError(f"line {number}: a face corner is not a vertex index: {line.strip()[:80]!r}") from None
            corners = np.where(corners < 0, len(vertices) + corners, corners - 1)
            if len(corners) and (corners.min() < 0 or corners.max() >= len(vertices)):
                raise ValueError(f"line {number}: a face names a vertex that does not exist (there are {len(vertices)} so far)")
            polygons.append(corners)
    return np.array(vertices, dtype=np.float64).reshape(-1, 3), polygons
