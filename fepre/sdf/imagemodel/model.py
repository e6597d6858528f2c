"""A grey-value image as an SDF model: the signed distance to a level set of its interpolant."""

from __future__ import annotations

import os
from pathlib import Path
from typing import Any

import numpy as np

from ...arguments import finite_float, nonnegative_float, shown
from ..meshmodel.model import MeshModel
from ..meshmodel.repair import repair
from .levelset import (auto_refine, border_depth, border_slab_ranges, level_surface, needs_padding, outside_value,
                       prepared_values)
from .partial_volume import PartialVolume, volume_level
from .read import Image, ImageInputError, read_image

__all__ = ["ImageModel", "image", "image_model", "checked_level", "checked_options", "is_chunked_source", "INSIDE"]

INSIDE = ("above", "below")


class ImageModel(MeshModel):
    """The solid where an image's interpolant is above (or below) a level.

    Values are the exact distance to the triangles of the level set (see
    :mod:`fepre.sdf.imagemodel.levelset`), negative inside; built by :func:`fepre.sdf.image`.
    """

    def __init__(self, vertices: np.ndarray, faces: np.ndarray, source: Image, *, level: float, inside: str,
                 smoothing: float, refine: int, features: float, on_level: bool = True,
                 partial_volume: PartialVolume | None = None) -> None:
        repaired = repair(vertices, faces, level_set=True, coincident=on_level)
        if len(repaired.faces) == 0:
            raise ImageInputError(f"{source.name}: no solid at level {shown(level)}")
        super().__init__(repaired, source.name, sign="winding", features=features)
        self.image = source
        self.level = level
        self.inside = inside
        self.smoothing = smoothing
        self.refine = refine
        #: with ``sdf.image(partial_volume=True)``: the phases' values, the volumes and the shift
        #: (:class:`fepre.sdf.imagemodel.partial_volume.PartialVolume`); else None
        self.partial_volume = partial_volume

    @property
    def spacing(self) -> np.ndarray:
        """The image's voxel spacing (3,)."""
        return self.image.spacing

    def _parameters(self) -> dict[str, Any]:
        parameters: dict[str, Any] = {"source": self.name, "level": self.level}
        if self.inside != "above":
            parameters["inside"] = self.inside
        if self.smoothing:
            parameters["smoothing"] = self.smoothing
        if self.partial_volume is not None:
            parameters["partial_volume"] = True
        parameters["refine"] = self.refine
        parameters["triangles"] = len(self.faces)
        return parameters

    def _label(self) -> str:
        return "image"


def checked_level(name: str, level: Any, low: float, high: float) -> float:
    """``level`` as a float strictly between the image's smallest and largest values ``low``,
    ``high``; a clear error naming the image otherwise."""
    if level is None:
        raise ValueError(f"{name}: level is required (the grey value of the boundary, between the image's "
                         f"values {shown(low)} and {shown(high)})")
    level = finite_float(level, "level")
    if not low < level < high:
        raise ImageInputError(
            f"{name}: level {shown(level)} is outside the image's values ({shown(low)} to {shown(high)}); "
            f"give a level strictly between them"
        )
    return level


def checked_options(inside: Any, smoothing: Any, features: Any, refine: Any,
                    partial_volume: Any = False) -> tuple[float, float]:
    """``smoothing`` and ``features`` as floats after checking every option of :func:`image`."""
    if not isinstance(partial_volume, (bool, np.bool_)):
        raise TypeError(f"partial_volume must be True or False; got {shown(partial_volume)}")
    if inside not in INSIDE:
        raise ValueError(f"inside must be 'above' or 'below' (which side of the level is the solid); got {shown(inside)}")
    smoothing = nonnegative_float(smoothing, "smoothing")
    features = finite_float(features, "features")
    if not 0.0 <= features < 180.0:
        raise ValueError(f"features must be an angle in degrees in [0, 180); got {shown(features)}")
    if refine is not None and (isinstance(refine, bool) or not isinstance(refine, (int, np.integer)) or not 1 <= refine <= 4):
        raise ValueError(f"refine must be an integer from 1 to 4 (samples per voxel along each axis); got {shown(refine)}")
    return smoothing, features


def is_chunked_source(source: Any) -> bool:
    """Whether ``source`` is read chunk by chunk: a dask or zarr array, or a ``.zarr`` store."""
    if isinstance(source, (str, os.PathLike)):
        path = Path(source)
        return path.name.lower().endswith(".zarr") or (path.is_dir() and any(
            (path / marker).exists() for marker in (".zarray", ".zgroup", "zarr.json")))
    module = type(source).__module__.split(".")[0]
    return module in ("dask", "zarr")


def image_model(vertices: np.ndarray, faces: np.ndarray, data: Image, touches: bool, **options):
    """The :class:`ImageModel` of the level-set triangles, cut by the voxels' box when the solid
    reaches the image's border."""
    model = ImageModel(vertices, faces, data, **options)
    if not touches:
        return model
    from ..solids import box

    lower, upper = data.voxel_box()
    return model & box(tuple(upper - lower), center=tuple(0.5 * (lower + upper)))


