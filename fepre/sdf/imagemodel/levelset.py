"""The level set of an image's smooth interpolant, as triangles.

The image is optionally smoothed (a Gaussian, ``smoothing`` voxels of the finest axis wide),
refined ``refine`` times by its cubic B-spline interpolant (``scipy.ndimage.zoom``, which passes
through the samples), padded so that the surface closes at the image's border, and contoured by
VTK's flying edges (linear along every grid edge of the refined grid). The triangles then lie
within a small fraction of a voxel of the interpolant's level set: their vertices on it, their
chords across a refined cell.
"""

from __future__ import annotations

import numpy as np

from .read import Image

__all__ = ["prepared_values", "level_surface", "AUTO_REFINE_POINTS"]

#: ``refine=None`` refines twice when the refined grid holds at most this many samples, else once.
AUTO_REFINE_POINTS = 40_000_000


def smoothed(values: np.ndarray, spacing: np.ndarray, smoothing: float) -> np.ndarray:
    """``values`` as float32, blurred by a Gaussian of ``smoothing`` voxels of the finest axis."""
    data = np.asarray(values, dtype=np.float32)
    if smoothing <= 0:
        return data
    from scipy import ndimage

    sigma = smoothing * float(spacing.min()) / spacing
    return ndimage.gaussian_filter(data, sigma=sigma, mode="nearest")


def refined(values: np.ndarray, spacing: np.ndarray, refine: int) -> tuple[np.ndarray, np.ndarray]:
    """The cubic B-spline interpolant of ``values`` at ``refine`` times the samples along each
    axis (the first and last samples kept), and its spacing."""
    if refine == 1:
        return values, spacing
    from scipy import ndimage

    shape = (np.array(values.shape) - 1) * refine + 1
    zoom = shape / np.array(values.shape)
    fine = ndimage.zoom(values, zoom, order=3, mode="nearest", grid_mode=False, output=np.float32)
    return fine, spacing / refine


def auto_refine(shape: tuple[int, ...]) -> int:
    """2 when the twice-refined grid stays under ``AUTO_REFINE_POINTS`` samples, else 1."""
    return 2 if float(np.prod((np.array(shape) - 1) * 2 + 1)) <= AUTO_REFINE_POINTS else 1


def prepared_values(image: Image, level: float, inside: str, smoothing: float, refine: int):
    """The field whose zero set is contoured: ``level - value`` (``inside="above"``) or
    ``value - level``, negative inside, smoothed and refined; and its spacing."""
    data = smoothed(image.values, image.spacing, smoothing)
    data, spacing = refined(data, image.spacing, refine)
    field = (np.float32(level) - data) if inside == "above" else (data - np.float32(level))
    return field, spacing


def level_surface(field: np.ndarray, spacing: np.ndarray, origin: np.ndarray) -> tuple[np.ndarray, np.ndarray, bool]:
    """Vertices (V, 3), triangles (F, 3) of the zero set of ``field`` (negative inside) and
    whether the solid reaches the grid's border.

    The field is padded by two samples on every side: the first copies the border, the second is
    outside, so that a solid reaching the border closes between one and two samples beyond it
    (the caller cuts it with the voxels' box).
    """
    import pyvista as pv
    import vtk

    touches = bool((_border(field) < 0).any())
    if touches:
        outside = np.float32(max(1.0, float(np.abs(field).max())))
        field = np.pad(np.pad(field, 1, mode="edge"), 1, constant_values=outside)
        origin = origin - 2 * spacing
    grid = pv.ImageData(dimensions=field.shape, spacing=tuple(spacing), origin=tuple(origin))
    grid.point_data["field"] = field.ravel(order="F")
    contour = vtk.vtkFlyingEdges3D()
    contour.SetInputData(grid)
    contour.SetValue(0, 0.0)
    contour.ComputeNormalsOff()
    contour.ComputeGradientsOff()
    contour.ComputeScalarsOff()
    contour.Update()
    surface = pv.wrap(contour.GetOutput())
    vertices = np.asarray(surface.points, dtype=np.float64)
    # flying edges orients triangles towards decreasing values: turned, outward for a field negative inside
    faces = np.asarray(surface.faces).reshape(-1, 4)[:, [1, 3, 2]].astype(np.int64)
    return vertices, faces, touches


def _border(field: np.ndarray) -> np.ndarray:
    return np.concatenate([
        field[[0, -1]].ravel(), field[:, [0, -1]].ravel(), field[:, :, [0, -1]].ravel(),
    ])
