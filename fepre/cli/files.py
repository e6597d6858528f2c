"""Reading mesh files for ``fepre info`` and ``fepre view``: VTK formats with PyVista, the rest
with meshio, with the named sets each format carries."""

from __future__ import annotations

from pathlib import Path

import numpy as np


_VTK_SUFFIXES = (".vtu", ".vtk", ".vtp", ".stl", ".ply", ".obj", ".vti")


def read_mesh(name: str):
    """(pyvista dataset, named sets {kind: {name: count}}) of a mesh file, VTK or meshio formats."""
    import pyvista as pv

    path = Path(name)
    if not path.exists():
        raise FileNotFoundError(f"{path} does not exist")
    if path.is_dir():
        raise ValueError(f"{path} is a directory; give a mesh file")
    sets: dict[str, dict[str, int]] = {}
    if path.suffix.lower() in _VTK_SUFFIXES + (".inp",):
        import warnings

        from ..export.grid import FACE_FIELD, set_names

        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            mesh = pv.read(str(path))
        if mesh.n_points == 0 and caught:
            raise ValueError(f"{path} holds no points: {str(caught[0].message).splitlines()[0]}")
        regions, boundaries = set_names(mesh)
        if regions and "region_id" in mesh.cell_data:
            counts = np.bincount(np.asarray(mesh.cell_data["region_id"]), minlength=len(regions))
            sets["regions (cells)"] = {n: int(counts[i]) for i, n in enumerate(regions)}
        if boundaries and FACE_FIELD in mesh.field_data:
            table = np.asarray(mesh.field_data[FACE_FIELD]).reshape(-1, 3)
            counts = np.bincount(table[:, 2], minlength=len(boundaries))
            sets["boundaries (faces)"] = {n: int(counts[i]) for i, n in enumerate(boundaries)}
        elif boundaries and "boundary_id" in mesh.point_data:
            values = np.asarray(mesh.point_data["boundary_id"])
            sets["boundaries (nodes)"] = {n: int(np.count_nonzero(values == i)) for i, n in enumerate(boundaries)}
    else:
        import meshio

        try:
            raw = meshio.read(str(path))
        except Exception as exc:  # meshio raises its own ReadError and others
            raise ValueError(f"{path}: cannot read it as a mesh ({type(exc).__name__}: {exc})") from None
        mesh = pv.from_meshio(raw)
        if raw.cell_sets:
            sets["element/face sets"] = {k: int(sum(len(np.asarray(b)) for b in v)) for k, v in raw.cell_sets.items()}
        if raw.point_sets:
            sets["node sets"] = {k: int(len(v)) for k, v in raw.point_sets.items()}
        if raw.field_data:
            sets["physical groups"] = {k: int(np.asarray(v).ravel()[0]) for k, v in raw.field_data.items()}
    if mesh.n_points == 0:
        raise ValueError(f"{path} holds no points (empty, or not a valid {path.suffix} file)")
    return mesh, sets
