"""The tables of a comparison: its metric rows and their formats, the plain fields of a surface
check, the package versions.

:mod:`fepre.compare` prints them as text and :mod:`fepre.report` as HTML; ``Comparison.to_html``
calls the report, so the report takes what it shares with compare from here, never from compare.
"""

from __future__ import annotations

import math
import platform
from typing import Any

import numpy as np

__all__ = ["TABLE_ROWS", "format_metric", "as_plain", "versions"]


# (row label, metric key, format) of the text and HTML tables
TABLE_ROWS: list[tuple[str, str, str]] = [
    ("tetrahedra", "elements", "{:d}"),
    ("nodes", "nodes", "{:d}"),
    ("time [s]", "seconds", "{:.2f}"),
    ("time per 1000 cells [ms]", "ms_per_1000_cells", "{:.1f}"),
    ("mean edge length", "mean_edge_length", "{:.4g}"),
    ("volume", "volume", "{:.5g}"),
    ("volume error", "volume_error", "{:+.3%}"),
    ("inverted cells", "inverted", "{:d}"),
    ("max |sdf| at boundary nodes", "boundary_sdf_max", "{:.2e}"),
    ("mean |sdf| at boundary nodes", "boundary_sdf_mean", "{:.2e}"),
    ("Hausdorff to fine surface", "hausdorff", "{:.2e}"),
    ("min dihedral [deg]", "min_dihedral_angle_min", "{:.2f}"),
    ("1st pct min dihedral [deg]", "min_dihedral_angle_p1", "{:.2f}"),
    ("mean min dihedral [deg]", "min_dihedral_angle_mean", "{:.2f}"),
    ("max dihedral [deg]", "max_dihedral_angle_max", "{:.2f}"),
    ("cells below 10 deg", "below_10", "{:d}"),
    ("cells below 15 deg", "below_15", "{:d}"),
    ("min radius ratio", "radius_ratio_min", "{:.3f}"),
    ("1st pct radius ratio", "radius_ratio_p1", "{:.3f}"),
    ("mean radius ratio", "radius_ratio_mean", "{:.3f}"),
    ("min volume-edge ratio", "volume_edge_ratio_min", "{:.3f}"),
    ("mean volume-edge ratio", "volume_edge_ratio_mean", "{:.3f}"),
]


def format_metric(value: Any, spec: str) -> str:
    """``value`` formatted with ``spec``, or '-' when it is missing or NaN."""
    if value is None or (isinstance(value, float) and math.isnan(value)):
        return "-"
    if spec.endswith("d}"):
        value = int(value)
    return spec.format(value)


def as_plain(check: Any) -> dict[str, Any]:
    """The plain (bool, int, float, str, None) fields of a check such as :class:`fepre.SurfaceCheck`."""
    import dataclasses

    if dataclasses.is_dataclass(check):
        items = dataclasses.asdict(check)
    else:
        items = dict(vars(check))
    plain = {}
    for key, value in items.items():
        if isinstance(value, (np.generic,)):
            value = value.item()
        if isinstance(value, (bool, int, float, str)) or value is None:
            plain[key] = value
    return plain


def versions() -> dict[str, str]:
    """Versions of fepre and the packages a comparison depends on."""
    from importlib.metadata import PackageNotFoundError, version

    found = {"python": platform.python_version()}
    for package in ("fepre", "numpy", "scipy", "vtk", "pyvista", "pytetwild", "gmsh", "meshio", "matplotlib"):
        try:
            found[package] = version(package)
        except PackageNotFoundError:
            continue
    return found
