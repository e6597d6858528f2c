"""fepre.improve: the quality stage on a whole mesh, from this or another mesher.

It finds the nodes to keep in place (sharp edges and corners of the model), puts those that
another mesher left off the model back on it (:mod:`~fepre.distmesh.feature_snap`), runs
:func:`~fepre.distmesh.slivers.improve_arrays` and returns a new grid with fepre's arrays.
"""

from __future__ import annotations

import numpy as np

from .._cell_kernels import corner_volumes
from .feature_snap import snap_pinned_nodes
from .slivers import DEFAULT_MAX_DIHEDRAL, DEFAULT_MAXITER, DEFAULT_MIN_DIHEDRAL, DEFAULT_MIN_RADIUS_RATIO, improve_arrays

__all__ = ["improve", "stage_pins"]


def stage_pins(points: np.ndarray, tets: np.ndarray, fixed_mask: np.ndarray, user_fixed, model, h: float) -> np.ndarray:
    """The nodes the quality stage keeps in place after DistMesh, (N,) bool.

    The user's fixed points, the fixed nodes (feature corners and curve nodes) on the mesh's
    boundary, and the boundary nodes on a crease (:func:`~fepre.distmesh.finalize.crease_nodes`):
    sliding those along the surface and projecting them back would round the part's creases
    off. A feature node that the final mesh left inside (cells on both sides of it, as at the
    tip of a thin void) shapes no crease; pinned, it froze its cells (gyroid infill at 1.04M
    cells: worst dihedral angle 8.3 deg, 30.0 with it released).

    Parameters
    ----------
    points, tets : the mesh
    fixed_mask : (N,) bool, the loop's fixed nodes (the user's and the feature nodes)
    user_fixed : (K, 3) array or None, the points the user asked to keep
    model : fepre.sdf.SDF
    h : float
    """
    from scipy.spatial import cKDTree

    from .finalize import crease_nodes
    from .tet_topology import face_neighbours, faces_on_boundary

    on_boundary = np.zeros(points.shape[0], dtype=bool)
    on_boundary[faces_on_boundary(tets, face_neighbours(tets, points.shape[0])).ravel()] = True
    pinned = (fixed_mask & on_boundary) | crease_nodes(model, points, tets, h)
    if user_fixed is not None and len(user_fixed):
        distance, index = cKDTree(points).query(np.asarray(user_fixed, dtype=np.float64))
        pinned[index[distance <= 1e-9 * h]] = True
    return pinned


