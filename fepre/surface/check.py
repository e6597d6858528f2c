"""``fepre.check_surface``: is a triangle surface closed, manifold, oriented, and how accurate?"""

from __future__ import annotations

from dataclasses import dataclass, fields
from typing import Any

import numpy as np

__all__ = ["SurfaceCheck", "check_surface"]


@dataclass
class SurfaceCheck:
    """Topology, geometry and accuracy figures of a triangle surface.

    Topology (``points``, ``watertight``, ``manifold``, ``oriented``, ``components``, ``genus``) is
    counted with exactly coincident vertices merged and the triangles that collapse left out, as a
    reader of an STL sees it; ``triangles``, ``area``, ``volume``, ``min_angle`` and
    ``degenerate_triangles`` are of the triangles as given.

    ``thin_components`` counts the components thinner than the grid spacing (enclosed volume
    over area under half a spacing): a wall under a spacing, or the pieces of an acute wedge's
    tip that the samples caught here and there. Their shape is below what the grid resolves;
    a finer spacing fixes them. None without a spacing.

    ``max_sdf_error``/``mean_sdf_error`` are ``|model(vertex)|`` divided by ``error_unit`` (the grid
    spacing the surface was extracted at); ``hausdorff`` is the two-sided vertex-to-surface
    distance to the reference, in world units. Figures that need a model or reference are None
    without one.
    """

    points: int
    triangles: int
    watertight: bool
    manifold: bool
    oriented: bool
    components: int
    euler_characteristic: int
    genus: float | None
    area: float
    volume: float
    max_sdf_error: float | None
    mean_sdf_error: float | None
    error_unit: float | None
    hausdorff: float | None
    min_angle: float
    degenerate_triangles: int
    thin_components: int | None = None

    def __str__(self) -> str:
        rows = []
        for item in fields(self):
            value = getattr(self, item.name)
            if isinstance(value, float):
                text = f"{value:.6g}"
            elif value is None:
                text = "-"
            else:
                text = str(value)
            rows.append((item.name.replace("_", " "), text))
        width = max(len(name) for name, _ in rows)
        return "\n".join(f"{name:<{width}}  {text}" for name, text in rows)


def _triangles(surface) -> tuple[np.ndarray, np.ndarray]:
    import pyvista as pv

    if not isinstance(surface, pv.PolyData):
        raise TypeError(f"surface must be a pyvista.PolyData; got {type(surface).__name__}")
    if surface.n_cells and not surface.is_all_triangles:
        surface = surface.triangulate()
    points = np.asarray(surface.points, dtype=np.float64)
    faces = np.asarray(surface.regular_faces, dtype=np.int64) if surface.n_cells else np.empty((0, 3), np.int64)
    return points, faces


def _distinct(values: np.ndarray) -> np.ndarray:
    """Sorted distinct values (by sorting: numpy's hash-based ``unique`` is slow on big int arrays)."""
    ordered = np.sort(values, kind="stable")
    return ordered[np.r_[True, ordered[1:] != ordered[:-1]]] if ordered.size else ordered


