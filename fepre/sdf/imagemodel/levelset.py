"""The level set of an image's smooth interpolant, as triangles.

The image is optionally smoothed (a Gaussian, ``smoothing`` voxels of the finest axis wide),
refined ``refine`` times by its cubic B-spline interpolant (:mod:`.bspline`: the coefficients of
``scipy.ndimage.zoom``'s prefilter, evaluated one axis at a time, passing through the samples),
padded so that the surface closes at the image's border, and contoured by VTK's flying edges
(linear along every grid edge of the refined grid). The triangles then lie within a small
fraction of a voxel of the interpolant's level set: their vertices on it, their chords across a
refined cell.

Every step is local, so a chunked image (:mod:`fepre.chunked.image`) gives the same triangles:
whether to pad is decided from the samples of the border slabs (:func:`needs_padding`), the
outside value from the image's range (:func:`outside_value`), and flying edges runs about the
origin (its float32 coordinates are node indices times spacing, whatever the extent).
"""

from __future__ import annotations

import numpy as np

from .bspline import SPLINE_HALO, certainly_one_side, refine_samples, refined_count
from .read import Image

__all__ = ["prepared_values", "level_surface", "needs_padding", "outside_value", "smoothing_radius", "border_values",
           "AUTO_REFINE_POINTS", "BORDER_PAD"]

#: nodes added beyond each face when the solid may reach it: a copy of the border, then an
#: outside node
BORDER_PAD = 2

#: ``refine=None`` refines twice when the refined grid holds at most this many samples, else once.
AUTO_REFINE_POINTS = 40_000_000


def smoothing_sigma(spacing: np.ndarray, smoothing: float) -> np.ndarray:
    """The Gaussian's standard deviation in samples along each axis."""
    return smoothing * float(np.min(spacing)) / np.asarray(spacing, dtype=float)


def smoothing_radius(spacing: np.ndarray, smoothing: float) -> int:
    """Samples the Gaussian reaches along its widest axis (scipy's ``int(4 sigma + 0.5)``); 0
    without smoothing."""
    if smoothing <= 0:
        return 0
    return int(max(int(4.0 * float(s) + 0.5) for s in smoothing_sigma(spacing, smoothing)))


def smoothed(values: np.ndarray, spacing: np.ndarray, smoothing: float) -> np.ndarray:
    """``values`` as float32, blurred by a Gaussian of ``smoothing`` voxels of the finest axis."""
    data = np.asarray(values, dtype=np.float32)
    if smoothing <= 0:
        return data
    from scipy import ndimage

    return ndimage.gaussian_filter(data, sigma=smoothing_sigma(spacing, smoothing), mode="nearest")


def refined(values: np.ndarray, spacing: np.ndarray, refine: int) -> tuple[np.ndarray, np.ndarray]:
    """The cubic B-spline interpolant of ``values`` at ``refine`` times the samples along each
    axis (the first and last samples kept), and its spacing."""
    if refine == 1:
        return values, spacing
    counts = [refined_count(n, refine) for n in values.shape]
    fine = refine_samples(values, (0, 0, 0), (0, 0, 0), counts, refine)
    return fine, spacing / refine


def signed_field(values: np.ndarray, level: float, inside: str) -> np.ndarray:
    """``level - values`` (``inside="above"``) or ``values - level`` in float32: negative inside."""
    return (np.float32(level) - values) if inside == "above" else (values - np.float32(level))


def border_depth(spacing: np.ndarray, smoothing: float, refine: int) -> int:
    """Samples from a face of the image whose values bound the refined field on that face: the
    Gaussian's reach, then (refined) the B-spline's halo and support."""
    return 1 + smoothing_radius(spacing, smoothing) + (SPLINE_HALO + 2 if refine > 1 else 0)


def side_of(field_low: float, field_high: float, refine: int, tolerance: float) -> int:
    """+1 (-1) when the refined field of samples whose field lies in ``[low, high]`` is surely
    positive (negative) everywhere: smoothing keeps values in their range, the B-spline may
    overshoot it (:func:`.bspline.certainly_one_side`)."""
    if refine > 1:
        return certainly_one_side(field_low, field_high, tolerance)
    return 1 if field_low > tolerance else (-1 if field_high < -tolerance else 0)


def outside_value(low: float, high: float, level: float) -> np.float32:
    """The value of the outer padding: positive and beyond every sample's field."""
    return np.float32(max(1.0, abs(level - low), abs(level - high)))


def field_tolerance(low: float, high: float, level: float) -> float:
    """Rounding allowance of the side tests: float32 steps of the largest field value."""
    return 1e-5 * float(outside_value(low, high, level))


