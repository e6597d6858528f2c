"""Closed cavities of a mesh the model does not have.

A mesh's boundary may hold closed inner surfaces: the walls of a void. A hollow part has them
where its model does; a new user's SolidWorks STL (trimesh's ``ADIS16480.STL``) at D/50 had two
more, each the four faces of one missing cell 0.2 h inside the material, and nothing said so
(its exported ``boundary`` set held their faces too). :func:`unmodelled_cavities` finds the
inner boundary pieces (faces joined through edges whose enclosed volume is negative: they face
into the void) whose middle the model puts inside the part, and most of whose faces (by area)
have the model's material just beyond them, in the void. :func:`sealed_pockets` finds the
other kind: voids of the model's outside that the mesh closed over (two cubes sharing an edge:
a cell missing in the wedge beside it), whose middle a ray joins to the outside of the part.
"""

from __future__ import annotations

import numpy as np

__all__ = ["inner_voids", "unmodelled_cavities", "sealed_pockets", "cavities_message", "pockets_message", "CAVITY_DEPTH"]

#: a cavity counts when the model's value at its middle is below this many h (inside material)
CAVITY_DEPTH = 0.05


def unmodelled_cavities(points: np.ndarray, faces: np.ndarray, model, h: float,
                        voids: list | None = None) -> list[tuple[np.ndarray, int, float]]:
    """The cavities of a mesh whose boundary faces (outward, (F, 3)) are ``faces`` where
    ``model`` is material: each as (middle, faces, volume). ``voids``: :func:`inner_voids` of
    the mesh, when already found.

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
    found = []
    for chosen, middle, volume, probes, areas in inner_voids(points, faces, h) if voids is None else voids:
        if float(np.asarray(model(middle[None]), dtype=float)[0]) >= -CAVITY_DEPTH * h:
            continue
        inside = np.asarray(model(probes), dtype=float) < 0
        if areas[inside].sum() > 0.5 * areas.sum():
            found.append((middle, int(chosen.sum()), volume))
    return found


def sealed_pockets(points: np.ndarray, faces: np.ndarray, model, h: float, lower, upper,
                   voids: list | None = None) -> list[tuple[np.ndarray, int, float]]:
    """The cavities of a mesh (boundary faces ``faces``) that hold the model's outside: their
    middle is outside the model, and a ray from it reaches past the box ``lower``-``upper``
    through the model's outside (:func:`_reaches_out`), so the model has no void there. Each as
    (middle, faces, volume). Two cubes sharing an edge at h = 0.2 (a new user's) held one, the
    four faces of a cell missing in the wedge beside the edge, and nothing said so; a hollow
    part's own void is not one (its rays all end in material). ``voids``: :func:`inner_voids` of
    the mesh, when already found.

    Examples
    --------
    >>> import numpy as np, fepre
    >>> from fepre import sdf
    >>> from fepre.distmesh.topology import boundary_faces
    >>> shell = sdf.box(2.0) - sdf.box(1.0)                         # a void of its own
    >>> mesh = fepre.distmesh(shell, 0.25)
    >>> faces = boundary_faces(np.asarray(mesh.cells_dict[10]))
    >>> sealed_pockets(np.asarray(mesh.points), faces, shell, 0.25, (-1, -1, -1), (1, 1, 1))
    []
    """
    found = []
    for chosen, middle, volume, probes, areas in inner_voids(points, faces, h) if voids is None else voids:
        if float(np.asarray(model(middle[None]), dtype=float)[0]) <= CAVITY_DEPTH * h:
            continue
        outside = np.asarray(model(probes), dtype=float) > 0
        if areas[outside].sum() > 0.5 * areas.sum() and _reaches_out(model, middle, lower, upper, h):
            found.append((middle, int(chosen.sum()), volume))
    return found


#: directions of the rays from a pocket's middle: the axes and the cube's diagonals
_RAYS = np.concatenate([np.eye(3), -np.eye(3), np.array([[x, y, z] for x in (-1, 1) for y in (-1, 1) for z in (-1, 1)])
                        / np.sqrt(3.0)])
#: steps of a ray through the model's outside, each as long as the distance to the surface
RAY_STEPS = 256


def _reaches_out(model, start: np.ndarray, lower, upper, h: float) -> bool:
    """True when a ray from ``start`` along one of ``_RAYS`` leaves the box ``lower``-``upper``
    (grown by h) without entering the model: sphere tracing, a step of the distance at a time."""
    lower, upper = np.asarray(lower, float) - h, np.asarray(upper, float) + h
    at = np.repeat(np.asarray(start, float)[None], len(_RAYS), axis=0)
    going = np.ones(len(_RAYS), dtype=bool)
    for _ in range(RAY_STEPS):
        distance = np.asarray(model(at[going]), dtype=float)
        stopped = distance <= 1e-3 * h
        index = np.flatnonzero(going)
        going[index[stopped]] = False
        index = index[~stopped]
        at[index] += _RAYS[index] * distance[~stopped, None]
        if ((at[index] < lower) | (at[index] > upper)).any():
            return True
        if not going.any():
            return False
    return False


def inner_voids(points: np.ndarray, faces: np.ndarray, h: float) -> list[tuple]:
    """The closed inner pieces of a mesh's boundary (faces joined through edges, enclosing a
    negative volume: they face into a void): for each, a mask of its faces, its middle, its
    volume, a probe a little into the void from each face and the faces' areas."""
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
    voids = []
    # a flat void (a co-planar cell's four faces) encloses a rounding error of either sign
    for label in np.flatnonzero(enclosed < 1e-12 * h**3):
        chosen = labels == label
        voids.append((chosen, corners[chosen].reshape(-1, 3).mean(axis=0), float(-enclosed[label]), probes[chosen],
                      areas[chosen]))
    return voids


def _listed(found: list, offset) -> str:
    """The first three voids of ``found`` (middle, faces, volume), their middles moved by
    ``offset``, and how many more."""
    offset = np.zeros(3) if offset is None else np.asarray(offset, dtype=float)
    shown = "; ".join(f"{faces} faces, volume {volume:.3g}, near ({', '.join(f'{c:.4g}' for c in middle + offset)})"
                      for middle, faces, volume in found[:3])
    return shown + (f" and {len(found) - 3} more" if len(found) > 3 else "")


def cavities_message(found: list, offset=None) -> str | None:
    """One line naming the cavities (most three), or None when there are none."""
    if not found:
        return None
    return (f"the mesh has {len(found)} closed cavit{'y' if len(found) == 1 else 'ies'} where the model is material "
            f"({_listed(found, offset)}): missing cells, whose faces are on the mesh's boundary (and in its boundary "
            "sets); a smaller h usually closes them")


def pockets_message(found: list, offset=None) -> str | None:
    """One line naming the pockets of the model's outside the mesh sealed (most three), or None."""
    if not found:
        return None
    return (f"the mesh encloses {len(found)} void{'' if len(found) == 1 else 's'} of the model's outside "
            f"({_listed(found, offset)}), sealed off where its surfaces come closer than the elements (parts "
            "touching along an edge or at a point, a narrow gap): an inner surface on the mesh's boundary (and in "
            "its boundary sets) that the model does not have")
