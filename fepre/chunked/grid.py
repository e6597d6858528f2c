"""A chunked grid: a lazy dask array of samples with the grid's origin and spacing."""

from __future__ import annotations

from typing import Any

import numpy as np

from .layout import ChunkLayout

__all__ = ["ChunkedGrid", "open_grid"]


class ChunkedGrid:
    """Samples of a model on a regular grid, held as a chunked (lazy) dask array.

    Made by :func:`fepre.sample` with ``chunks=`` (or read back from a zarr store by
    :func:`open_grid`). Nothing is evaluated until the values are computed, by
    :meth:`to_image`, by :func:`fepre.isosurface` (chunk by chunk) or by dask itself.

    Attributes
    ----------
    values : dask.array.Array
        Shape ``(nz, ny, nx)`` in VTK order (x fastest), chunked as ``layout``.
    origin, spacing : (3,) float arrays
    layout : fepre.chunked.layout.ChunkLayout
        The chunks (nodes owned per chunk along x, y, z).
    band : float or None
        Narrow band half-width when the grid was sampled in a band.
    model : fepre.sdf.SDF or None
        The model the samples came from (dual contouring uses it for sharp features).
    store : str or None
        The zarr store the values live in, if any.

    Examples
    --------
    >>> import fepre
    >>> from fepre import sdf
    >>> grid = fepre.sample(sdf.sphere(1.0), spacing=0.1, chunks=16)
    >>> grid.dimensions, grid.chunks
    ((25, 25, 25), (16, 16, 16))
    >>> image = grid.to_image()
    >>> float(image["sdf"].min()) < 0
    True
    """

    def __init__(self, values, origin: Any, spacing: Any, layout: ChunkLayout, *, band=None, model=None, store=None):
        self.values = values
        self.origin = np.asarray(origin, dtype=float)
        self.spacing = np.asarray(spacing, dtype=float)
        self.layout = layout
        self.band = band
        self.model = model
        self.store = store

    @property
    def dimensions(self) -> tuple[int, int, int]:
        """Nodes along x, y, z."""
        return tuple(int(c) for c in self.layout.counts)

    @property
    def chunks(self) -> tuple[int, int, int]:
        """Nodes per chunk along x, y, z (the first chunk of each axis)."""
        return tuple(int(s[0]) for s in self.layout.sizes)

    @property
    def n_points(self) -> int:
        return int(np.prod(self.dimensions))

    @property
    def nbytes(self) -> int:
        """Bytes of the whole grid if it were held in memory."""
        return self.n_points * self.values.dtype.itemsize

    def __repr__(self) -> str:
        nx, ny, nz = self.dimensions
        where = f", store={self.store!r}" if self.store else ""
        band = f", band={self.band:g}" if self.band is not None else ""
        return (
            f"ChunkedGrid({nx} x {ny} x {nz} nodes, {self.layout.n_chunks} chunks of {self.chunks}, "
            f"{self.values.dtype.name}, spacing={tuple(float(s) for s in self.spacing)}{band}{where})"
        )

    def to_image(self):
        """Compute every chunk and return the whole grid as a :class:`pyvista.ImageData`
        (point array ``"sdf"``); it must fit in memory (``fepre.config.max_grid_bytes``)."""
        import pyvista as pv

        from ..sampling import _check_memory

        _check_memory(np.array(self.dimensions), self.values.dtype)
        image = pv.ImageData(dimensions=self.dimensions, spacing=tuple(self.spacing), origin=tuple(self.origin))
        image.point_data["sdf"] = np.asarray(self.values.compute()).reshape(-1)
        if self.band is not None:
            image.field_data["sdf_band"] = np.array([self.band])
        return image


def open_grid(store: Any) -> ChunkedGrid:
    """Open a grid written by :func:`fepre.sample` with ``store=`` (a zarr store).

    Examples
    --------
    >>> import tempfile, pathlib, fepre
    >>> from fepre import sdf
    >>> path = pathlib.Path(tempfile.mkdtemp()) / "ball.zarr"
    >>> _ = fepre.sample(sdf.sphere(1.0), spacing=0.1, chunks=16, store=path)
    >>> fepre.chunked.open_grid(path).dimensions
    (25, 25, 25)
    """
    import dask.array as da
    import zarr

    path = str(store)
    try:
        array = zarr.open_array(path, mode="r")
    except Exception as exc:  # zarr raises several types for a missing or foreign store
        raise ValueError(f"store: {path!r} is not a zarr array written by fepre.sample ({exc})") from None
    attrs = dict(array.attrs)
    if attrs.get("fepre") != "sdf-grid":
        raise ValueError(f"store: {path!r} is a zarr array but not a grid written by fepre.sample (no 'fepre' attribute)")
    nz, ny, nx = array.shape
    layout = ChunkLayout((nx, ny, nz), tuple(tuple(int(c) for c in s) for s in attrs["chunk_sizes"]))
    values = da.from_zarr(path, chunks=layout.dask_chunks)
    band = attrs.get("band")
    return ChunkedGrid(values, attrs["origin"], attrs["spacing"], layout, band=band, store=path)
