"""Read a 3D image (a PyVista grid, a file or a numpy array) into plain arrays.

An image here is a scalar field sampled on a regular grid: values ``(nx, ny, nz)`` with index
``i`` along x, a spacing and the position of the first sample (voxel centres; a grid's cell data
is taken at its cell centres). Files: ``.vti`` (and any grid PyVista reads), NIfTI (``.nii``,
``.nii.gz``) through nibabel and TIFF stacks (``.tif``, ``.tiff``) through tifffile, both
optional (``pip install fepre[images]``).
"""

from __future__ import annotations

import os
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from ...arguments import shown

__all__ = ["Image", "ImageInputError", "read_image", "IMAGE_SUFFIXES"]

#: File suffixes read as images (the CLI meshes them as image models; a ``.zarr`` store is read
#: chunk by chunk by :mod:`fepre.chunked.image`).
IMAGE_SUFFIXES = (".vti", ".nii", ".nii.gz", ".tif", ".tiff", ".zarr")


class ImageInputError(ValueError):
    """An image given as a model cannot be used: unreadable, not 3D, without a scalar array,
    non-finite, or a level outside its values. The message names the image and what to pass."""


@dataclass(frozen=True)
class Image:
    """Values on a regular grid.

    Attributes
    ----------
    values : ndarray
        (nx, ny, nz) samples, index ``i`` along x.
    spacing, origin : ndarray
        (3,) distance between samples along each axis and position of sample (0, 0, 0).
    name : str
        The file or the kind of object, for messages.
    spacing_from : str
        Where the spacing came from: ``"image"`` (the file or grid), ``"given"`` (``spacing=``)
        or ``"default"`` (a TIFF stack without a voxel size, or an array without ``spacing=``: 1).
    """

    values: np.ndarray
    spacing: np.ndarray
    origin: np.ndarray
    name: str
    spacing_from: str = "image"

    @property
    def upper(self) -> np.ndarray:
        """Position of the last sample."""
        return self.origin + self.spacing * (np.array(self.values.shape) - 1)

    def voxel_box(self) -> tuple[np.ndarray, np.ndarray]:
        """The box the voxels fill: half a spacing beyond the first and last samples."""
        return self.origin - 0.5 * self.spacing, self.upper + 0.5 * self.spacing


def _suffix(path: Path) -> str:
    name = path.name.lower()
    return ".nii.gz" if name.endswith(".nii.gz") else path.suffix.lower()


def _from_grid(grid: Any, name: str, array: str | None) -> Image:
    import pyvista as pv

    if isinstance(grid, pv.RectilinearGrid):
        raise ImageInputError(f"{name} is a rectilinear grid; give a pyvista.ImageData (uniform spacing)")
    if not isinstance(grid, pv.ImageData):
        raise ImageInputError(
            f"{name} is a {type(grid).__name__}, not an image; give a pyvista.ImageData, a .vti file, "
            "a NIfTI or TIFF file, or a numpy array with spacing= and origin="
        )
    if np.asarray(grid.direction_matrix).round(12).tolist() != np.eye(3).tolist():
        raise ImageInputError(f"{name} has a rotated direction matrix; resample it to the axes first")
    point_names, cell_names = list(grid.point_data.keys()), list(grid.cell_data.keys())
    if array is None:
        active = grid.active_scalars_name
        if active is not None:
            array = active
        elif len(point_names) + len(cell_names) == 1:
            array = (point_names + cell_names)[0]
        elif not point_names and not cell_names:
            raise ImageInputError(f"{name} has no scalar array (no point or cell data); give an image with one")
        else:
            raise ImageInputError(
                f"{name} has several arrays ({', '.join(map(repr, point_names + cell_names))}) and none is active; "
                "name one with array= (fepre mesh and fepre surface: --array NAME)"
            )
    dims = np.array(grid.dimensions)
    spacing, origin = np.array(grid.spacing, float), np.array(grid.origin, float)
    if array in point_names:
        data, shape = np.asarray(grid.point_data[array]), dims
    elif array in cell_names:  # cell data: samples at the cell centres
        data, shape = np.asarray(grid.cell_data[array]), np.maximum(dims - 1, 1)
        origin = origin + 0.5 * spacing
    else:
        raise ImageInputError(
            f"{name} has no array {array!r}; it has {', '.join(map(repr, point_names + cell_names)) or 'none'}"
        )
    if data.ndim != 1:
        raise ImageInputError(f"{name}: array {array!r} has {data.shape[1]} components; give a scalar array")
    values = data.reshape(tuple(shape), order="F")
    return _checked(values, spacing, origin, name)