def improve(
    mesh,
    model,
    *,
    min_dihedral: float = DEFAULT_MIN_DIHEDRAL,
    max_dihedral: float = DEFAULT_MAX_DIHEDRAL,
    min_radius_ratio: float = DEFAULT_MIN_RADIUS_RATIO,
    maxiter: int = DEFAULT_MAXITER,
    seed: int = 0,
    features: bool = True,
):
    """Remove slivers and improve the cell shapes of a tetrahedral mesh of ``model``.

    Boundary nodes on the model's sharp edges and corners stay where they are, so the stage
    never rounds them off: nodes on a crease of the mesh's boundary (the model's gradient
    differs across it) and, with ``features``, nodes on the features :func:`fepre.features`
    finds for the mesh's median edge length. Those that another mesher left off the model
    (more than ``1e-4 h``) are first moved onto the nearest feature within ``h/4``, or else
    onto the zero set (:func:`~fepre.distmesh.feature_snap.snap_pinned_nodes`).

    Parameters
    ----------
    mesh : pyvista.UnstructuredGrid
        A purely tetrahedral mesh (VTK_TETRA cells; negatively oriented cells are reoriented),
        whose boundary nodes lie on the zero set of ``model`` (within half an edge length).
    model : fepre.sdf.SDF
        The model of the mesh; boundary nodes stay on its zero set (within ``1e-3 h``).
    min_dihedral, max_dihedral : float
        Targets for every cell's smallest and largest dihedral angle, degrees.
    min_radius_ratio : float
        Target for every cell's radius ratio ``3 r_in / R_circ``. Unreachable targets warn
        with :class:`fepre.ConvergenceWarning` and return the best mesh reached.
    maxiter : int
        Largest number of flip-and-smooth rounds.
    seed : int
        Seed of the random candidate moves.
    features : bool
        Also pin the nodes that lie on the model's detected features (within ``1e-6 h``).

    Returns
    -------
    pyvista.UnstructuredGrid
        A new mesh with point data ``"sdf"``, ``"boundary"`` and ``"feature"``, the cell quality arrays of
        :mod:`fepre.quality`, and field data ``improve_*`` (seconds, counts, worst angles,
        ``pinned`` and ``snapped`` nodes).

    Examples
    --------
    >>> import fepre
    >>> from fepre import sdf
    >>> ball = sdf.sphere(1.0)
    >>> raw = fepre.distmesh(ball, h=0.3, slivers=False)
    >>> better = fepre.improve(raw, ball)
    >>> bool(better.cell_data["min_dihedral_angle"].min() >= 20)
    True
    """
    import pyvista as pv

    from .output import to_grid

    if not isinstance(mesh, pv.UnstructuredGrid):
        raise TypeError(f"mesh must be a pyvista.UnstructuredGrid of tetrahedra; got {type(mesh).__name__}")
    if mesh.n_cells == 0:
        raise ValueError("mesh must contain tetrahedra; got an empty mesh")
    types = np.unique(np.asarray(mesh.celltypes))
    if not np.array_equal(types, [pv.CellType.TETRA]):
        names = ", ".join(pv.CellType(int(t)).name for t in types)
        raise ValueError(f"mesh must be purely tetrahedral (VTK_TETRA cells only); got cell types {names}")
    points = np.asarray(mesh.points, dtype=np.float64)
    tets = np.asarray(mesh.cells_dict[pv.CellType.TETRA], dtype=np.int64).copy()
    used = np.zeros(points.shape[0], dtype=bool)
    used[tets.ravel()] = True
    if not used.all():
        new_index = np.cumsum(used) - 1
        points, tets = points[used], new_index[tets]
    negative = corner_volumes(points, tets) < 0
    tets[negative] = tets[negative][:, [0, 2, 1, 3]]
    edges = points[tets[:, [0, 0, 0, 1, 1, 2]]] - points[tets[:, [1, 2, 3, 2, 3, 3]]]
    h = float(np.median(np.linalg.norm(edges, axis=2)))
    if not h > 0:
        raise ValueError("mesh must have cells of positive size; all its edges have zero length")
    if not isinstance(features, (bool, np.bool_)):
        raise TypeError(f"features must be True or False; got {features!r}")
    from ..placement import local_offset
    from .finalize import crease_nodes

    # a mesh far from the origin is improved near it and moved back (fepre.placement)
    offset = local_offset(points.min(axis=0), points.max(axis=0))
    given = points
    if offset.any():
        points, model = points - offset, model.translate(-offset)
    local = points

    pinned = crease_nodes(model, points, tets, h)
    found = None
    if features:
        from ..features import features as detect_features

        bounds = model.bounds if model.bounds is not None else (points.min(axis=0), points.max(axis=0))
        found = detect_features(model, h, bounds=bounds, warn=False)
        if found:
            pinned |= found.distance(points)[0] <= 1e-6 * h
    points, snapped = snap_pinned_nodes(model, points, tets, pinned, found, h)
    new_points, new_tets, info = improve_arrays(
        points, tets, model, h, fixed_mask=pinned, min_dihedral=min_dihedral, max_dihedral=max_dihedral,
        min_radius_ratio=min_radius_ratio, maxiter=maxiter, seed=seed,
    )
    info["pinned"] = int(pinned.sum())
    info["snapped"] = snapped
    grid = to_grid(new_points, new_tets, model, {}, found)
    if offset.any():
        moved = np.asarray(grid.points) + offset
        if len(new_points) == len(local):  # the nodes that stayed keep their coordinates bit for bit
            stayed = (new_points == local).all(axis=1)
            moved[stayed] = given[stayed]
        grid.points = moved
    for key, value in info.items():
        grid.field_data[f"improve_{key}"] = np.array([value])
    return grid
