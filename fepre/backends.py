"""Implementations that a lower layer hands work over to without importing them.

A module knows the stages before it, never the stages after it. ``fepre.chunked`` builds on
:mod:`fepre.sampling` and :mod:`fepre.surface` (it cuts their grids into chunks), yet
``sample(..., chunks=)`` and ``isosurface(..., chunks=)`` (or a ``ChunkedGrid`` source) hand
over to it. So those two ask for it here, by name, and the package's façade
(``fepre/__init__.py``, which Python runs before any ``fepre`` module) registers a loader for each
name: the implementation is imported on first use, as before, and the import graph has no cycle.

Registered names: ``"ChunkedGrid"`` (the class, for ``isinstance``), ``"sample_chunked"``
(:func:`fepre.chunked.sampling.sample_model`), ``"isosurface_chunked"``
(:func:`fepre.chunked.api.isosurface_chunked`) and ``"image_chunked"``
(:func:`fepre.chunked.image.image_chunked`: ``sdf.image`` of a zarr store or a dask array) and
``"labels_chunked"`` (:func:`fepre.chunked.labels.labels_chunked`: ``sdf.labels`` of one).
"""

from __future__ import annotations

from typing import Any, Callable

__all__ = ["provide", "provided"]

_LOADERS: dict[str, Callable[[], Any]] = {}


def provide(name: str, loader: Callable[[], Any]) -> None:
    """Register ``loader``, called on each :func:`provided` of ``name`` (import inside it)."""
    _LOADERS[name] = loader


def provided(name: str) -> Any:
    """The implementation registered as ``name``."""
    try:
        loader = _LOADERS[name]
    except KeyError:  # pragma: no cover - fepre/__init__.py registers every name
        raise RuntimeError(f"no implementation of {name!r} is registered (fepre/__init__.py registers them)") from None
    return loader()
