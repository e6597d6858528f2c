"""Measurements of a tetrahedral mesh against its model, the same for every mesher.

Counts, volume error, boundary fidelity (``|model|`` at boundary nodes and the two-sided
Hausdorff distance of the boundary surface to a reference surface), and every quality metric of
:mod:`fepre.quality` with its minimum, 1st percentile, mean and maximum.

Examples
--------
>>> import numpy as np, pyvista as pv
>>> from fepre import sdf
>>> p = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]], float)
>>> grid = pv.UnstructuredGrid({pv.CellType.TETRA: np.array([[0, 1, 2, 3]])}, p)
>>> mesh_metrics(grid, sdf.sphere(2.0))["elements"]
1
"""

from __future__ import annotations

from typing import Any

import numpy as np

__all__ = ["tetra_cells", "boundary_faces", "boundary_surface", "hausdorff", "model_hausdorff", "mesh_metrics",
           "mean_edge_length"]

# face opposite each vertex, outward for a positive (VTK) tetrahedron
_FACES = np.array([[1, 2, 3], [0, 3, 2], [0, 1, 3], [0, 2, 1]])


def tetra_cells(mesh: Any) -> np.ndarray:
    """Corner connectivity (M, 4) of a grid of linear or quadratic tetrahedra."""
    import pyvista as pv

    if not isinstance(mesh, pv.UnstructuredGrid):
        raise TypeError(f"mesh must be a pyvista.UnstructuredGrid; got {type(mesh).__name__}")
    cells = mesh.cells_dict
    kinds = set(cells)
    allowed = {int(pv.CellType.TETRA), int(pv.CellType.QUADRATIC_TETRA)}
    if not kinds or not kinds <= allowed or len(kinds) > 1:
        raise ValueError(f"mesh must hold only tetrahedra (VTK_TETRA or VTK_QUADRATIC_TETRA); got cell types {sorted(kinds)}")
    return np.asarray(next(iter(cells.values()))[:, :4], dtype=np.int64)


def boundary_faces(tets: np.ndarray) -> np.ndarray:
    """Faces (K, 3) used by exactly one tetrahedron, oriented outward."""
    faces = tets[:, _FACES].reshape(-1, 3)
    key = np.sort(faces, axis=1)
    _, first, counts = np.unique(key, axis=0, return_index=True, return_counts=True)
    return faces[first[counts == 1]]


def boundary_surface(mesh: Any):
    """The boundary triangles of a tetrahedral grid as a ``pyvista.PolyData`` (outward).

    Examples
    --------
    >>> import numpy as np, pyvista as pv
    >>> p = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]], float)
    >>> grid = pv.UnstructuredGrid({pv.CellType.TETRA: np.array([[0, 1, 2, 3]])}, p)
    >>> boundary_surface(grid).n_cells
    4
    """
    return _boundary(mesh)[0]


def _boundary(mesh: Any) -> tuple[Any, np.ndarray]:
    """Boundary surface and the mesh's indices of its nodes."""
    import pyvista as pv

    faces = boundary_faces(tetra_cells(mesh))
    used, inverse = np.unique(faces, return_inverse=True)
    points = np.asarray(mesh.points, dtype=np.float64)[used]
    return pv.PolyData.from_regular_faces(points, inverse.reshape(-1, 3)), used


def _surface_samples(surface: Any) -> np.ndarray:
    """Vertices and triangle centroids of a surface (the Hausdorff samples)."""
    points = np.asarray(surface.points, dtype=np.float64)
    triangles = np.asarray(surface.regular_faces, dtype=np.int64)
    return np.concatenate([points, points[triangles].mean(axis=1)])


def _distances_to_surface(points: np.ndarray, surface: Any) -> np.ndarray:
    """Distance from each point to the nearest point of ``surface``'s triangles (VTK cell locator)."""
    _, closest = surface.find_closest_cell(points, return_closest_point=True)
    return np.linalg.norm(np.asarray(closest) - points, axis=1)


