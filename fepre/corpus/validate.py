"""An independent check of a tetrahedral mesh against its model, for the corpus.

Nothing here calls fepre's own quality, topology or meshing code: volumes, dihedral angles and
radius ratios are computed from the corner coordinates with their textbook formulas, conformity
and the boundary's manifoldness from sorted face and edge keys, components with scipy's graph
labelling, and the model's volume by Monte Carlo sampling of its sign. The model itself is the
only thing shared with the mesher (it is the truth being meshed).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

__all__ = ["MeshCheck", "check_mesh", "monte_carlo_volume", "cell_measures"]

_FACES = np.array([[1, 2, 3], [0, 3, 2], [0, 1, 3], [0, 2, 1]])
_EDGES = np.array([[0, 1], [0, 2], [0, 3], [1, 2], [1, 3], [2, 3]])


def cell_measures(points: np.ndarray, tets: np.ndarray) -> dict[str, np.ndarray]:
    """Signed volume, smallest and largest dihedral angle (degrees) and radius ratio
    ``3 r_in / R_circ`` of each tetrahedron.

    Examples
    --------
    >>> corners = np.array([[1, 1, 1], [1, -1, -1], [-1, 1, -1], [-1, -1, 1]], float)
    >>> m = cell_measures(corners, np.array([[0, 1, 2, 3]]))
    >>> round(float(m["min_dihedral"][0]), 4), round(float(m["radius_ratio"][0]), 6)
    (70.5288, 1.0)
    """
    p = np.asarray(points, np.float64)[np.asarray(tets)]
    a, b, c, d = p[:, 0], p[:, 1], p[:, 2], p[:, 3]
    volume = np.einsum("ij,ij->i", b - a, np.cross(c - a, d - a)) / 6.0
    # outward-ish face normals (area vectors) for the face opposite each corner
    normals = []
    for opposite in _FACES:
        u, v, w = (p[:, k] for k in opposite)
        normals.append(np.cross(v - u, w - u))
    normals = np.stack(normals, axis=1)  # (M, 4, 3)
    areas = np.linalg.norm(normals, axis=2)
    unit = normals / np.maximum(areas, 1e-300)[..., None]
    # the dihedral angle at the edge shared by faces i and j is pi minus the angle of their normals
    angles = []
    for i in range(4):
        for j in range(i + 1, 4):
            cosine = np.clip(np.einsum("ij,ij->i", unit[:, i], unit[:, j]), -1.0, 1.0)
            angles.append(180.0 - np.degrees(np.arccos(cosine)))
    angles = np.stack(angles, axis=1)
    # inradius 3V / total area; circumradius from the standard determinant formula
    inradius = 3.0 * np.abs(volume) / np.maximum(0.5 * areas.sum(axis=1), 1e-300)  # areas: twice each face
    ba, ca, da = b - a, c - a, d - a
    numerator = (
        np.einsum("ij,ij->i", ba, ba)[:, None] * np.cross(ca, da)
        + np.einsum("ij,ij->i", ca, ca)[:, None] * np.cross(da, ba)
        + np.einsum("ij,ij->i", da, da)[:, None] * np.cross(ba, ca)
    )
    circumradius = np.linalg.norm(numerator, axis=1) / np.maximum(12.0 * np.abs(volume), 1e-300)
    ratio = np.where(np.abs(volume) > 0, 3.0 * inradius / np.maximum(circumradius, 1e-300), 0.0)
    return {"volume": volume, "min_dihedral": angles.min(axis=1), "max_dihedral": angles.max(axis=1), "radius_ratio": ratio}


def monte_carlo_volume(model, lower, upper, samples: int = 400_000, seed: int = 0) -> tuple[float, float]:
    """Volume of ``{model < 0}`` inside the box and its standard error, from uniform samples.

    Examples
    --------
    >>> from fepre import sdf
    >>> volume, error = monte_carlo_volume(sdf.sphere(1.0), (-1, -1, -1), (1, 1, 1), 200_000)
    >>> bool(abs(volume - 4.18879) < 4 * error)
    True
    """
    lower, upper = np.asarray(lower, float), np.asarray(upper, float)
    rng = np.random.default_rng(seed)
    box = float(np.prod(upper - lower))
    inside = 0
    done = 0
    while done < samples:
        count = min(200_000, samples - done)
        points = lower + rng.random((count, 3)) * (upper - lower)
        inside += int(np.count_nonzero(model(points) < 0))
        done += count
    fraction = inside / samples
    return box * fraction, box * np.sqrt(max(fraction * (1 - fraction), 1e-12) / samples)


def _fans(faces: np.ndarray) -> int:
    """Number of fans of faces around the vertices of a surface (one per vertex when no vertex is
    pinched): (vertex, face) incidences joined across the edges they share."""
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import connected_components

    count = len(faces)
    local = np.array([[0, 1], [1, 2], [2, 0]])
    vertices = faces[:, local].reshape(-1, 2)
    incidence = (3 * np.arange(count)[:, None, None] + local[None]).reshape(-1, 2)
    swap = vertices[:, 0] > vertices[:, 1]
    vertices[swap] = vertices[swap][:, ::-1]
    incidence[swap] = incidence[swap][:, ::-1]
    order = np.lexsort((vertices[:, 1], vertices[:, 0]))
    vertices, incidence = vertices[order], incidence[order]
    same = (vertices[1:] == vertices[:-1]).all(axis=1)
    first, second = incidence[:-1][same], incidence[1:][same]
    rows = np.concatenate([first[:, 0], first[:, 1]])
    cols = np.concatenate([second[:, 0], second[:, 1]])
    graph = coo_matrix((np.ones(rows.size), (rows, cols)), shape=(3 * count, 3 * count))
    return int(connected_components(graph, directed=False)[0])


@dataclass
class MeshCheck:
    """What :func:`check_mesh` found. ``problems`` is empty for a valid mesh."""

    cells: int
    min_dihedral: float
    max_dihedral: float
    min_radius_ratio: float
    volume: float
    components: int
    boundary_distance: float  # largest |model| at a boundary node, in units of h
    problems: list[str] = field(default_factory=list)

    @property
    def valid(self) -> bool:
        return not self.problems


def check_mesh(points: np.ndarray, tets: np.ndarray, model, h: float) -> MeshCheck:
    """Validity and shape of a tetrahedral mesh of ``model`` at size ``h``.

    Valid means: every cell has positive volume, every face is shared by at most two cells, the
    boundary faces form a closed 2-manifold (every boundary edge in exactly two boundary faces,
    the faces around every boundary vertex one fan), and every boundary node lies on the model's
    zero set to ``1e-3 h``.
    """
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import connected_components

    points = np.asarray(points, np.float64)
    tets = np.asarray(tets, np.int64)
    problems: list[str] = []
    measures = cell_measures(points, tets)
    if measures["volume"].min() <= 0:
        problems.append(f"{int((measures['volume'] <= 0).sum())} cells of zero or negative volume")
    faces = np.sort(tets[:, _FACES].reshape(-1, 3), axis=1)
    unique, inverse, counts = np.unique(faces, axis=0, return_inverse=True, return_counts=True)
    inverse = inverse.ravel()
    if counts.max() > 2:
        problems.append(f"{int((counts > 2).sum())} faces shared by more than two cells")
    boundary = unique[counts == 1]
    edges = np.sort(boundary[:, [[0, 1], [1, 2], [0, 2]]].reshape(-1, 2), axis=1)
    _, edge_counts = np.unique(edges, axis=0, return_counts=True)
    if edge_counts.size and (edge_counts != 2).any():
        problems.append(f"{int((edge_counts != 2).sum())} boundary edges not in exactly two boundary faces")
    if len(boundary):
        pinched = _fans(boundary) - np.unique(boundary).size
        if pinched:
            problems.append(f"{pinched} extra fans at pinched boundary vertices")
    nodes = np.unique(boundary)
    distance = float(np.abs(model(points[nodes])).max() / h) if nodes.size else 0.0
    if distance > 1e-3:
        problems.append(f"a boundary node is {distance:.3g} h from the zero set")
    # components: cells joined through shared faces
    cell_of_face = np.repeat(np.arange(len(tets)), 4)
    order = np.argsort(inverse, kind="stable")
    shared = inverse[order][1:] == inverse[order][:-1]
    first, second = cell_of_face[order][:-1][shared], cell_of_face[order][1:][shared]
    graph = coo_matrix((np.ones(first.size), (first, second)), shape=(len(tets), len(tets)))
    components = int(connected_components(graph, directed=False)[0]) if len(tets) else 0
    return MeshCheck(
        cells=len(tets),
        min_dihedral=float(measures["min_dihedral"].min()),
        max_dihedral=float(measures["max_dihedral"].max()),
        min_radius_ratio=float(measures["radius_ratio"].min()),
        volume=float(measures["volume"].sum()),
        components=components,
        boundary_distance=distance,
        problems=problems,
    )
