"""Conformal regions: one mesh of a part made of several materials, cells tagged by region,
the interfaces between regions made of faces of the mesh."""

from .conform import cell_regions, check_interfaces, improve_regions
from .interface import interface_faces, interface_nodes
from .partition import RegionSet, region_set

__all__ = ["RegionSet", "region_set", "interface_nodes", "interface_faces", "cell_regions", "check_interfaces", "improve_regions"]