def image(
    source: Any,
    level: float | None = None,
    *,
    inside: str = "above",
    smoothing: float = 0.0,
    refine: int | None = None,
    features: float = 0.0,
    spacing: Any = None,
    origin: Any = None,
    array: str | None = None,
    chunks: Any = None,
    partial_volume: bool = False,
):
    """A grey-value image (CT scan, density field) as a model: the solid where the image's
    smooth interpolant is above ``level`` (or below it).

    The value is the exact signed distance to the level set of the interpolant, as triangles
    (cubic B-spline interpolant refined ``refine`` times, contoured by flying edges): negative
    inside, 1-Lipschitz, with gradients and exact projection; the level set is within a small
    fraction of a voxel of the interpolant's (a partial-volume sphere 17 voxels across: 0.09
    voxel). A solid that reaches the image's border is cut by the box the voxels fill (half a
    spacing beyond the first and last samples); the result is then that intersection.

    Parameters
    ----------
    source : pyvista.ImageData, str, path-like or array_like
        A grid (point data at the samples; cell data at the cell centres), an image file
        (``.vti`` or any grid PyVista reads; ``.nii``/``.nii.gz`` with nibabel, ``.tif`` stacks
        with tifffile), a 3D array indexed ``[i, j, k]`` along x, y, z, or an image beyond
        memory: a dask array, a zarr array or a ``.zarr`` store (same indexing; ``spacing`` and
        ``origin`` as for arrays, or from the store's attributes).
    level : float
        The boundary's grey value, strictly between the image's smallest and largest values.
    inside : {"above", "below"}
        Which side is the solid: values above the level (bright material in a CT) or below it.
    smoothing : float
        Width (standard deviation) of a Gaussian blur in voxels of the finest axis, for noisy
        scans; 0 (default) keeps the samples.
    refine : int, optional
        Samples of the interpolant per voxel along each axis (1-4). Default 2 when the refined
        grid has at most 40M samples, else 1.
    features : float
        Crease angle in degrees for :func:`fepre.features` (see :func:`fepre.sdf.mesh`); 0
        (default): the surface of an image is smooth at the voxel scale.
    spacing, origin : float or (3,) floats, optional
        For an array or a TIFF stack: the voxel spacing and the position of voxel (0, 0, 0)
        (default 0). A TIFF stack's own voxel size (OME or ImageJ metadata) is used when
        ``spacing`` is not given; without one, and for an array, it is 1.
    array : str, optional
        The grid's array to read (default its active scalars or its only array); for a zarr
        group, the name of its array.
    chunks : int or (3,) ints, optional
        Samples per chunk along x, y, z: the image is then processed chunk by chunk
        (:mod:`fepre.chunked.image`), never held whole, and gives the same triangles (default 128
        for a dask or zarr source, which always goes that way; refine then defaults to 2).
    partial_volume : bool
        The values are partial volumes, or a scan's blur of the part (one material on one
        background): they integrate to the part's volume, which the level set midway between
        the two does not keep where the surface is curved at the scale of a voxel or has edges
        (a gyroid lattice in a box at 30 voxels across: -1.27%). The level is then moved to the
        one at which the solid holds that volume (the surface moves a few hundredths of a voxel
        on the phantoms; see :mod:`fepre.sdf.imagemodel.partial_volume`); the
        background's and material's values are the medians of the samples 2 voxels or more from
        the level set. Not for densities (a SIMP design's grey values are not shares of a
        shape). Default False.

    Returns
    -------
    ImageModel or SDF
        An :class:`ImageModel` (a :class:`fepre.sdf.MeshModel` with ``image``, ``level``,
        ``spacing`` and ``partial_volume``), or its intersection with the voxels' box when the
        solid reaches the border.

    Raises
    ------
    fepre.sdf.imagemodel.ImageInputError
        Unreadable file, no scalar array, not 3D, non-finite values, a level outside the values.

    Examples
    --------
    >>> import numpy as np
    >>> from fepre import sdf
    >>> x, y, z = np.mgrid[-1:1:41j, -1:1:41j, -1:1:41j]
    >>> ball = sdf.image(1.0 - np.sqrt(x**2 + y**2 + z**2), level=0.3, spacing=0.05, origin=-1.0)
    >>> round(float(ball([0.0, 0.0, 0.0])), 2)      # the level set is the sphere of radius 0.7
    -0.7
    """
    smoothing, features = checked_options(inside, smoothing, features, refine, partial_volume)
    if chunks is not None or is_chunked_source(source):
        if partial_volume:
            raise ValueError("partial_volume applies to an image held in memory, not one read chunk by chunk "
                             "(chunks=, a dask or zarr source)")
        from ...backends import provided

        return provided("image_chunked")(source, level, inside=inside, smoothing=smoothing, refine=refine,
                                         features=features, spacing=spacing, origin=origin, array=array, chunks=chunks)
    data = read_image(source, spacing=spacing, origin=origin, array=array)
    low, high = float(data.values.min()), float(data.values.max())
    level = checked_level(data.name, level, low, high)
    refine = auto_refine(data.values.shape) if refine is None else int(refine)
    field, fine_spacing = prepared_values(data, level, inside, smoothing, refine)
    if not (field < 0).any() or not (field > 0).any():
        raise ImageInputError(
            f"{data.name}: after smoothing by {shown(smoothing)} voxels no sample is on both sides of level "
            f"{shown(level)}; give less smoothing or another level"
        )
    pad = needs_padding(border_slab_ranges(data.values, border_depth(data.spacing, smoothing, refine)), level, inside,
                        refine, low, high)
    on_level = bool((field == 0).any())
    vertices, faces, touches = level_surface(field, fine_spacing, data.origin, pad=pad,
                                             outside=outside_value(low, high, level))
    found = None
    if partial_volume:
        vertices, faces, touches, found = volume_level(data, level, inside, field, fine_spacing, pad=pad,
                                                       outside=outside_value(low, high, level),
                                                       first=(vertices, faces, touches))
    return image_model(vertices, faces, data, touches, level=level, inside=inside, smoothing=smoothing, refine=refine,
                       features=features, on_level=on_level or partial_volume, partial_volume=found)
