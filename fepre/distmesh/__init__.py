"""DistMesh tetrahedral meshing of SDF models (Persson 2004, with the extensions of Kelly's DistMesh.jl).

Examples
--------
>>> import fepre
>>> from fepre import sdf
>>> mesh = fepre.distmesh(sdf.sphere(1.0), h=0.3)
>>> set(mesh.celltypes.tolist()) == {10}   # VTK_TETRA only
True
"""


from ..callable_package import make_callable
from .loop import DistMeshState
from .mesher import distmesh
from .options import DistMeshOptions
from .improve_mesh import improve
from .lost_material import LostRegion, added_material, lost_material

__all__ = ["distmesh", "DistMeshOptions", "DistMeshState", "improve", "lost_material", "added_material", "LostRegion"]


make_callable(__name__, distmesh)
