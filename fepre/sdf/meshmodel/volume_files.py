"""Volume meshes as surface models: the boundary of a tetrahedral or hexahedral mesh file.

An engineer's part often arrives as a volume mesh from another tool (a Medit ``.mesh``, a gmsh
``.msh``, an Abaqus or CalculiX ``.inp``, a VTK ``.vtu``) to be remeshed. :func:`read_volume_boundary`
reads it with meshio (which reads all of these; ``pv.read`` fails on some ``.inp`` files) and
returns the boundary faces of its 3D cells (faces used by one cell, quads split in two) as a
``pyvista.PolyData``. The 2D cells such files carry beside their cells (boundary and interface
tags) are left out when 3D cells exist, so a tagged interface never becomes a sheet inside the
part; a file with 2D cells only is read as a surface.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

__all__ = ["read_volume_boundary", "VOLUME_SUFFIXES"]

#: Volume mesh files read through meshio.
VOLUME_SUFFIXES = (".vtu", ".mesh", ".msh", ".inp")

#: The faces of each 3D cell type (meshio's names, VTK's vertex order), outward.
_CELL_FACES = {
    "tetra": ([[0, 2, 1], [0, 1, 3], [1, 2, 3], [0, 3, 2]], []),
    "pyramid": ([[0, 1, 4], [1, 2, 4], [2, 3, 4], [3, 0, 4]], [[0, 3, 2, 1]]),
    "wedge": ([[0, 1, 2], [3, 5, 4]], [[0, 3, 4, 1], [1, 4, 5, 2], [2, 5, 3, 0]]),
    "hexahedron": ([], [[0, 3, 2, 1], [4, 5, 6, 7], [0, 1, 5, 4], [1, 2, 6, 5], [2, 3, 7, 6], [3, 0, 4, 7]]),
}
#: Higher-order cells are read by their corner nodes.
_CORNERS = {"tetra10": "tetra", "pyramid13": "pyramid", "pyramid14": "pyramid", "wedge15": "wedge",
            "wedge18": "wedge", "hexahedron20": "hexahedron", "hexahedron27": "hexahedron"}
_CORNER_COUNT = {"tetra": 4, "pyramid": 5, "wedge": 6, "hexahedron": 8}


def _cell_faces(blocks) -> np.ndarray:
    """Triangles (F, 3) of every face of the 3D cells in ``blocks`` (meshio CellBlocks)."""
    triangles = []
    for block in blocks:
        kind = _CORNERS.get(block.type, block.type)
        if kind not in _CELL_FACES:
            continue
        cells = np.asarray(block.data, dtype=np.int64)[:, : _CORNER_COUNT[kind]]
        tris, quads = _CELL_FACES[kind]
        if tris:
            triangles.append(cells[:, tris].reshape(-1, 3))
        if quads:
            q = cells[:, quads].reshape(-1, 4)
            triangles.append(np.concatenate([q[:, [0, 1, 2]], q[:, [0, 2, 3]]]))
    return np.concatenate(triangles) if triangles else np.zeros((0, 3), np.int64)


def _once(faces: np.ndarray) -> np.ndarray:
    """The faces of ``faces`` whose vertex set occurs once (the boundary of a cell complex; a quad
    split the same way in its two cells gives the same two triangles)."""
    keys = np.sort(faces, axis=1)
    _, inverse, counts = np.unique(keys, axis=0, return_inverse=True, return_counts=True)
    return faces[counts[inverse.ravel()] == 1]


def read_volume_boundary(path: str | Path):
    """The boundary surface of the 3D cells of a volume mesh file, as a ``pyvista.PolyData``.

    Parameters
    ----------
    path : str or Path
        A ``.vtu``, ``.mesh`` (Medit), ``.msh`` (gmsh) or ``.inp`` (Abaqus/CalculiX) file.

    Returns
    -------
    pyvista.PolyData
        The faces used by one cell, oriented outwards for positively oriented cells; the file's
        triangles and quads when it holds no 3D cells.

    Raises
    ------
    ValueError
        meshio cannot read the file.

    Examples
    --------
    >>> import meshio, tempfile, os
    >>> points = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1], [1, 1, 1]], float)
    >>> cells = [("tetra", np.array([[0, 1, 2, 3], [1, 2, 3, 4]]))]
    >>> path = os.path.join(tempfile.mkdtemp(), "two.mesh")
    >>> meshio.write(path, meshio.Mesh(points, cells))
    >>> read_volume_boundary(path).n_cells  # 8 faces, the shared one left out
    6
    """
    import meshio
    import pyvista as pv

    try:
        mesh = meshio.read(path)
    except Exception as exc:  # meshio raises anything from ReadError to KeyError on bad files
        raise ValueError(f"meshio could not read it ({type(exc).__name__}: {exc})") from None
    points = np.asarray(mesh.points, dtype=np.float64)
    if points.shape[1] == 2:
        points = np.column_stack([points, np.zeros(len(points))])
    faces = _once(_cell_faces(mesh.cells))
    if len(faces) == 0:
        surface = [np.asarray(b.data, np.int64) for b in mesh.cells if b.type in ("triangle", "quad")]
        quads = [s for s in surface if s.shape[1] == 4]
        faces = np.concatenate([s for s in surface if s.shape[1] == 3]
                               + [np.concatenate([q[:, [0, 1, 2]], q[:, [0, 2, 3]]]) for q in quads]
                               or [np.zeros((0, 3), np.int64)])
    if len(faces) == 0:
        return pv.PolyData(points)
    return pv.PolyData.from_regular_faces(points, faces)
