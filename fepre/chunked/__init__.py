"""Grids larger than memory: chunked sampling and surfaces on dask, grids stored in zarr.

``fepre.sample(model, spacing=..., chunks=...)`` returns a lazy :class:`ChunkedGrid` (or writes
it to a zarr store with ``store=``); ``fepre.isosurface(..., chunks=...)`` extracts chunk by
chunk and stitches the single-grid surface; :func:`write_isosurface` streams a surface too large
to hold to an STL or PLY file. Chunks run wherever dask runs them: threads by default, or the
``dask.distributed`` client the user has (the model is then pickled to the workers).

``fepre.sdf.image`` of a zarr store or a dask array (an image beyond memory) is taken chunk by chunk
here too (:mod:`fepre.chunked.image`: the same triangles as the in-memory image, bit for bit), and
so is ``fepre.sdf.labels`` of one (:mod:`fepre.chunked.labels`: the same label surface, bit for bit).

Needs the optional dependencies: ``pip install 'fepre[dask]'``.

Examples
--------
>>> import fepre
>>> from fepre import sdf
>>> whole = fepre.isosurface(sdf.torus(1.0, 0.3), spacing=0.05, method="surface_nets")
>>> chunked = fepre.isosurface(sdf.torus(1.0, 0.3), spacing=0.05, method="surface_nets", chunks=16)
>>> bool((whole.points == chunked.points).all() and (whole.regular_faces == chunked.regular_faces).all())
True
"""

from .api import write_isosurface
from .cluster import check_picklable
from .grid import ChunkedGrid, open_grid
from .layout import ChunkLayout
from .stream import StreamedSurface

__all__ = ["ChunkedGrid", "ChunkLayout", "StreamedSurface", "check_picklable", "open_grid", "write_isosurface"]
