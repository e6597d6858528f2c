"""``fepre info``: print a mesh file's counts, cell types, quality summary and named sets."""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np

from . import files


HELP = "print a mesh file's counts, cell types, quality summary and named sets"


def configure(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("file", metavar="FILE", help="a mesh or surface file (VTU, VTK, STL, INP, MSH, ...)")


def run(args: argparse.Namespace) -> int:
    print(_describe_file(args.file))
    return 0


#: model files that are not meshes: ``fepre info`` names the commands that take them
_MODEL_SUFFIXES = (".step", ".stp", ".brep", ".iges", ".igs", ".py", ".nii", ".tif", ".tiff", ".zarr")


def _describe_file(name: str) -> str:
    import pyvista as pv

    from ..plotting import tetrahedra_of

    if name.lower().endswith(_MODEL_SUFFIXES + (".nii.gz",)) and Path(name).exists():
        raise ValueError(f"{name} is a model file, not a mesh: fepre info reads meshes and surfaces. Mesh it first "
                         f"(fepre mesh {name} --h H -o part.vtu, then fepre info part.vtu), or list its sharp "
                         f"edges with fepre features {name}")
    mesh, sets = files.read_mesh(name)
    celltypes = np.asarray(mesh.celltypes if isinstance(mesh, pv.UnstructuredGrid) else mesh.cast_to_unstructured_grid().celltypes)
    types = {pv.CellType(int(t)).name: int(n) for t, n in zip(*np.unique(celltypes, return_counts=True))}
    lo, hi = np.asarray(mesh.bounds).reshape(3, 2).T
    lines = [
        f"{name}: {type(mesh).__name__}",
        f"points     {mesh.n_points}",
        f"cells      {mesh.n_cells}  ({', '.join(f'{k} {v}' for k, v in types.items())})",
        f"bounds     ({lo[0]:.6g}, {lo[1]:.6g}, {lo[2]:.6g}) to ({hi[0]:.6g}, {hi[1]:.6g}, {hi[2]:.6g})",
    ]
    tetrahedra = tetrahedra_of(mesh)
    if tetrahedra is not None:
        from ..quality import summary

        total = float(tetrahedra.compute_cell_sizes(length=False, area=False)["Volume"].sum())
        lines.append(f"volume     {total:.6g}")
        lines.append("quality of the tetrahedra:")
        lines.extend("  " + line for line in str(summary(tetrahedra)).splitlines())
    elif isinstance(mesh, pv.PolyData):
        lines.append(f"area       {mesh.area:.6g}")
        if mesh.n_open_edges == 0 and mesh.is_all_triangles:
            lines.append(f"volume     {mesh.volume:.6g} (closed surface)")
        else:
            lines.append(f"open edges {mesh.n_open_edges}")
    for kind, named in sets.items():
        lines.append(f"{kind}: " + (", ".join(f"{k} ({v})" for k, v in named.items()) or "none"))
    if not sets:
        lines.append("named sets: none")
    areas = files.boundary_set_areas(name, mesh)
    if areas:
        width = max(map(len, areas))
        lines.append("boundary set areas (faces as the solver sees them):")
        lines.extend(f"  {set_name:<{width}}  {count:>8} faces  area {area:.7g}" for set_name, (count, area) in areas.items())
    return "\n".join(lines)