def hausdorff(a: Any, b: Any) -> tuple[float, float]:
    """Directed Hausdorff distances (``a`` to ``b``, ``b`` to ``a``) of two triangle surfaces.

    Each direction is the largest exact point-to-triangle distance over the vertices and triangle
    centroids of the first surface.

    Examples
    --------
    >>> import pyvista as pv
    >>> [round(d, 2) for d in hausdorff(pv.Sphere(radius=1.0), pv.Sphere(radius=1.2))]
    [0.2, 0.2]
    """
    return (
        float(_distances_to_surface(_surface_samples(a), b).max()),
        float(_distances_to_surface(_surface_samples(b), a).max()),
    )


#: Barycentric sample points of a triangle for :func:`model_hausdorff`: corners, edge
#: midpoints, centroid and points between them.
_BARYCENTRIC = np.array(
    [[1, 0, 0], [0, 1, 0], [0, 0, 1], [0.5, 0.5, 0], [0, 0.5, 0.5], [0.5, 0, 0.5], [1 / 3, 1 / 3, 1 / 3],
     [2 / 3, 1 / 6, 1 / 6], [1 / 6, 2 / 3, 1 / 6], [1 / 6, 1 / 6, 2 / 3]]
)


def model_hausdorff(
    mesh: Any,
    model: Any,
    *,
    spacing: float,
    exclude: Any = None,
    margin: float = 0.0,
) -> tuple[float, float]:
    """Directed Hausdorff distances between a mesh's boundary and the model's true surface.

    Mesh to surface: ten points per boundary triangle (corners, edge midpoints, interior points),
    each moved onto the zero set by Newton steps (:meth:`fepre.sdf.SDF.project`); the distance
    moved bounds the distance to the surface from above. Surface to mesh: vertices of a flying
    edges surface at ``spacing``, moved onto the zero set the same way, measured to the mesh's
    boundary triangles exactly.

    Parameters
    ----------
    mesh : pyvista.UnstructuredGrid
    model : SDF
    spacing : float
        Grid spacing of the model's sampled surface.
    exclude : SDF, optional
        Leave out samples inside this solid or within ``margin`` of it (curved parts, where
        chords are expected).
    margin : float

    Returns
    -------
    (mesh_to_surface, surface_to_mesh) : floats

    Examples
    --------
    >>> import fepre
    >>> from fepre import sdf
    >>> mesh = fepre.distmesh(sdf.box(1.0), h=0.5)
    >>> [round(d, 9) for d in model_hausdorff(mesh, sdf.box(1.0), spacing=0.05)]
    [0.0, 0.0]
    """
    from .surface import isosurface

    surface, _ = _boundary(mesh)
    corners = np.asarray(surface.points, dtype=np.float64)[np.asarray(surface.regular_faces, dtype=np.int64)]
    samples = np.einsum("sk,tkd->tsd", _BARYCENTRIC, corners).reshape(-1, 3)
    truth = np.asarray(isosurface(model, spacing=spacing).points, dtype=np.float64)
    truth = model.project(truth, iterations=30, warn=False)
    if exclude is not None:
        samples = samples[exclude(samples) > margin]
        truth = truth[exclude(truth) > margin]
    to_surface = np.linalg.norm(model.project(samples, iterations=30, warn=False) - samples, axis=1) if len(samples) else np.zeros(1)
    from_surface = _distances_to_surface(truth, surface) if len(truth) else np.zeros(1)
    return float(to_surface.max()), float(from_surface.max())


def mean_edge_length(points: np.ndarray, tets: np.ndarray) -> float:
    """Mean length of the mesh's edges, each counted once.

    Examples
    --------
    >>> import numpy as np
    >>> corners = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1.0]])
    >>> round(mean_edge_length(corners, np.array([[0, 1, 2, 3]])), 6)   # 3 edges of 1, 3 of sqrt 2
    1.207107
    """
    pairs = np.sort(tets[:, [[0, 1], [0, 2], [0, 3], [1, 2], [1, 3], [2, 3]]].reshape(-1, 2), axis=1)
    edges = np.unique(pairs[:, 0].astype(np.int64) * points.shape[0] + pairs[:, 1])
    a, b = edges // points.shape[0], edges % points.shape[0]
    return float(np.linalg.norm(points[a] - points[b], axis=1).mean()) if edges.size else float("nan")


