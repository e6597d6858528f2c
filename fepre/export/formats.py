"""The registry of export formats: name, file extensions, writer, supported orders, backend."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Callable

from . import meshio_formats as mf
from .abaqus import write_inp
from .data import ExportData
from .xdmf import write_xdmf, xdmf_outputs

__all__ = ["Format", "FORMATS", "ALIASES", "resolve_format"]

Writer = Callable[[Path, str, ExportData], None]


def single_file(filename: str) -> list[str]:
    """The files a one-file format writes for ``filename``: just that one."""
    return [filename]


@dataclass(frozen=True)
class Format:
    """One output format.

    ``writer(directory, filename, data)`` writes ``outputs(filename)`` into ``directory``.
    ``backend`` is ``(module, pip package)`` when the format needs an optional package.
    """

    name: str
    extensions: tuple[str, ...]
    writer: Writer
    description: str
    orders: tuple[int, ...] = (1, 2)
    backend: tuple[str, str] | None = None
    outputs: Callable[[str], list[str]] = single_file


FORMATS: dict[str, Format] = {
    f.name: f
    for f in [
        Format("abaqus", (".inp",), write_inp, "Abaqus/CalculiX input (fepre's own writer)"),
        Format("gmsh22", (".msh",), mf.write_gmsh22, "Gmsh 2.2 ASCII with named physical groups"),
        Format("vtu", (".vtu",), mf.write_vtu, "VTK XML unstructured grid"),
        Format("xdmf", (".xdmf", ".xmf"), write_xdmf, "XDMF/HDF5 for FEniCSx (cells + facets files)",
               backend=("h5py", "h5py"), outputs=xdmf_outputs),
        Format("nastran", (".bdf", ".nas"), mf.write_nastran, "Nastran bulk data"),
        Format("medit", (".mesh",), mf.write_medit, "Medit/mmg mesh (linear only)", orders=(1,)),
        Format("med", (".med",), mf.write_med, "MED for Code_Aster/Salome", backend=("h5py", "h5py")),
        Format("exodus", (".e", ".exo", ".ex2"), mf.write_exodus, "Exodus II",
               backend=("netCDF4", "netCDF4")),
    ]
}
ALIASES = {"calculix": "abaqus", "inp": "abaqus", "gmsh": "gmsh22", "msh": "gmsh22", "nas": "nastran",
           "bdf": "nastran", "exo": "exodus"}


def _accepted() -> str:
    return ", ".join(f"{f.name} ({' '.join(f.extensions)})" for f in FORMATS.values())


def resolve_format(path: Path, format: str | None) -> Format:
    """The format named by ``format``, else the one owning ``path``'s extension."""
    if format is not None:
        if not isinstance(format, str):
            raise TypeError(f"format must be a string or None; got {type(format).__name__}")
        key = ALIASES.get(format.lower(), format.lower())
        if key not in FORMATS:
            raise ValueError(f"format {format!r} is not known; accepted formats: {_accepted()}")
        return FORMATS[key]
    suffix = path.suffix.lower()
    for candidate in FORMATS.values():
        if suffix in candidate.extensions:
            return candidate
    raise ValueError(
        f"path: cannot tell the format from the extension {suffix or '(none)'!r} of {str(path)!r}; "
        f"use one of: {_accepted()}; or pass format="
    )
