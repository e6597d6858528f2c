"""Cells short of the quality targets that sit where the part is about one element thick.

Where a limb, a fin or a fold is less than about one and a half elements thick, the mesh holds it
with a single layer of cells whose four nodes all lie on its surface, and the quality stage
has no interior node to move: such cells are flat caps and wedges (a regular tetrahedron
standing on an edge is ``0.71 h`` high, so below about ``0.7 h`` no well-shaped cell of size
``h`` fits at all). On public graphics models meshed at D/50 (odedstein/meshes' scorpion,
springer, plane, human_woman), nearly all the cells left below the targets are of this kind, and
the graded mesh with two elements across those parts meets the targets. :func:`thin_bad_cells`
measures the part's thickness at each cell below the targets and :func:`thin_cells_message`
names the places and the ``h`` that resolves them, so the user is told why the cells are bad
and what to do, not only that the stage fell short.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

__all__ = ["ThinCells", "thin_bad_cells", "thin_cells_message", "combined", "cell_thickness", "chord_thickness", "sizes_at",
           "THIN_SHARE"]

#: a cell is in a thin part where the part there is thinner than this times the local element
#: size (fewer than two elements across)
THIN_SHARE = 1.5
#: cells within this many local sizes of each other are one place
_PLACE = 2.0


@dataclass(frozen=True)
class ThinCells:
    """The cells below the quality targets and which of them lie in parts too thin for them.

    Attributes
    ----------
    bad : int
        Cells below the targets.
    centres : (K, 3) ndarray
        A point inside each bad cell in a thin part: the deepest of its centroid, face centres
        and edge midpoints.
    thickness : (K,) ndarray
        The part's thickness through each of them.
    size : (K,) ndarray
        The element size wanted there.
    """

    bad: int
    centres: np.ndarray
    thickness: np.ndarray
    size: np.ndarray


def _unit_gradient(model, points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    gradient = np.asarray(model.gradient(points), dtype=float)
    norm = np.linalg.norm(gradient, axis=1)
    return gradient / np.where(norm > 0, norm, 1.0)[:, None], norm > 0


#: the 13 directions through a centroid besides the gradient (cube faces, edges and corners)
_AXES = np.array([[1, 0, 0], [0, 1, 0], [0, 0, 1], [1, 1, 0], [1, -1, 0], [1, 0, 1], [1, 0, -1], [0, 1, 1], [0, 1, -1],
                  [1, 1, 1], [1, 1, -1], [1, -1, 1], [-1, 1, 1]], dtype=float)
_AXES /= np.linalg.norm(_AXES, axis=1)[:, None]
_FACES = np.array([[1, 2, 3], [0, 2, 3], [0, 1, 3], [0, 1, 2]])
_EDGES = np.array([[0, 1], [0, 2], [0, 3], [1, 2], [1, 3], [2, 3]])


def _deepest_samples(model, corners: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """For (K, 4, 3) cells, the deepest of each one's centroid, face centres and edge midpoints
    and its depth (negative where all lie outside the model: a flat cell lying on the surface
    may have its centroid just outside)."""
    samples = np.concatenate([corners.mean(axis=1)[:, None], corners[:, _FACES].mean(axis=2), corners[:, _EDGES].mean(axis=2)], axis=1)
    depth = -np.asarray(model(samples.reshape(-1, 3)), dtype=float).reshape(len(corners), -1)
    deepest = depth.argmax(axis=1)
    return samples[np.arange(len(corners)), deepest], depth[np.arange(len(corners)), deepest]


def chord_thickness(model, origins: np.ndarray, depth: np.ndarray, limit: float, step: float) -> np.ndarray:
    """The part's thickness through ``origins`` inside it (``depth`` deep): the shortest chord
    through each along the model's gradient and 13 fixed directions (within 27.6 degrees of any
    direction: at most 13% over a slab's thickness), or twice the depth if larger (off a rod's
    axis the shortest chord is shorter than the rod); ``inf`` past ``limit``, rays stepped at
    least ``step``.

    Examples
    --------
    >>> from fepre import sdf
    >>> slab = sdf.box((10.0, 10.0, 0.8))
    >>> near_face = np.array([[0.3, 0.2, 0.32]])              # 0.08 deep in a 0.8 slab
    >>> round(float(chord_thickness(slab, near_face, np.array([0.08]), 4.0, 0.01)[0]), 3)
    0.8
    """
    from ..sizing.rays import ray_lengths

    gradient, usable = _unit_gradient(model, origins)
    directions = np.concatenate([np.where(usable[:, None], gradient, _AXES[0])[:, None],
                                 np.broadcast_to(_AXES, (len(origins), 13, 3))], axis=1)
    starts = np.repeat(origins, 14, axis=0)
    directions = directions.reshape(-1, 3)
    chords = (ray_lengths(model, starts, directions, True, limit, step)
              + ray_lengths(model, starts, -directions, True, limit, step))
    return np.maximum(chords.reshape(-1, 14).min(axis=1), 2.0 * depth)


def _thickness(model, points: np.ndarray, tets: np.ndarray, cells: np.ndarray, origins: np.ndarray, depth: np.ndarray,
               size: np.ndarray) -> np.ndarray:
    """The part's thickness at ``cells``, from ``origins`` inside them (their deepest samples,
    ``depth`` deep): the shortest chord through the origin along the model's gradient and 13
    fixed directions (within 27.6 degrees of any direction: at most 13% over a slab's
    thickness), or twice the depth if larger (off a rod's axis the shortest chord is shorter
    than the rod), or the median over the cell's nodes of the ray from each node against the
    gradient (a node's wall) if smaller; ``inf`` past ``2 size``."""
    from ..sizing.rays import ray_lengths

    limit, step = 2.0 * float(size.max()), float(size.min()) / 64.0
    through = chord_thickness(model, origins, depth, limit, step)
    nodes, corner = np.unique(tets[cells], return_inverse=True)
    direction, usable = _unit_gradient(model, points[nodes])
    wall = np.where(usable, ray_lengths(model, points[nodes], -direction, True, limit, step), np.inf)
    wall = np.where(wall > 0, wall, np.inf)  # a node on an edge whose ray leaves at once
    return np.minimum(through, np.median(wall[corner.reshape(-1, 4)], axis=1))


def sizes_at(points: np.ndarray, h: float, local_size=None) -> np.ndarray:
    """The element size wanted at ``points``: ``h``, or the graded mesh's ``local_size``."""
    return np.full(len(points), float(h)) if local_size is None else np.asarray(local_size(points), dtype=float).ravel()


def cell_thickness(model, points: np.ndarray, tets: np.ndarray, cells: np.ndarray, size: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The part's thickness at ``cells`` (rows of ``tets``) where ``size`` is the element size
    wanted there (``inf`` past twice it), and a point inside each cell it is measured from (the
    deepest of its centroid, face centres and edge midpoints). A cell with all of those outside
    the model (flat on its surface) has thickness 0."""
    cells = np.asarray(cells, dtype=np.int64)
    origins, depth = _deepest_samples(model, points[tets[cells]])
    thickness = np.zeros(len(cells))
    inside = depth > 0
    if inside.any():
        thickness[inside] = _thickness(model, points, tets, cells[inside], origins[inside], depth[inside], size[inside])
    return thickness, origins


def thin_bad_cells(model, points: np.ndarray, tets: np.ndarray, h: float, local_size=None, targets=None) -> ThinCells:
    """The cells below the quality targets and those of them in parts thinner than ``THIN_SHARE``
    times the local size.

    Parameters
    ----------
    model : fepre.sdf.SDF
    points, tets : the mesh, (N, 3) and (M, 4)
    h : float
        The element size (uniform meshes).
    local_size : callable, optional
        The graded mesh's element size at points, in units of length.
    targets : ShapeTargets, optional
        The quality targets (default: the plain-mesh targets).

    Examples
    --------
    >>> import numpy as np
    >>> from fepre import sdf
    >>> slab = sdf.box((4.0, 4.0, 0.2))                      # 0.2 thick
    >>> flat = np.array([[0, 0, -0.1], [1, 0, -0.1], [0.5, 1, 0.1], [0.5, -1, 0.1]])
    >>> found = thin_bad_cells(slab, flat, np.array([[0, 1, 2, 3]]), h=1.0)
    >>> found.bad, round(float(found.thickness[0]), 3)
    (1, 0.2)
    """
    from .tet_shape import ShapeTargets

    targets = ShapeTargets() if targets is None else targets
    score = targets.score(points[tets])
    bad = np.flatnonzero(score < targets.min_dihedral)
    count = int(bad.size)
    empty = ThinCells(count, np.zeros((0, 3)), np.zeros(0), np.zeros(0))
    if not bad.size:
        return empty
    origins, depth = _deepest_samples(model, points[tets[bad]])
    inside = depth > 0
    if not inside.any():
        return empty
    bad, centres, depth = bad[inside], origins[inside], depth[inside]
    size = sizes_at(centres, h, local_size)
    thickness = _thickness(model, points, tets, bad, centres, depth, size)
    thin = thickness < THIN_SHARE * size
    return ThinCells(count, centres[thin], thickness[thin], size[thin])


def combined(parts) -> ThinCells:
    """One :class:`ThinCells` of several meshes' (a region mesh's regions, each measured in its
    own model: a thin sheet of one material inside a thick part is thin for its cells)."""
    parts = list(parts)
    return ThinCells(sum(part.bad for part in parts), np.concatenate([part.centres for part in parts]).reshape(-1, 3),
                     *(np.concatenate([getattr(part, name) for part in parts]) for name in ("thickness", "size")))


def _places(found: ThinCells) -> list[np.ndarray]:
    """The thin bad cells grouped into places (cells within ``_PLACE`` sizes of each other),
    most cells first."""
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import connected_components
    from scipy.spatial import cKDTree

    pairs = cKDTree(found.centres).query_pairs(_PLACE * float(found.size.max()), output_type="ndarray")
    n = len(found.centres)
    graph = coo_matrix((np.ones(len(pairs)), (pairs[:, 0], pairs[:, 1])), shape=(n, n)) if len(pairs) else coo_matrix((n, n))
    labels = connected_components(graph, directed=False)[1]
    groups = [np.flatnonzero(labels == label) for label in np.unique(labels)]
    return sorted(groups, key=lambda group: (-len(group), float(np.median(found.thickness[group]))))


def thin_cells_message(found: ThinCells, h: float | None, offset=None) -> str | None:
    """One line naming where the bad cells in thin parts are, how thick the part is there (the
    median over a place's cells) and the ``h`` that resolves them all (half the thinnest place's
    thickness: two elements across; that place is named too when it is not among the three
    shown), or None when there are none.

    ``h``: the uniform size (None for a graded mesh); ``offset``: added to the places (the
    user's frame).
    """
    if not len(found.centres):
        return None
    offset = np.zeros(3) if offset is None else np.asarray(offset, dtype=float)
    groups = _places(found)
    thick = [float(np.median(found.thickness[group])) for group in groups]

    def place(group: np.ndarray, t: float) -> str:
        return (f"{len(group)} near ({', '.join(f'{c:.4g}' for c in found.centres[group].mean(axis=0) + offset)}), "
                f"{t:.3g} thick against a size of {float(found.size[group].max()):.3g}")

    shown = "; ".join(place(group, t) for group, t in zip(groups[:3], thick))
    more = f" and {len(groups) - 3} more place(s)" if len(groups) > 3 else ""
    thinnest = int(np.argmin(thick))
    if thinnest >= 3:  # the advice must resolve every place, not only those shown
        more += f", the thinnest {place(groups[thinnest], thick[thinnest])}"
    fine = 0.5 * thick[thinnest]
    advice = (f"mesh with h=({fine:.2g}, {h:.4g}) (the automatic size field: that fine only where the model is "
              f"that thin) or h <= {fine:.2g}" if h is not None else f"mesh with a smaller hmin (about {fine:.2g})")
    return (
        f"{len(found.centres)} of the {found.bad} cell(s) short of the quality targets lie where the model is "
        f"less than {THIN_SHARE:g} elements thick, held by one layer of cells with every node on its surface: "
        f"{shown}{more}; "
        f"{advice} to resolve them"
    )
