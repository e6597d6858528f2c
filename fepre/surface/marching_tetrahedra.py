"""fepre's marching tetrahedra on a fixed six-tetrahedron split of every cube.

Each cube is split into the six tetrahedra around its main diagonal (corner 0 to corner 7),
one per order of the three axes. A cube face is then always cut along the diagonal from its
lowest to its highest corner, the same diagonal the neighbouring cube uses, so the split is
conforming and the surface has no cracks and no ambiguous cases. Vertices lie on grid edges,
face diagonals and cube diagonals (seven edge families), one per crossing edge, shared.

The 256-case cube table is assembled at import from the 16 cases of each tetrahedron, with
every triangle oriented from the inside corners to the outside ones.
"""

from __future__ import annotations

import itertools

import numpy as np

from .table_extraction import CaseTable, extract_with_table

__all__ = ["marching_tetrahedra", "TETRAHEDRON_TABLE"]

#: edge families: x, y, z, then the xy, xz, yz face diagonals and the body diagonal
_FAMILIES = [(1, 0, 0), (0, 1, 0), (0, 0, 1), (1, 1, 0), (1, 0, 1), (0, 1, 1), (1, 1, 1)]


def _corner(index: int) -> np.ndarray:
    return np.array([index & 1, (index >> 1) & 1, index >> 2])


def _tetrahedra() -> list[tuple[int, int, int, int]]:
    """Corner indices of the six tetrahedra sharing the diagonal 0-7 (Kuhn split)."""
    tets = []
    for order in itertools.permutations((1, 2, 4)):
        tets.append((0, order[0], order[0] + order[1], 7))
    return tets


def _build_table() -> CaseTable:
    edges: dict[tuple[int, int], int] = {}
    starts, families = [], []

    def edge(a: int, b: int) -> int:
        a, b = min(a, b), max(a, b)  # b - a has only bits absent from a (b is a superset of a)
        if (a, b) not in edges:
            edges[(a, b)] = len(starts)
            starts.append(_corner(a))
            families.append(_FAMILIES.index(tuple(_corner(b) - _corner(a))))
        return edges[(a, b)]

    tets = _tetrahedra()
    for tet in tets:
        for a, b in itertools.combinations(tet, 2):
            edge(a, b)
    triangles = []
    for case in range(256):
        flat: list[int] = []
        for tet in tets:
            inside = [c for c in tet if (case >> c) & 1]
            outside = [c for c in tet if not (case >> c) & 1]
            if not inside or not outside:
                continue
            if len(inside) == 1 or len(outside) == 1:
                lone, others = (inside[0], outside) if len(inside) == 1 else (outside[0], inside)
                polygons = [[(lone, o) for o in others]]
            else:
                (a, b), (c, d) = inside, outside
                polygons = [[(a, c), (a, d), (b, d)], [(a, c), (b, d), (b, c)]]
            inner = np.mean([_corner(c) for c in inside], axis=0)
            outer = np.mean([_corner(c) for c in outside], axis=0)
            for polygon in polygons:
                mids = [(_corner(p) + _corner(q)) / 2 for p, q in polygon]
                normal = np.cross(mids[1] - mids[0], mids[2] - mids[0])
                if np.dot(normal, outer - inner) < 0:
                    polygon = polygon[::-1]
                flat.extend(edge(p, q) for p, q in polygon)
        triangles.append(tuple(flat))
    return CaseTable(np.array(_FAMILIES), np.array(starts), np.array(families), tuple(triangles))


TETRAHEDRON_TABLE = _build_table()


def marching_tetrahedra(
    values: np.ndarray,
    level: float,
    origin: np.ndarray,
    spacing: np.ndarray,
    workers: int | None = None,
    *,
    first_node: np.ndarray | None = None,
    keys: bool = False,
):
    """Points and outward triangles of the ``level`` set of a (nz, ny, nx) array.

    Examples
    --------
    >>> import numpy as np
    >>> t = np.linspace(-1, 1, 9)
    >>> r = np.sqrt(t[None, None, :]**2 + t[None, :, None]**2 + t[:, None, None]**2) - 0.6
    >>> points, triangles = marching_tetrahedra(r, 0.0, np.full(3, -1.0), np.full(3, 0.25))
    >>> points.shape[1], triangles.shape[1]
    (3, 3)
    """
    return extract_with_table(
        values, level, np.asarray(origin, float), np.asarray(spacing, float), TETRAHEDRON_TABLE, workers,
        first_node=first_node, keys=keys,
    )
