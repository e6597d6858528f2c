"""fepre: finite-element pre-processing for parts described by signed distance functions.

Model a part with :mod:`fepre.sdf`, sample it onto VTK image grids, extract its surface, mesh
its volume with DistMesh tetrahedra, compare against pytetwild and export to FEA solvers.

Heavy modules (VTK, PyVista) load on first use, so ``import fepre`` stays fast.

Examples
--------
>>> import fepre
>>> from fepre import sdf
>>> part = sdf.sphere(1.0)
>>> round(float(part([0.0, 0.0, 0.5])), 3)
-0.5
"""

from __future__ import annotations

import importlib
from typing import Any

from . import backends as _backends
from . import constraint_keywords as _constraint_keywords
from . import sdf
from ._version import __version__
from .config import config
from .errors import ConvergenceWarning, FeatureWarning, MeshingError, RepairWarning, ResolutionWarning


# public name -> module that defines it (imported on first access). fepre.distmesh,
# fepre.features and fepre.export are callable packages (listed in _SUBMODULES): fepre.distmesh(model, h) meshes.
_LAZY: dict[str, str] = {
    "sample": "fepre.sampling",
    "isosurface": "fepre.surface",
    "check_surface": "fepre.surface",
    "SurfaceCheck": "fepre.surface",
    "DistMeshOptions": "fepre.distmesh",
    "improve": "fepre.distmesh",
    "Features": "fepre.features",
    "compare": "fepre.compare",
    "Comparison": "fepre.compare",
    "plot": "fepre.plotting",
    "plot_model": "fepre.plotting",
    "size_field": "fepre.sizing",
    "SizeField": "fepre.sizing",
    "periodic_nodes": "fepre.periodic",
    "PeriodicNodes": "fepre.periodic",
    "homogenize": "fepre.homogenization",
    "Homogenized": "fepre.homogenization",
}
_SUBMODULES = {"quality", "sampling", "surface", "features", "distmesh", "export", "bench", "cli", "corpus", "sizing", "chunked"}

__all__ = ["sdf", "config", "MeshingError", "ConvergenceWarning", "FeatureWarning", "RepairWarning", "ResolutionWarning", "__version__", *_LAZY, *_SUBMODULES]


# sample(chunks=) and isosurface(chunks=) hand over to fepre.chunked, which builds on sampling and
# surface: they find it through fepre.backends, filled here (imported on first use).
_backends.provide("ChunkedGrid", lambda: importlib.import_module("fepre.chunked.grid").ChunkedGrid)
_backends.provide("sample_chunked", lambda: importlib.import_module("fepre.chunked.sampling").sample_model)
_backends.provide("isosurface_chunked", lambda: importlib.import_module("fepre.chunked.api").isosurface_chunked)
# sdf.image of a zarr store or dask array (the model layer hands over the same way)
_backends.provide("image_chunked", lambda: importlib.import_module("fepre.chunked.image").image_chunked)
_backends.provide("labels_chunked", lambda: importlib.import_module("fepre.chunked.labels").labels_chunked)


def __getattr__(name: str) -> Any:
    if name in _LAZY:
        value = getattr(importlib.import_module(_LAZY[name]), name)
        globals()[name] = value
        return value
    if name in _SUBMODULES:
        module = importlib.import_module(f"fepre.{name}")
        globals()[name] = module
        return module
    raise AttributeError(f"module 'fepre' has no attribute {name!r}")


def __dir__() -> list[str]:
    return sorted(__all__)


# fepre.distmesh(..., periodic=, regions=): the constraints of fepre.periodic and fepre.regions,
# which import fepre.distmesh; this package, above all three, hands them to the mesher by keyword.
def _periodic_constraint(periodic: Any, job: Any):
    from .periodic.constraint import PeriodicConstraint

    return PeriodicConstraint.from_keyword(periodic, job)


def _region_constraint(regions: Any, job: Any):
    from .regions.constraint import RegionConstraint

    return RegionConstraint.from_keyword(regions, job)


_constraint_keywords.register("periodic", _periodic_constraint)
_constraint_keywords.register("regions", _region_constraint)


# The PyVista plugin (``dataset.fepre`` accessors, ``.inp`` writer): registered now if PyVista is
# loaded, else as soon as it is imported; fepre.accessors itself does not import PyVista.
from . import accessors as _accessors  # noqa: E402,F401  (registers on import)