def mesh_metrics(
    mesh: Any,
    model: Any,
    *,
    reference: Any = None,
    volume: float | None = None,
    seconds: float | None = None,
) -> dict[str, float]:
    """Measure one tetrahedral mesh.

    Parameters
    ----------
    mesh : pyvista.UnstructuredGrid
        Linear or quadratic tetrahedra.
    model : SDF
        The part; boundary nodes are scored by ``|model|``.
    reference : pyvista.PolyData, optional
        Surface for the two-sided Hausdorff distance of the mesh boundary.
    volume : float, optional
        The part's volume (exact or estimated) for the volume error.
    seconds : float, optional
        Meshing time, copied into the result.

    Returns
    -------
    dict
        Keys ``elements``, ``nodes``, ``volume``, ``volume_error`` (relative), ``inverted``,
        ``boundary_sdf_max``, ``boundary_sdf_mean``, ``hausdorff`` (and its two directions),
        ``<metric>_<stat>`` for every quality metric, ``below_10``/``below_15`` (cells with a
        dihedral angle under 10/15 degrees), ``seconds``, ``ms_per_1000_cells`` and
        ``mean_edge_length`` (to set beside ``h``: meshers differ in how long their edges come
        out for the same ``h``).

    Examples
    --------
    >>> import numpy as np, pyvista as pv
    >>> from fepre import sdf
    >>> p = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]], float)
    >>> grid = pv.UnstructuredGrid({pv.CellType.TETRA: np.array([[0, 1, 2, 3]])}, p)
    >>> m = mesh_metrics(grid, sdf.sphere(2.0), volume=1 / 6)
    >>> m["elements"], round(m["volume_error"], 12), round(m["boundary_sdf_max"], 3)
    (1, 0.0, 2.0)
    """
    from .quality import tet_quality

    tets = tetra_cells(mesh)
    points = np.asarray(mesh.points, dtype=np.float64)
    quality = tet_quality(points, tets)
    total = float(quality["volume"].sum())
    surface, boundary_nodes = _boundary(mesh)
    sdf_at_boundary = np.abs(np.asarray(model(points[boundary_nodes]), dtype=np.float64))

    metrics: dict[str, float] = {
        "elements": int(len(tets)),
        "nodes": int(mesh.n_points),
        "boundary_nodes": int(len(boundary_nodes)),
        "volume": total,
        "volume_error": (total - volume) / volume if volume else float("nan"),
        "inverted": int(np.count_nonzero(quality["volume"] <= 0)),
        "boundary_sdf_max": float(sdf_at_boundary.max()),
        "boundary_sdf_mean": float(sdf_at_boundary.mean()),
    }
    if reference is not None:
        to_reference, from_reference = hausdorff(surface, reference)
        metrics.update(
            hausdorff=max(to_reference, from_reference),
            hausdorff_mesh_to_surface=to_reference,
            hausdorff_surface_to_mesh=from_reference,
        )
    for name in ("min_dihedral_angle", "max_dihedral_angle", "radius_ratio", "volume_edge_ratio"):
        values = quality[name]
        metrics[f"{name}_min"] = float(values.min())
        metrics[f"{name}_p1"] = float(np.percentile(values, 1))
        metrics[f"{name}_mean"] = float(values.mean())
        metrics[f"{name}_max"] = float(values.max())
    metrics["below_10"] = int(np.count_nonzero(quality["min_dihedral_angle"] < 10.0))
    metrics["below_15"] = int(np.count_nonzero(quality["min_dihedral_angle"] < 15.0))
    metrics["seconds"] = float("nan") if seconds is None else float(seconds)
    metrics["ms_per_1000_cells"] = 1e6 * metrics["seconds"] / max(len(tets), 1)
    metrics["mean_edge_length"] = mean_edge_length(points, tets)
    return metrics
