"""Closed cavities inside a mesh where its model is material.

A mesh's boundary may hold closed inner surfaces: the walls of a void. A hollow part has them
where its model does; a new user's SolidWorks STL (trimesh's ``ADIS16480.STL``) at D/50 had two
more, each the four faces of one missing cell 0.2 h inside the material, and nothing said so
(its exported ``boundary`` set held their faces too). :func:`unmodelled_cavities` finds the
inner boundary pieces (faces joined through edges whose enclosed volume is negative: they face
into the void) whose middle the model puts inside the part, and most of whose faces (by area)
have the model's material just beyond them, in the void.
"""

from __future__ import annotations

import numpy as np

__all__ = ["unmodelled_cavities", "cavities_message", "CAVITY_DEPTH"]

#: a cavity counts when the model's value at its middle is below this many h (inside material)
CAVITY_DEPTH = 0.05


def unmodelled_cavities(points: np.ndarray, faces: np.ndarray, model, h: float) -> list[tuple[np.ndarray, int, float]]:
    """The cavities of a mesh whose boundary faces (outward, (F, 3)) are ``faces`` where
    ``model`` is material: each as (middle, faces, volume).

    Examples
    --------
    >>> import numpy as np, fepre
    >>> from fepre import sdf
    >>> from fepre.distmesh.topology import boundary_faces
    >>> cube = fepre.distmesh(sdf.box(2.0), 0.5)
    >>> points, tets = np.asarray(cube.points), cube.cells_dict[10]
    >>> inner = int(np.argmin(np.abs(points[tets].mean(axis=1)).max(axis=1)))   # a cell at the middle
    >>> found = unmodelled_cavities(points, boundary_faces(np.delete(tets, inner, axis=0)), sdf.box(2.0), 0.5)
    >>> len(found), found[0][1]
    (1, 4)
    """
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import connected_components

    if len(faces) == 0:
        return []
    edges = np.sort(np.concatenate([faces[:, [0, 1]], faces[:, [1, 2]], faces[:, [2, 0]]]), axis=1)
    _, key = np.unique(edges, axis=0, return_inverse=True)
    key = key.ravel()
    owner = np.tile(np.arange(len(faces)), 3)
    order = np.argsort(key, kind="stable")
    same = np.flatnonzero(key[order[1:]] == key[order[:-1]])
    n = len(faces)
    graph = coo_matrix((np.ones(len(same)), (owner[order[same]], owner[order[same + 1]])), shape=(n, n))
    count, labels = connected_components(graph, directed=False)
    if count < 2:
        return []
    corners = points[faces]
    signed = np.einsum("ij,ij->i", corners[:, 0], np.cross(corners[:, 1], corners[:, 2])) / 6.0
    enclosed = np.bincount(labels, weights=signed, minlength=count)
    # a probe a little into the void from each face (the faces' normals point out of the mesh):
    # a void the model has is outside it there, whatever its middle (a gyroid's labyrinth closed
    # in a shell has its middle in the material)
    normals = np.cross(corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0])
    areas = np.linalg.norm(normals, axis=1)
    probes = corners.mean(axis=1) + CAVITY_DEPTH * h * normals / np.maximum(areas, 1e-300)[:, None]
    found = []
    for label in np.flatnonzero(enclosed < 0):
        chosen = labels == label
        middle = corners[chosen].reshape(-1, 3).mean(axis=0)
        if float(np.asarray(model(middle[None]), dtype=float)[0]) >= -CAVITY_DEPTH * h:
            continue
        inside = np.asarray(model(probes[chosen]), dtype=float) < 0
        if areas[chosen][inside].sum() > 0.5 * areas[chosen].sum():
            found.append((middle, int(chosen.sum()), float(-enclosed[label])))
    return found


def cavities_message(found: list, offset=None) -> str | None:
    """One line naming the cavities (most three), or None when there are none."""
    if not found:
        return None
    offset = np.zeros(3) if offset is None else np.asarray(offset, dtype=float)
    shown = "; ".join(f"{faces} faces, volume {volume:.3g}, near ({', '.join(f'{c:.4g}' for c in middle + offset)})"
                      for middle, faces, volume in found[:3])
    more = f" and {len(found) - 3} more" if len(found) > 3 else ""
    return (f"the mesh has {len(found)} closed cavit{'y' if len(found) == 1 else 'ies'} where the model is material "
            f"({shown}{more}): missing cells, whose faces are on the mesh's boundary (and in its boundary sets); "
            "a smaller h usually closes them")
