"""fepre as a PyVista plugin: ``dataset.fepre`` accessors and a ``.inp`` writer.

Importing this module registers (PyVista >= 0.48):

* on ``pyvista.UnstructuredGrid``: ``grid.fepre.quality()``, ``.summary()``, ``.improve(model)``,
  ``.export(path)``, ``.plot_quality(metric)``, ``.compare(model, h)``;
* on ``pyvista.ImageData``: ``image.fepre.isosurface(method=...)``;
* on ``pyvista.PolyData``: ``surface.fepre.check(model)``;
* a writer for ``.inp`` so ``grid.save("part.inp")`` writes Abaqus/CalculiX through
  :func:`fepre.export`.

``import fepre`` calls :func:`install`: it registers at once when PyVista is already loaded, and
otherwise waits for PyVista's own import (a one-shot import hook), so ``import fepre`` never pays
for importing PyVista. The package's ``pyvista.accessors``/``pyvista.writers`` entry points also
load this module when a dataset's ``.fepre`` or a ``.inp`` save is first used.

Examples
--------
>>> import pyvista as pv
>>> import fepre.accessors
>>> from fepre import sdf
>>> grid = fepre.sample(sdf.sphere(1.0), spacing=0.1)
>>> surface = grid.fepre.isosurface()
>>> surface.fepre.check(sdf.sphere(1.0)).watertight
True
"""

from __future__ import annotations

import importlib.abc
import sys
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    import pyvista as pv

__all__ = ["UnstructuredGridAccessor", "ImageDataAccessor", "PolyDataAccessor", "write_inp", "install"]


class UnstructuredGridAccessor:
    """``grid.fepre``: quality, improvement, export and views of a tetrahedral mesh."""

    def __init__(self, mesh: "pv.UnstructuredGrid") -> None:
        self._mesh = mesh

    def quality(self, inplace: bool = False) -> pv.UnstructuredGrid:
        """The mesh with fepre's quality cell arrays (``min_dihedral_angle``, ``radius_ratio``, ...).

        Examples
        --------
        >>> grid.fepre.quality()["radius_ratio"].min()  # doctest: +SKIP
        """
        from .quality import add_quality

        return add_quality(self._mesh, inplace=inplace)

    def summary(self):
        """:func:`fepre.quality.summary` of the mesh (min, percentiles, mean of every metric)."""
        from .quality import summary

        return summary(self._mesh)

    def improve(self, model: Any, **options: Any) -> pv.UnstructuredGrid:
        """:func:`fepre.improve`: remove slivers, keeping the boundary on ``model``'s zero set."""
        from .distmesh import improve

        return improve(self._mesh, model, **options)

    def export(self, path: Any, **options: Any) -> pv.UnstructuredGrid:
        """:func:`fepre.export`: write the mesh for a solver (format from the extension)."""
        from .export import export

        return export(self._mesh, path, **options)

    def plot_quality(self, metric: str = "min_dihedral_angle", clip: bool = True, **options: Any):
        """:func:`fepre.plot`: the interior coloured by ``metric``."""
        from .plotting import plot

        return plot(self._mesh, metric=metric, clip=clip, **options)

    def compare(self, model: Any, h: float, **options: Any):
        """:func:`fepre.compare` with this mesh as fepre's."""
        from .compare import compare

        return compare(model, h, mesh=self._mesh, **options)


class ImageDataAccessor:
    """``image.fepre``: surfaces of a sampled grid (point array ``"sdf"``)."""

    def __init__(self, image: pv.ImageData) -> None:
        self._image = image

    def isosurface(self, method: str = "flying_edges", **options: Any) -> pv.PolyData:
        """:func:`fepre.isosurface` of this grid (``method``: flying_edges, marching_cubes,
        marching_tetrahedra, surface_nets, dual_contouring; pass ``model=`` the grid was sampled
        from to give dual contouring sharp edges)."""
        from .surface import isosurface

        return isosurface(self._image, method=method, **options)


class PolyDataAccessor:
    """``surface.fepre``: checks of a triangle surface."""

    def __init__(self, surface: pv.PolyData) -> None:
        self._surface = surface

    def check(self, model: Any = None, **options: Any):
        """:func:`fepre.check_surface`: watertight, manifold, Euler, area, volume, errors."""
        from .surface import check_surface

        return check_surface(self._surface, model, **options)


def write_inp(dataset: Any, path: str, /, **options: Any) -> None:
    """PyVista writer for ``.inp``: Abaqus/CalculiX through :func:`fepre.export`."""
    from .export import export

    export(dataset, path, format=options.pop("format", "abaqus"), **options)


def read_inp(path: str, /, **options: Any) -> pv.UnstructuredGrid:
    """PyVista reader for ``.inp``: Abaqus/CalculiX tetrahedra through :func:`fepre.export.inp_reader.read_inp`."""
    from .export.inp_reader import read_inp as read

    return read(path, **options)


def register() -> None:
    """Register the ``fepre`` accessors and the ``.inp`` reader and writer with PyVista (idempotent)."""
    import pyvista as pv

    accessors = ((pv.UnstructuredGrid, UnstructuredGridAccessor), (pv.ImageData, ImageDataAccessor),
                 (pv.PolyData, PolyDataAccessor))
    for target, accessor in accessors:
        pv.register_dataset_accessor("fepre", target)(accessor)
    pv.register_writer(".inp", write_inp, override=True)
    pv.register_reader(".inp", read_inp, override=True)


class _RegisterAfter(importlib.abc.Loader):
    """Runs PyVista's own loader, then :func:`register`."""

    def __init__(self, loader: Any) -> None:
        self._loader = loader

    def create_module(self, spec: Any) -> Any:
        return self._loader.create_module(spec)

    def exec_module(self, module: Any) -> None:
        self._loader.exec_module(module)
        register()

    def __getattr__(self, name: str) -> Any:  # resource readers and the like
        return getattr(self._loader, name)


class _PyVistaImportHook(importlib.abc.MetaPathFinder):
    """Finds ``pyvista`` with the other finders and wraps its loader; removes itself after one use."""

    def find_spec(self, fullname: str, path: Any, target: Any = None) -> Any:
        if fullname != "pyvista":
            return None
        _remove_hook()
        for finder in sys.meta_path:
            spec = getattr(finder, "find_spec", lambda *args: None)(fullname, path, target)
            if spec is not None:
                if spec.loader is not None and hasattr(spec.loader, "exec_module"):
                    spec.loader = _RegisterAfter(spec.loader)
                return spec
        return None


def _remove_hook() -> None:
    sys.meta_path[:] = [finder for finder in sys.meta_path if not isinstance(finder, _PyVistaImportHook)]


def install() -> None:
    """Register now if PyVista is loaded, else when it is imported (no PyVista import here)."""
    if "pyvista" in sys.modules:
        register()
    elif not any(isinstance(finder, _PyVistaImportHook) for finder in sys.meta_path):
        sys.meta_path.insert(0, _PyVistaImportHook())


install()
