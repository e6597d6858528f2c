"""``fepre.isosurface``: sample if needed, run one extractor, return an outward PolyData."""

from __future__ import annotations

from typing import Any

import numpy as np

from ..arguments import choice, finite_float
from ..backends import provided
from ..config import config
from ..errors import warn_user
from ..sdf.core import SDF
from .dual_contouring import dual_contouring
from .flying_edges import flying_edges
from .marching_cubes import marching_cubes
from .weld import weld
from .zero_area import remove_zero_area
from .marching_tetrahedra import marching_tetrahedra
from .surface_nets import surface_nets

__all__ = ["isosurface", "METHODS", "triangle_polydata"]

METHODS = ("flying_edges", "marching_cubes", "marching_tetrahedra", "surface_nets", "dual_contouring")
#: methods whose triangles can have three distinct collinear corners (the cube-table methods'
#: only arise at nodes on the level, which the weld removes); the check costs 0.4 s per 2M triangles
_COLLINEAR_METHODS = ("dual_contouring", "surface_nets", "marching_tetrahedra")
_NUMPY_METHODS = {
    "marching_cubes": marching_cubes,
    "marching_tetrahedra": marching_tetrahedra,
    "surface_nets": surface_nets,
}


def triangle_polydata(points: np.ndarray, triangles: np.ndarray):
    """A :class:`pyvista.PolyData` of triangles (built without a Python loop)."""
    import pyvista as pv

    if len(triangles) == 0:
        return pv.PolyData()
    return pv.PolyData.from_regular_faces(np.asarray(points), np.asarray(triangles, dtype=np.int64))


def _grid_values(grid, scalars: str | None) -> tuple[np.ndarray, str]:
    import pyvista as pv

    if not isinstance(grid, pv.ImageData):
        raise TypeError(f"source must be a fepre.sdf.SDF or a pyvista.ImageData; got {type(grid).__name__}")
    name = "sdf" if scalars is None else scalars
    if name not in grid.point_data:
        available = ", ".join(repr(k) for k in grid.point_data.keys()) or "none"
        if scalars is None:
            raise ValueError(
                f"the ImageData has no point array 'sdf'; pass scalars= naming the array to contour "
                f"(point arrays: {available})"
            )
        raise ValueError(f"scalars={scalars!r} is not a point array of the ImageData (point arrays: {available})")
    array = np.asarray(grid.point_data[name])
    if array.ndim != 1:
        raise ValueError(f"scalars {name!r} must be a scalar array; got shape {array.shape}")
    if not np.issubdtype(array.dtype, np.floating):
        array = array.astype(np.float64)
    if np.any(np.asarray(grid.direction_matrix) != np.eye(3)):
        raise ValueError("source ImageData must have the identity direction matrix")
    nx, ny, nz = grid.dimensions
    if min(nx, ny, nz) < 2:
        raise ValueError(f"source ImageData must have at least 2 nodes per axis; got dimensions {grid.dimensions}")
    return array.reshape(nz, ny, nx), name


def _check_samples(values: np.ndarray, name: str, grid) -> None:
    """Refuse NaN samples (one reduction pass: the minimum of an array holding NaN is NaN)."""
    if np.isnan(np.min(values)):
        flat = values.reshape(-1)
        where = int(np.flatnonzero(np.isnan(flat))[0])
        raise ValueError(
            f"the {name!r} samples contain NaN (first at point {where}, {grid.GetPoint(where)}); "
            f"fix the model or the array so every node has a value"
        )


