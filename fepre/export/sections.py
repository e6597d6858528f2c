"""Materials and solid sections per region, for the Abaqus/CalculiX writer."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Mapping

import numpy as np

from ..materials import elastic_material, material_density

__all__ = ["Section", "sections", "mesh_regions", "section_text"]


@dataclass(frozen=True)
class Section:
    """One region's isotropic elastic material (named after the region)."""

    region: str
    young: float
    poisson: float
    density: float | None = None


def sections(materials: Mapping[str, Any] | None, region_names: list[str], format_name: str) -> list[Section] | None:
    """The checked ``materials`` of :func:`fepre.export`, one :class:`Section` per region."""
    if materials is None:
        return None
    if not isinstance(materials, Mapping):
        raise TypeError(f"materials must be a dict region name -> (E, nu); got {type(materials).__name__}")
    if format_name != "abaqus":
        raise ValueError(f"materials: only the Abaqus/CalculiX format (.inp) carries materials; got format {format_name!r}")
    unknown = [name for name in materials if name not in region_names]
    missing = [name for name in region_names if name not in materials]
    if unknown or missing:
        raise ValueError(
            f"materials must name every region exactly: the regions are {region_names}"
            + (f"; unknown {unknown}" if unknown else "") + (f"; missing {missing}" if missing else "")
        )
    return [
        Section(name, *elastic_material(materials[name], f"materials[{name!r}]"),
                material_density(materials[name], f"materials[{name!r}]"))
        for name in region_names
    ]


def section_text(table: list[Section]) -> str:
    """``*MATERIAL``, ``*ELASTIC`` (and ``*DENSITY`` when given) and ``*SOLID SECTION`` cards,
    one material per region."""
    return "".join(
        f"*MATERIAL, NAME={s.region}\n*ELASTIC\n{s.young:.12e}, {s.poisson:.12e}\n"
        + (f"*DENSITY\n{s.density:.12e}\n" if s.density is not None else "")
        + f"*SOLID SECTION, ELSET={s.region}, MATERIAL={s.region}\n"
        for s in table
    )


def mesh_regions(mesh: Any, n_cells: int) -> tuple[np.ndarray, list[str]]:
    """The regions a mesh carries: cell data ``region_id`` into field data ``region_names``."""
    from ..arguments import check_names

    ids = np.asarray(mesh.cell_data["region_id"]).astype(np.int64).reshape(-1)
    names = [str(name) for name in np.asarray(mesh.field_data["region_names"]).reshape(-1).tolist()]
    if ids.shape != (n_cells,) or ids.min(initial=0) < 0 or ids.max(initial=0) >= len(names):
        raise ValueError(
            f"mesh: cell data 'region_id' must give each of the {n_cells} cells an index into field data "
            f"'region_names' ({len(names)} names); pass regions= to assign regions instead"
        )
    check_names(names, "region_names")
    return ids, names
