"""Solid modelling with signed distance functions (the Descartes.jl layer of fepre).

A model is a tree of :class:`SDF` nodes: primitives combined by booleans, transforms and
deformations. Calling a model on an (N, 3) array returns (N,) float64 values, negative inside.

Examples
--------
>>> from fepre import sdf
>>> part = sdf.sphere(1.0)
>>> part.exact, part.bounds
(True, ((-1.0, -1.0, -1.0), (1.0, 1.0, 1.0)))
"""

from .core import SDF
from .solids import *  # noqa: F401,F403
from .shapes2d import *  # noqa: F401,F403
from .extrusions import *  # noqa: F401,F403
from .booleans import *  # noqa: F401,F403
from .transforms import *  # noqa: F401,F403
from .deform import *  # noqa: F401,F403
from .lattices import *  # noqa: F401,F403
from .patterns import *  # noqa: F401,F403
from .meshmodel import MeshModel, MeshInputError, mesh
from .meshmodel.cad_solids import SolidRegions, cad_solids
from . import meshmodel
from .imagemodel import ImageModel, ImageInputError, LabelRegions, image, labels
from . import imagemodel
from . import booleans, deform, extrusions, lattices, patterns, shapes2d, solids, transforms

__all__ = (
    ["SDF", "mesh", "MeshModel", "MeshInputError", "cad_solids", "SolidRegions", "image", "ImageModel", "ImageInputError", "labels", "LabelRegions"]
    + solids.__all__
    + shapes2d.__all__
    + extrusions.__all__
    + booleans.__all__
    + transforms.__all__
    + deform.__all__
    + lattices.__all__
    + patterns.__all__
)