def isosurface(
    source: Any,
    *,
    method: str = "flying_edges",
    level: float = 0.0,
    spacing: Any = None,
    shape: Any = None,
    bounds: Any = None,
    scalars: str | None = None,
    normals: bool = False,
    band: float | None = None,
    model: SDF | None = None,
    workers: int | None = None,
    chunks: Any = None,
):
    """Extract the ``level`` set of a model or an image grid as outward triangles.

    Parameters
    ----------
    source : fepre.sdf.SDF, pyvista.ImageData or fepre.chunked.ChunkedGrid
        A model (sampled first with :func:`fepre.sample` and ``spacing``/``shape``/``bounds``/
        ``band``), a sampled grid, or a chunked grid (extracted chunk by chunk).
    method : {"flying_edges", "marching_cubes", "marching_tetrahedra", "surface_nets", "dual_contouring"}
        ``"flying_edges"`` is VTK's vtkFlyingEdges3D (the reference); the others are fepre's.
        ``"dual_contouring"`` keeps the sharp edges and corners of CSG parts: each cell's vertex
        minimises the distance to the model's tangent planes at its crossings (see
        :mod:`fepre.surface.dual_contouring`).
    level : float
        The iso value (a node with value >= level counts as outside).
    scalars : str, optional
        Point array of an ImageData source (default ``"sdf"``).
    normals : bool
        Add point normals ``"Normals"``: the model's normalised gradient when there is a model,
        area-weighted triangle normals for a grid source without one.
    model : fepre.sdf.SDF, optional
        For an ImageData source only: the model it was sampled from. Dual contouring then takes
        its crossings and normals from the model (sharp features) instead of from the grid's
        gradient, and ``normals`` uses its gradient.
    workers : int, optional
        Threads (default ``fepre.config.workers``; chunked: dask's scheduler decides).
    chunks : int or (3,) ints, optional
        Nodes per chunk along x, y, z (at least 8): extract chunk by chunk on dask (threads, or
        the user's ``dask.distributed`` client) and stitch. Each chunk reads a halo (one node for
        the case-table methods, three for the dual ones), vertices shared by chunks are merged
        by their grid edge or cell, and the result is the single-grid surface (fepre's methods:
        the same arrays; flying edges: the same vertices and triangles in another order). A
        model is sampled per chunk in a narrow band (default two cell diagonals beyond the
        level), so chunks far from the surface cost one evaluation. See
        :func:`fepre.chunked.write_isosurface` for surfaces too large to hold.

    Returns
    -------
    pyvista.PolyData
        Triangles with normals pointing to positive values, in world coordinates, without
        coincident vertices or the zero-area triangles between them (grid nodes on the level,
        :mod:`fepre.surface.weld`); field data
        ``"surface_method"``, ``"surface_level"``, ``"surface_spacing"`` and the grid's
        ``"surface_grid_origin"``/``"surface_grid_dimensions"``. Empty (with a warning) when the
        level is not crossed.

    Examples
    --------
    >>> import fepre
    >>> from fepre import sdf
    >>> surface = fepre.isosurface(sdf.sphere(1.0), spacing=0.1, method="marching_cubes")
    >>> surface.is_all_triangles, round(surface.area, 1)
    (True, 12.5)
    >>> cube = sdf.box((1, 1, 1))
    >>> sharp = fepre.isosurface(cube, spacing=0.1, method="dual_contouring")
    >>> round(sharp.area, 6), round(fepre.check_surface(sharp).volume, 6)
    (6.0, 1.0)
    """
    # chunk by chunk: fepre.chunked, above this module (see fepre.backends)
    if chunks is not None or isinstance(source, provided("ChunkedGrid")):
        if scalars not in (None, "sdf"):
            raise ValueError("scalars applies only to an ImageData source")
        return provided("isosurface_chunked")(
            source, method=method, level=level, chunks=chunks, spacing=spacing, shape=shape, bounds=bounds,
            band=band, model=model, normals=normals,
        )
    method = choice(method, "method", METHODS)
    level = finite_float(level, "level")
    workers = config.resolve_workers(workers)
    if model is not None and not isinstance(model, SDF):
        raise TypeError(f"model must be a fepre.sdf.SDF or None; got {type(model).__name__}")
    grid, values, name, model = _sampled_source(source, model, spacing, shape, bounds, band, scalars, workers)
    _check_samples(values, name, grid)
    if "sdf_band" in grid.field_data and name == "sdf":
        width = float(np.asarray(grid.field_data["sdf_band"])[0])
        if abs(level) > width - float(np.linalg.norm(grid.spacing)):
            warn_user(
                f"level {level:g} is not inside the sampled band (half-width {width:g}); the surface "
                f"may be wrong: sample with a wider band",
                UserWarning,
            )
    points, triangles = _extract(method, grid, values, name, level, workers, model)
    points, triangles = clean_triangles(
        points, triangles, method, bool((values == level).any()), grid.spacing, grid.origin
    )
    return surface_dataset(
        points,
        triangles,
        method=method,
        level=level,
        grid=(grid.origin, grid.spacing, grid.dimensions),
        normals=normals,
        model=model,
        value_range=lambda: (float(values.min()), float(values.max())),
    )


#: the weld's tolerance in grid spacings
NEAR_LEVEL = 1e-6
#: the methods whose vertices lie on grid edges (a node a hair off the level gathers them)
_EDGE_METHODS = ("flying_edges", "marching_cubes", "marching_tetrahedra")


