"""The faces between regions of a tetrahedral mesh, as named face sets (``interface_<a>_<b>``)."""

from __future__ import annotations

import numpy as np

from ..arguments import SET_NAME, check_names
from .boundaries import OPPOSITE_NODE, OUTWARD_FACES, FaceSets

__all__ = ["with_interfaces", "interface_name"]

# Abaqus face number (0 for S1) of the face opposite each local vertex
_FACE_OPPOSITE = np.argsort(OPPOSITE_NODE)


def interface_name(first: str, second: str, index: tuple[int, int]) -> str:
    """``interface_<first>_<second>``, or ``interface_<i>_<j>`` when that is too long a set name."""
    name = f"interface_{first}_{second}"
    return name if SET_NAME.match(name) else f"interface_{index[0]}_{index[1]}"


def with_interfaces(faces: FaceSets, cells: np.ndarray, region_ids: np.ndarray, region_names: list[str]) -> FaceSets:
    """``faces`` with one more set per pair of regions that share faces.

    Each face between regions ``a < b`` (indices into ``region_names``) is given once, from its
    cell in region ``a`` (element, Abaqus face number, nodes ordered so the normal points out
    of that cell, i.e. into region ``b``).

    Examples
    --------
    >>> import numpy as np
    >>> from fepre.export.boundaries import assign_boundaries
    >>> cells = np.array([[0, 1, 2, 3], [1, 2, 3, 4]])
    >>> points = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1], [1, 1, 1]], float)
    >>> cells[1] = cells[1][[0, 2, 1, 3]]  # positive volume
    >>> sets = with_interfaces(assign_boundaries(points, cells, None), cells, np.array([0, 1]), ["a", "b"])
    >>> sets.names, sets.interfaces, int((sets.set_ids == 1).sum())
    (['boundary', 'interface_a_b'], 1, 1)
    """
    from ..distmesh.tet_topology import face_neighbours

    linear = np.ascontiguousarray(cells[:, :4], dtype=np.int64)
    neighbours = face_neighbours(linear, int(linear.max()) + 1)
    cell, vertex = np.nonzero(neighbours >= 0)
    other = neighbours[cell, vertex]
    keep = region_ids[cell] < region_ids[other]
    cell, vertex, other = cell[keep], vertex[keep], other[keep]
    if cell.size == 0:
        return faces
    pair_keys = region_ids[cell] * len(region_names) + region_ids[other]
    pairs, pair_of = np.unique(pair_keys, return_inverse=True)
    names = [interface_name(region_names[k // len(region_names)], region_names[k % len(region_names)],
                            (int(k // len(region_names)), int(k % len(region_names)))) for k in pairs.tolist()]
    check_names(faces.names + names, "interfaces")
    local = _FACE_OPPOSITE[vertex]
    triangles = linear[cell[:, None], OUTWARD_FACES[local]]
    return FaceSets(
        np.concatenate([faces.elements, cell]),
        np.concatenate([faces.local_faces, local]),
        np.concatenate([faces.triangles, triangles]),
        np.concatenate([faces.set_ids, len(faces.names) + pair_of]),
        faces.names + names,
        faces.interfaces + len(names),
    )
