"""Triangle meshes (STL, OBJ, PLY, ...) as SDF models: reading, repair, exact distance, patches.

Examples
--------
>>> import pyvista as pv
>>> from fepre import sdf
>>> cube = sdf.mesh(pv.Cube())
>>> cube.patch_count, float(cube([0.0, 0.0, 0.0]))
(6, -0.5)
"""

from .model import MeshModel, mesh
from .read import MeshInputError
from .repair import Repair, repair

__all__ = ["mesh", "MeshModel", "MeshInputError", "Repair", "repair"]