def _read_file(path: Path, array: str | None, spacing: Any = None, origin: Any = None) -> Image:
    if not path.exists():
        raise ImageInputError(f"image file {path} does not exist")
    if path.is_dir():
        raise ImageInputError(f"image file {path} is a directory; give a .vti, .nii(.gz) or .tif file")
    suffix = _suffix(path)
    if suffix in (".tif", ".tiff"):
        return _read_tiff(path, spacing, origin)
    if spacing is not None or origin is not None:
        raise ValueError(f"spacing and origin (fepre's --voxel-size and --origin) are for numpy arrays and TIFF stacks; "
                         f"{path} carries its own")
    if suffix in (".nii", ".nii.gz"):
        return _read_nifti(path)
    import warnings

    import pyvista as pv

    from ...vtk_messages import vtk_messages_kept

    with warnings.catch_warnings(), vtk_messages_kept():
        warnings.simplefilter("ignore")
        try:
            grid = pv.read(path)
        except Exception as exc:  # readers raise anything from ValueError to VTK errors
            raise ImageInputError(f"image file {path} could not be read ({type(exc).__name__}: {exc})") from None
    if grid is None or grid.n_points == 0:
        raise ImageInputError(f"image file {path} could not be read (not a valid {suffix} file?)")
    return _from_grid(grid, str(path), array)


def _read_nifti(path: Path) -> Image:
    try:
        import nibabel
    except ImportError:
        raise ImageInputError(f"reading {path} needs nibabel: pip install nibabel (or fepre[images])") from None
    try:
        volume = nibabel.load(str(path))
        values = np.asarray(volume.dataobj)
    except Exception as exc:
        raise ImageInputError(f"image file {path} could not be read ({type(exc).__name__}: {exc})") from None
    affine = np.asarray(volume.affine, float)
    linear = affine[:3, :3]
    spacing = np.linalg.norm(linear, axis=0)
    if not np.allclose(np.abs(linear), np.diag(spacing), atol=1e-6 * spacing.max()):
        raise ImageInputError(f"{path}: its voxel axes are rotated against x, y, z; resample it to the axes first")
    # axes flipped by the affine: reverse them so that spacing is positive
    origin = affine[:3, 3].copy()
    for axis in range(3):
        if linear[axis, axis] < 0 and values.ndim == 3:
            values = np.flip(values, axis=axis)
            origin[axis] += linear[axis, axis] * (values.shape[axis] - 1)
    return _checked(values, spacing, origin, str(path))


def _read_tiff(path: Path, spacing: Any, origin: Any) -> Image:
    """A TIFF stack with the voxel size of its OME or ImageJ metadata, or ``spacing`` (which
    overrides it), else 1; the first voxel at ``origin`` (default 0)."""
    try:
        import tifffile  # noqa: F401
    except ImportError:
        raise ImageInputError(f"reading {path} needs tifffile: pip install tifffile (or fepre[images])") from None
    from .tiff import read_tiff_stack

    try:
        values, found = read_tiff_stack(path)
    except Exception as exc:
        raise ImageInputError(f"image file {path} could not be read ({type(exc).__name__}: {exc})") from None
    given, first = _spacing_and_origin(spacing, origin)
    source = "given" if spacing is not None else ("image" if found is not None else "default")
    chosen = given if spacing is not None else (found if found is not None else np.ones(3))
    return _checked(values, chosen, first, str(path), source)


