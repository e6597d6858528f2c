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

        from ..vtk_messages import vtk_messages_kept

        with warnings.catch_warnings(record=True) as caught, vtk_messages_kept():
            warnings.simplefilter("always")
            mesh = pv.read(str(path))
        if mesh.n_points == 0 and caught:
            raise ValueError(f"{path} holds no points: the reader failed (not a valid {path.suffix} file?)")
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
        if path.suffix.lower() in (".xdmf", ".xmf"):
            sets.update(_xdmf_sets(path, raw))
        elif raw.field_data:
            sets["physical groups"] = {k: int(np.asarray(v).ravel()[0]) for k, v in raw.field_data.items()}
    if mesh.n_points == 0:
        raise ValueError(f"{path} holds no points (empty, or not a valid {path.suffix} file)")
    return mesh, sets


def boundary_set_areas(name: str, mesh) -> dict[str, tuple[int, float]]:
    """{set: (faces, area)} of the named boundary sets of a mesh file fepre wrote: a ``.inp`` or
    VTU (the tagged grid's ``boundary_faces``), or an XDMF's ``<stem>_facets.xdmf`` facet tags;
    quadratic faces over their curved shape. Empty for other files."""
    import pyvista as pv

    from ..export.areas import set_areas
    from ..export.grid import grid_set_areas

    path = Path(name)
    if isinstance(mesh, pv.UnstructuredGrid) and path.suffix.lower() in _VTK_SUFFIXES + (".inp",):
        return grid_set_areas(mesh)
    if path.suffix.lower() not in (".xdmf", ".xmf"):
        return {}
    import meshio

    from ..export.xdmf import facets_name

    facets_path = path.with_name(facets_name(path.name))
    if not facets_path.is_file() or facets_path == path:
        return {}
    facets = meshio.read(str(facets_path))
    names = {int(np.asarray(v).ravel()[0]): k for k, v in facets.field_data.items()}
    if "boundary_id" not in facets.cell_data or not names:
        return {}
    found: dict[str, tuple[int, float]] = {}
    for block, tags in zip(facets.cells, facets.cell_data["boundary_id"]):
        if block.type not in ("triangle", "triangle6"):
            continue
        tags = np.asarray(tags, dtype=np.int64).ravel()
        counts, areas = set_areas(facets.points, np.asarray(block.data), tags, int(tags.max()) + 1)
        for tag, set_name in sorted(names.items()):
            if tag < len(counts):
                count, area = found.get(set_name, (0, 0.0))
                found[set_name] = (count + int(counts[tag]), area + float(areas[tag]))
    return found


def _tag_counts(mesh, array: str) -> dict[str, int]:
    """{name: cells} of the integer cell data ``array`` of a meshio mesh, named by its field data
    (name -> [tag, dim]); tags without a name are listed as ``tag N``."""
    if array not in mesh.cell_data:
        return {}
    tags = np.concatenate([np.asarray(block).ravel() for block in mesh.cell_data[array]]).astype(np.int64)
    names = {int(np.asarray(v).ravel()[0]): k for k, v in mesh.field_data.items()}
    values, counts = np.unique(tags, return_counts=True)
    counted = {int(v): int(n) for v, n in zip(values, counts)}
    named = {name: counted.pop(tag, 0) for tag, name in sorted(names.items())}
    named.update({f"tag {tag}": count for tag, count in counted.items()})
    return named


def _xdmf_sets(path: Path, raw) -> dict[str, dict[str, int]]:
    """The regions of an XDMF mesh (``fepre.export``: cell data ``region_id``) and the facet tags of
    its ``<stem>_facets.xdmf`` companion (``boundary_id``), which dolfinx reads separately."""
    import meshio

    from ..export.xdmf import facets_name

    sets = {}
    regions = _tag_counts(raw, "region_id")
    if regions:
        sets["regions (cells)"] = regions
    elif raw.field_data:
        sets["physical groups"] = {k: int(np.asarray(v).ravel()[0]) for k, v in raw.field_data.items()}
    facets = path.with_name(facets_name(path.name))
    if facets.is_file() and facets != path:
        try:
            tagged = meshio.read(str(facets))
        except Exception as exc:  # meshio raises its own ReadError and others
            raise ValueError(f"{facets}: cannot read the facet tags of {path.name} ({type(exc).__name__}: {exc})") from None
        sets[f"facet tags (faces, {facets.name})"] = _tag_counts(tagged, "boundary_id")
    return sets