def needs_padding(slab_ranges, level: float, inside: str, refine: int, low: float, high: float) -> bool:
    """Whether the refined field may be negative on the image's border, from the (min, max)
    of the samples in each face's slab of :func:`border_depth` samples: the surface is then
    closed beyond the border (padding), else the border is surely outside."""
    tolerance = field_tolerance(low, high, level)
    for lo, hi in slab_ranges:
        field = (level - hi, level - lo) if inside == "above" else (lo - level, hi - level)
        if side_of(field[0], field[1], refine, tolerance) != 1:
            return True
    return False


def border_slab_ranges(values: np.ndarray, depth: int) -> list[tuple[float, float]]:
    """(min, max) of the samples within ``depth`` of each of the six faces."""
    ranges = []
    for axis in range(3):
        n = values.shape[axis]
        for part in (slice(0, min(depth, n)), slice(max(0, n - depth), n)):
            index = [slice(None)] * 3
            index[axis] = part
            slab = values[tuple(index)]
            ranges.append((float(slab.min()), float(slab.max())))
    return ranges


def auto_refine(shape: tuple[int, ...]) -> int:
    """2 when the twice-refined grid stays under ``AUTO_REFINE_POINTS`` samples, else 1."""
    return 2 if float(np.prod((np.array(shape) - 1) * 2 + 1)) <= AUTO_REFINE_POINTS else 1


def prepared_values(image: Image, level: float, inside: str, smoothing: float, refine: int):
    """The field whose zero set is contoured: ``level - value`` (``inside="above"``) or
    ``value - level``, negative inside, smoothed and refined; and its spacing."""
    data = smoothed(image.values, image.spacing, smoothing)
    data, spacing = refined(data, image.spacing, refine)
    return signed_field(data, level, inside), spacing


def contour(field: np.ndarray, spacing: np.ndarray, origin: np.ndarray, first=(0, 0, 0)) -> tuple[np.ndarray, np.ndarray]:
    """Flying edges of ``field`` (x, y, z; negative inside) whose node (0, 0, 0) is node ``first``
    of a grid at ``origin``: vertices (V, 3) and outward triangles (F, 3).

    VTK runs about the origin and the extent starts at ``first`` (its float32 coordinates are then
    the whole grid's node indices times spacing, as :mod:`fepre.chunked` extracts chunks); the
    origin is added in float64.
    """
    import pyvista as pv
    import vtk

    grid = pv.ImageData(dimensions=field.shape, spacing=tuple(spacing))
    f = [int(v) for v in first]
    grid.SetExtent(f[0], f[0] + field.shape[0] - 1, f[1], f[1] + field.shape[1] - 1, f[2], f[2] + field.shape[2] - 1)
    grid.point_data["field"] = field.ravel(order="F")
    extractor = vtk.vtkFlyingEdges3D()
    extractor.SetInputData(grid)
    extractor.SetValue(0, 0.0)
    extractor.ComputeNormalsOff()
    extractor.ComputeGradientsOff()
    extractor.ComputeScalarsOff()
    extractor.Update()
    surface = pv.wrap(extractor.GetOutput())
    if surface.n_points == 0:
        return np.empty((0, 3)), np.empty((0, 3), dtype=np.int64)
    vertices = np.asarray(surface.points, dtype=np.float64) + origin
    # flying edges orients triangles towards decreasing values: turned, outward for a field negative inside
    faces = np.asarray(surface.faces).reshape(-1, 4)[:, [1, 3, 2]].astype(np.int64)
    return vertices, faces


def level_surface(field: np.ndarray, spacing: np.ndarray, origin: np.ndarray, *, pad: bool,
                  outside: float) -> tuple[np.ndarray, np.ndarray, bool]:
    """Vertices (V, 3), triangles (F, 3) of the zero set of ``field`` (negative inside) and
    whether the solid reaches the grid's border.

    With ``pad`` (:func:`needs_padding`) the field is padded by ``BORDER_PAD`` samples on every
    side: the first copies the border, the others are ``outside``, so that a solid reaching the
    border closes between one and two samples beyond it (the caller cuts it with the voxels' box).
    """
    touches = bool((border_values(field) < 0).any())
    if pad or touches:
        field = np.pad(np.pad(field, 1, mode="edge"), BORDER_PAD - 1, constant_values=np.float32(outside))
        origin = origin - BORDER_PAD * spacing
    vertices, faces = contour(field, spacing, origin)
    return vertices, faces, touches


def border_values(field: np.ndarray) -> np.ndarray:
    """The values on the six faces of a 3D array, in one flat array."""
    return np.concatenate([
        field[[0, -1]].ravel(), field[:, [0, -1]].ravel(), field[:, :, [0, -1]].ravel(),
    ])