def _spacing_and_origin(spacing: Any, origin: Any) -> tuple[np.ndarray, np.ndarray]:
    """``spacing`` (default 1) and ``origin`` (default 0) as (3,) floats, each a number or three."""
    try:
        spacing = np.broadcast_to(np.asarray(1.0 if spacing is None else spacing, float), (3,)) if np.ndim(spacing) == 0 else np.asarray(spacing, float)
        origin = np.zeros(3) if origin is None else (np.full(3, float(origin)) if np.ndim(origin) == 0 else np.asarray(origin, float))
    except (TypeError, ValueError):
        raise ImageInputError(f"spacing and origin must be numbers or three numbers each; got {shown(spacing)} and {shown(origin)}") from None
    return spacing, origin


def _checked(values: np.ndarray, spacing: np.ndarray, origin: np.ndarray, name: str, spacing_from: str = "image") -> Image:
    if values.ndim != 3 or min(values.shape) < 2:
        raise ImageInputError(
            f"{name} is not a 3D image (shape {tuple(values.shape)}); give a volume of at least 2 samples along "
            "each axis (stack 2D slices into one 3D array)"
        )
    if not (np.issubdtype(values.dtype, np.number) or values.dtype == bool) or np.iscomplexobj(values):
        raise ImageInputError(f"{name} holds {values.dtype} values; give a real-valued scalar image")
    if np.issubdtype(values.dtype, np.floating):
        bad = ~np.isfinite(values)
        if bad.any():
            first = np.unravel_index(int(np.argmax(bad)), values.shape)
            raise ImageInputError(
                f"{name} has {int(bad.sum())} non-finite values (NaN or inf), for example at index {tuple(map(int, first))}"
            )
    spacing = np.asarray(spacing, float)
    if spacing.shape != (3,) or not np.isfinite(spacing).all() or (spacing <= 0).any():
        raise ImageInputError(f"{name}: spacing must be three positive numbers; got {shown(spacing)}")
    origin = np.asarray(origin, float)
    if origin.shape != (3,) or not np.isfinite(origin).all():
        raise ImageInputError(f"{name}: origin must be three finite numbers; got {shown(origin)}")
    return Image(values, spacing, origin, name, spacing_from)


def read_image(source: Any, *, spacing: Any = None, origin: Any = None, array: str | None = None) -> Image:
    """The values, spacing and origin of an image.

    Parameters
    ----------
    source : pyvista.ImageData, str, path-like or array_like
        A grid, an image file (``IMAGE_SUFFIXES``) or a 3D array (index ``i`` along x).
    spacing, origin : float or (3,) floats, optional
        For an array or a TIFF stack: distance between samples and position of sample (0, 0, 0)
        (default 0). A stack's own voxel size (OME or ImageJ metadata) is used when ``spacing``
        is not given, else 1; other files and grids carry their own and refuse these.
    array : str, optional
        Which point or cell array of a grid; default its active scalars or its only array.

    Raises
    ------
    ImageInputError
        Unreadable file, no scalar array, not 3D, non-finite values.

    Examples
    --------
    >>> import numpy as np
    >>> image = read_image(np.zeros((4, 5, 6)), spacing=0.5)
    >>> image.values.shape, image.upper.tolist()
    ((4, 5, 6), [1.5, 2.0, 2.5])
    """
    import pyvista as pv

    if isinstance(source, (str, os.PathLike)):
        return _read_file(Path(source), array, spacing, origin)
    if isinstance(source, pv.DataSet):
        if spacing is not None or origin is not None:
            raise ValueError("spacing and origin are for numpy arrays; a pyvista.ImageData carries its own")
        return _from_grid(source, f"{type(source).__name__} image", array)
    try:
        values = np.asarray(source)
    except (TypeError, ValueError):
        values = np.asarray(None)
    if values.dtype == object or values.ndim == 0:
        raise TypeError(
            f"image must be a pyvista.ImageData, an image file (.vti, .nii, .nii.gz, .tif), a 3D numpy array, or a zarr store, zarr or dask array; "
            f"got {type(source).__name__}"
        )
    source_of_spacing = "default" if spacing is None else "given"
    spacing, origin = _spacing_and_origin(spacing, origin)
    return _checked(values, spacing, origin, "image array", source_of_spacing)