def _sampled_source(source, model, spacing, shape, bounds, band, scalars, workers):
    """The grid to extract from (a model is sampled), its values (nz, ny, nx), their name and the
    model: ``(grid, values, name, model)``."""
    if isinstance(source, SDF):
        if model is not None:
            raise ValueError("model applies only when source is an ImageData; the source is already a model")
        from ..sampling import sample

        model = source
        grid = sample(model, spacing=spacing, shape=shape, bounds=bounds, band=band, workers=workers)
        name = "sdf"
        values = np.asarray(grid.point_data[name]).reshape(tuple(reversed(grid.dimensions)))
    else:
        for option, value in (("spacing", spacing), ("shape", shape), ("bounds", bounds), ("band", band)):
            if value is not None:
                raise ValueError(f"{option} applies only when source is a model; the ImageData is already sampled")
        grid = source
        values, name = _grid_values(grid, scalars)
    return grid, values, name, model


def _extract(method: str, grid, values: np.ndarray, name: str, level: float, workers: int, model):
    """The raw ``(points, triangles)`` of one method, before cleaning."""
    if method == "flying_edges":
        return flying_edges(grid, name, level, workers)
    origin = np.asarray(grid.origin, dtype=float)
    step = np.asarray(grid.spacing, dtype=float)
    if method == "dual_contouring":
        return dual_contouring(values, level, origin, step, workers, model=model)
    return _NUMPY_METHODS[method](values, level, origin, step, workers)


def clean_triangles(
    points: np.ndarray, triangles: np.ndarray, method: str, on_level: bool, spacing: Any, origin: Any = None
) -> tuple[np.ndarray, np.ndarray]:
    """The passes after extraction: weld where grid nodes lie on the level (or so near it that
    the crossings on their edges land within the weld's tolerance of the node: a label image's
    smoothed value a rounding error off the level), then (for the methods that make them) flip
    away triangles with three collinear corners."""
    tolerance = NEAR_LEVEL * float(np.min(spacing))
    near_node = method in _EDGE_METHODS and origin is not None and _vertex_at_node(points, origin, spacing, tolerance)
    if points.shape[0] and (on_level or near_node):
        # nodes on the level: the crossings on their edges coincide
        points, triangles = weld(np.asarray(points), np.asarray(triangles), tolerance)
    if len(triangles) and method in _COLLINEAR_METHODS:
        # corners on one line (dual contouring along a crease, marching tetrahedra through an
        # edge): flipped away, the surface unchanged
        points, triangles = remove_zero_area(np.asarray(points), np.asarray(triangles), tolerance)
    return points, triangles


def _vertex_at_node(points: np.ndarray, origin: Any, spacing: Any, tolerance: float) -> bool:
    """Whether a vertex lies within ``tolerance`` of a grid node (a node all but on the level)."""
    step = np.asarray(spacing, dtype=float)
    cells = (np.asarray(points, dtype=float) - np.asarray(origin, dtype=float)) / step
    off = np.abs(cells - np.rint(cells)) * step
    return bool(np.any(np.all(off <= tolerance, axis=1)))


def surface_dataset(
    points: np.ndarray,
    triangles: np.ndarray,
    *,
    method: str,
    level: float,
    grid: tuple[Any, Any, Any],
    normals: bool,
    model: SDF | None,
    value_range,
):
    """The PolyData ``isosurface`` returns: triangles, optional normals and the field data naming
    the method, level and grid ``(origin, spacing, dimensions)``; warns when empty
    (``value_range()`` gives the samples' range for the message)."""
    origin, spacing, dimensions = grid
    surface = triangle_polydata(points, triangles)
    if surface.n_points == 0:
        low, high = value_range()
        warn_user(
            f"the surface is empty: level {level:g} is not crossed by the samples (range "
            f"[{low:g}, {high:g}]); choose a level inside that range or check the model and bounds",
            UserWarning,
        )
    elif normals:
        surface.point_data["Normals"] = _point_normals(surface, model, points, triangles)
    surface.field_data["surface_method"] = np.array([method])
    surface.field_data["surface_level"] = np.array([level])
    surface.field_data["surface_spacing"] = np.asarray(spacing, dtype=float)
    surface.field_data["surface_grid_origin"] = np.asarray(origin, dtype=float)
    surface.field_data["surface_grid_dimensions"] = np.asarray(dimensions, dtype=np.int64)
    return surface


def _point_normals(surface, model: SDF | None, points: np.ndarray, triangles: np.ndarray) -> np.ndarray:
    if model is not None:
        gradient = model.gradient(np.asarray(points, dtype=float))
    else:
        p = np.asarray(points, dtype=float)[triangles]
        face = np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0])  # length = 2 * area
        gradient = np.stack(
            [np.bincount(triangles.ravel(), weights=np.repeat(face[:, a], 3), minlength=len(points)) for a in range(3)],
            axis=1,
        )
    length = np.linalg.norm(gradient, axis=1, keepdims=True)
    return gradient / np.where(length > 0, length, 1.0)
