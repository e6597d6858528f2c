"""Isosurface extraction from models and image grids, and checks of the surfaces.

Methods: ``"flying_edges"`` (VTK's vtkFlyingEdges3D, the reference), and fepre's own vectorised
``"marching_cubes"`` (VTK's case table, same vertices and triangles as flying edges),
``"marching_tetrahedra"`` (six-tetrahedron split, watertight), ``"surface_nets"`` and
``"dual_contouring"`` (surface nets' connectivity, vertices at the QEF minimisers of the model's
Hermite data: sharp edges and corners kept).

Examples
--------
>>> import fepre
>>> from fepre import sdf
>>> surface = fepre.isosurface(sdf.sphere(1.0), spacing=0.1, method="surface_nets")
>>> fepre.check_surface(surface).watertight
True
"""

from .check import SurfaceCheck, check_surface
from .extract import METHODS, isosurface

__all__ = ["isosurface", "check_surface", "SurfaceCheck", "METHODS"]
