"""DistMesh tetrahedral meshing of SDF models (Persson 2004, with the extensions of Kelly's DistMesh.jl).

Examples
--------
>>> import fepre
>>> from fepre import sdf
>>> mesh = fepre.distmesh(sdf.sphere(1.0), h=0.3)
>>> set(mesh.celltypes.tolist()) == {10}   # VTK_TETRA only
True
"""

import sys
import types

from .loop import DistMeshState
from .mesher import distmesh
from .options import DistMeshOptions
from .improve_mesh import improve
from .lost_material import LostRegion, added_material, lost_material

__all__ = ["distmesh", "DistMeshOptions", "DistMeshState", "improve", "lost_material", "added_material", "LostRegion"]


class _CallableModule(types.ModuleType):
    """``fepre.distmesh`` is both this package and the function: calling it meshes."""

    def __call__(self, *args, **kwargs):
        return distmesh(*args, **kwargs)


sys.modules[__name__].__class__ = _CallableModule
# inspect.signature() and IDEs show the function's parameters, not (*args, **kwargs)
sys.modules[__name__].__signature__ = __import__("inspect").signature(distmesh)