def _corner_fans(faces: np.ndarray, directed: np.ndarray, key: np.ndarray, order: np.ndarray, count: np.ndarray):
    """Number of (vertex, fan) pairs: corners joined across edges shared by two triangles."""
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import connected_components

    n_corners = faces.size
    position = np.arange(directed.shape[0])
    corner_start = position  # directed edge 3t+p starts at corner 3t+p
    corner_end = 3 * (position // 3) + (position % 3 + 1) % 3
    sorted_keys = key[order]
    first = np.flatnonzero(np.r_[True, sorted_keys[1:] != sorted_keys[:-1]])
    pairs = first[count == 2]
    i, j = order[pairs], order[pairs + 1]
    same = directed[i, 0] == directed[j, 0]
    a = np.concatenate([corner_start[i], corner_end[i]])
    b = np.concatenate([np.where(same, corner_start[j], corner_end[j]), np.where(same, corner_end[j], corner_start[j])])
    graph = coo_matrix((np.ones(a.size), (a, b)), shape=(n_corners, n_corners))
    _, labels = connected_components(graph, directed=False)
    vertex = faces.reshape(-1)
    return _distinct(vertex.astype(np.int64) * n_corners + labels).size


#: Largest number of vertices of each surface whose distance to the other the Hausdorff distance
#: measures; more are sampled evenly (about 20 us per vertex).
HAUSDORFF_VERTICES = 200_000


def _one_way(source, target) -> float:
    from .distance import distance_to_surface

    points = np.asarray(source.points, dtype=np.float64)
    used = np.flatnonzero(np.bincount(np.asarray(source.regular_faces).ravel(), minlength=len(points))) if source.n_cells else np.arange(len(points))
    points = points[used]
    if len(points) > HAUSDORFF_VERTICES:
        points = points[:: -(-len(points) // HAUSDORFF_VERTICES)]
    return float(distance_to_surface(points, np.asarray(target.points), np.asarray(target.regular_faces)).max())


def _hausdorff(surface, reference) -> float:
    """Two-sided vertex-to-surface distance; on big surfaces measured from an even sample of
    ``HAUSDORFF_VERTICES`` vertices of each (exact below that)."""
    return max(_one_way(surface, reference), _one_way(reference, surface))


def _flying_edges_reference(surface, model):
    from ..sampling import sample
    from .extract import isosurface

    origin = np.asarray(surface.field_data["surface_grid_origin"], dtype=float)
    step = np.asarray(surface.field_data["surface_spacing"], dtype=float)
    dims = np.asarray(surface.field_data["surface_grid_dimensions"], dtype=np.int64)
    level = float(np.asarray(surface.field_data["surface_level"])[0]) if "surface_level" in surface.field_data else 0.0
    grid = sample(model, shape=tuple(int(d) for d in dims), bounds=(origin, origin + step * (dims - 1)))
    return isosurface(grid, method="flying_edges", level=level)


@dataclass
class _Topology:
    used: np.ndarray  # vertex ids that triangles use
    labels: np.ndarray  # connected component of every vertex
    watertight: bool
    manifold: bool
    oriented: bool
    components: int
    euler: int
    genus: float | None


def _topology(points: np.ndarray, faces: np.ndarray) -> _Topology:
    """Edges used twice, fans around vertices, orientation, components, Euler characteristic."""
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import connected_components

    used = _distinct(faces.reshape(-1))
    n_vertices = points.shape[0]
    directed = faces[:, [0, 1, 1, 2, 2, 0]].reshape(-1, 2)
    low, high = np.minimum(directed[:, 0], directed[:, 1]), np.maximum(directed[:, 0], directed[:, 1])
    key = low * n_vertices + high
    order = np.argsort(key, kind="stable")
    sorted_key = key[order]
    starts = np.flatnonzero(np.r_[True, sorted_key[1:] != sorted_key[:-1]]) if key.size else np.empty(0, np.int64)
    count = np.diff(np.r_[starts, key.size])
    edges = count.size
    watertight = bool(faces.size) and bool(np.all(count == 2))
    manifold = bool(np.all(count <= 2)) and _corner_fans(faces, directed, key, order, count) == used.size
    directed_key = directed[:, 0] * n_vertices + directed[:, 1]
    oriented = bool(_distinct(directed_key).size == directed_key.size)
    graph = coo_matrix((np.ones(low.size), (low, high)), shape=(n_vertices, n_vertices))
    _, labels = connected_components(graph, directed=False)
    components = int(_distinct(labels[used]).size)
    euler = int(used.size - edges + faces.shape[0])
    genus = components - euler / 2 if watertight and oriented and manifold else None
    return _Topology(used, labels, watertight, manifold, oriented, components, euler, genus)


def surface_genus(faces: np.ndarray) -> int | None:
    """The total genus of a closed surface of triangles (the sum over its pieces; the same
    count as :func:`check_surface`'s), or None unless it is closed, manifold and oriented.

    Examples
    --------
    >>> import pyvista as pv
    >>> surface_genus(pv.Sphere().regular_faces), surface_genus(pv.ParametricTorus().triangulate().clean().regular_faces)
    (0, 1)
    """
    faces = np.asarray(faces, dtype=np.int64)
    if len(faces) == 0:
        return 0
    used, local = np.unique(faces, return_inverse=True)
    genus = _topology(np.empty((len(used), 3)), local.reshape(faces.shape)).genus
    return None if genus is None else int(round(genus))


def _geometry(points: np.ndarray, faces: np.ndarray) -> tuple[float, float, np.ndarray, int]:
    """Area, enclosed volume, the triangles' angles (degrees) and the degenerate triangles."""
    p = points[faces]
    cross = np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0])
    double_area = np.linalg.norm(cross, axis=1)
    area = float(double_area.sum() / 2)
    volume = float(np.einsum("ij,ij->i", p[:, 0], cross).sum() / 6)
    sides = np.stack([np.linalg.norm(p[:, (k + 1) % 3] - p[:, (k + 2) % 3], axis=1) for k in range(3)], axis=1)
    with np.errstate(invalid="ignore", divide="ignore"):
        cosines = [
            (sides[:, (k + 1) % 3] ** 2 + sides[:, (k + 2) % 3] ** 2 - sides[:, k] ** 2)
            / (2 * sides[:, (k + 1) % 3] * sides[:, (k + 2) % 3])
            for k in range(3)
        ]
    angles = np.degrees(np.arccos(np.clip(np.nan_to_num(np.stack(cosines, axis=1), nan=1.0), -1, 1)))
    scale = float(sides.mean()) if sides.size else 0.0
    repeated = (faces[:, 0] == faces[:, 1]) | (faces[:, 1] == faces[:, 2]) | (faces[:, 2] == faces[:, 0])
    degenerate = int(np.count_nonzero(repeated | (double_area <= 1e-12 * scale * scale)))
    return area, volume, angles, degenerate


def check_surface(
    surface, model=None, reference=None, *, spacing: Any = None, merge_coincident: bool = True
) -> SurfaceCheck:
    """Check a triangle surface; compare it with a model and a reference surface.

    Parameters
    ----------
    surface : pyvista.PolyData
    model : fepre.sdf.SDF, optional
        Gives ``max_sdf_error``/``mean_sdf_error`` and, for a surface made by
        :func:`fepre.isosurface` with another method than flying edges, the default reference:
        flying edges on the same grid. Flying
        edges chamfers sharp edges and corners, so for a ``"dual_contouring"`` surface of a CSG
        part ``hausdorff`` is dominated by the reference's own error there (about a cell at a
        corner); ``max_sdf_error`` measures the surface itself.
    reference : pyvista.PolyData, optional
        Surface to measure the two-sided Hausdorff distance to.
    spacing : float, optional
        Unit of the sdf errors (default: the grid spacing stored on the surface).
    merge_coincident : bool
        Count the topology with exactly coincident vertices as one vertex, as a reader of the
        written file (STL) sees it (default); False counts the vertex ids as given.

    Examples
    --------
    >>> import fepre
    >>> from fepre import sdf
    >>> ball = sdf.sphere(1.0)
    >>> check = fepre.check_surface(fepre.isosurface(ball, spacing=0.1), ball)
    >>> check.watertight, check.euler_characteristic, check.max_sdf_error < 0.1
    (True, 2, True)
    """
    from .weld import weld

    original_points, original_faces = _triangles(surface)
    # topology as a reader of the written file sees it: coincident vertices are one vertex
    if not isinstance(merge_coincident, bool):
        raise TypeError(f"merge_coincident must be True or False; got {merge_coincident!r}")
    welded_points, welded_faces = weld(original_points, original_faces) if merge_coincident else (original_points, original_faces)
    topology = _topology(welded_points, welded_faces)
    used, labels = topology.used, topology.labels
    points, faces = original_points, original_faces
    area, volume, angles, degenerate = _geometry(points, faces)

    unit = None
    if spacing is not None:
        from ..arguments import positive_float

        unit = positive_float(spacing, "spacing")
    elif "surface_spacing" in surface.field_data:
        unit = float(np.max(surface.field_data["surface_spacing"]))
    max_error = mean_error = None
    if model is not None and used.size:
        error = np.abs(model(points[_distinct(faces.reshape(-1))])) / (unit if unit else 1.0)
        max_error, mean_error = float(error.max()), float(error.mean())
    method = str(np.asarray(surface.field_data["surface_method"])[0]) if "surface_method" in surface.field_data else ""
    if reference is None and model is not None and "surface_grid_dimensions" in surface.field_data and method != "flying_edges":
        # the default reference is flying edges on the same grid (for flying edges it would be
        # the surface itself)
        reference = _flying_edges_reference(surface, model)
    hausdorff = None
    if reference is not None and faces.size and reference.n_cells:
        hausdorff = _hausdorff(surface, reference)

    thin_components = None
    if unit is not None and used.size:
        thin_components = _thin_components(welded_points, welded_faces, labels, unit)

    return SurfaceCheck(
        points=int(used.size),
        triangles=int(faces.shape[0]),
        watertight=topology.watertight,
        manifold=topology.manifold,
        oriented=topology.oriented,
        components=topology.components,
        euler_characteristic=topology.euler,
        genus=topology.genus,
        area=area,
        volume=volume,
        max_sdf_error=max_error,
        mean_sdf_error=mean_error,
        error_unit=unit if model is not None else None,
        hausdorff=hausdorff,
        min_angle=float(angles.min()) if angles.size else 0.0,
        degenerate_triangles=degenerate,
        thin_components=thin_components,
    )


def _thin_components(points: np.ndarray, faces: np.ndarray, labels: np.ndarray, spacing: float) -> int:
    """Number of components thinner than ``spacing``: enclosed volume over area under half of it
    (a plate t thick has t/2, a ball of radius r has r/3)."""
    label = labels[faces[:, 0]]
    p = points[faces]
    cross = np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0])
    area = np.bincount(label, weights=np.linalg.norm(cross, axis=1) / 2)
    volume = np.abs(np.bincount(label, weights=np.einsum("ij,ij->i", p[:, 0], cross) / 6))
    present = area > 0
    return int(np.count_nonzero(present & (volume <= 0.5 * spacing * area)))
