"""Meshes for the export tests (no tests here): structured Kuhn meshes of boxes, the unit ball as a
radially mapped Kuhn cube (exact halving of h between levels), and irregular meshes."""

from __future__ import annotations

import itertools

import numpy as np
import pyvista as pv

from fepre.quality import signed_volumes

# The six tetrahedra of the Kuhn (Freudenthal) subdivision of a cube: paths 000 -> 111.
_KUHN = np.array(
    [[0, 1 << a, (1 << a) | (1 << b), 7] for a, b, _ in itertools.permutations(range(3))], dtype=np.int64
)


def kuhn_box(lower, upper, n) -> pv.UnstructuredGrid:
    """Box [lower, upper] split into n[0] x n[1] x n[2] cubes of 6 tetrahedra each."""
    n = np.broadcast_to(np.asarray(n, dtype=np.int64), (3,))
    axes = [np.linspace(lower[i], upper[i], n[i] + 1) for i in range(3)]
    z, y, x = np.meshgrid(axes[2], axes[1], axes[0], indexing="ij")
    points = np.column_stack([x.ravel(), y.ravel(), z.ravel()])
    stride = np.array([1, n[0] + 1, (n[0] + 1) * (n[1] + 1)])
    i, j, k = np.meshgrid(np.arange(n[0]), np.arange(n[1]), np.arange(n[2]), indexing="ij")
    base = (i.ravel() * stride[0] + j.ravel() * stride[1] + k.ravel() * stride[2])[:, None]
    corner_offset = np.array([(c & 1) * stride[0] + ((c >> 1) & 1) * stride[1] + ((c >> 2) & 1) * stride[2]
                              for c in range(8)])
    cells = (base[:, None, :] + corner_offset[_KUHN][None, :, :]).reshape(-1, 4)
    negative = signed_volumes(points, cells) < 0
    cells[negative] = cells[negative][:, [0, 2, 1, 3]]
    return pv.UnstructuredGrid({pv.CellType.TETRA: cells}, points)


def kuhn_ball(n: int) -> pv.UnstructuredGrid:
    """Unit ball from the Kuhn mesh of [-1, 1]^3 (n cubes per axis): each shell |x|_inf = r is
    mapped onto the sphere of radius r by the smooth cube-to-sphere map
    x sqrt(1 - y^2/2 - z^2/2 + y^2 z^2/3) (and cyclically) applied to x / r."""
    mesh = kuhn_box((-1, -1, -1), (1, 1, 1), n)
    points = np.asarray(mesh.points)
    r = np.abs(points).max(axis=1)
    q = np.divide(points, r[:, None], out=np.zeros_like(points), where=r[:, None] > 0)
    q2 = q * q
    mapped = np.empty_like(q)
    for axis in range(3):
        b, c = q2[:, (axis + 1) % 3], q2[:, (axis + 2) % 3]
        mapped[:, axis] = q[:, axis] * np.sqrt(1 - b / 2 - c / 2 + b * c / 3)
    mesh.points = mapped * r[:, None]
    return mesh


def distmesh_ball(h: float) -> pv.UnstructuredGrid:
    """An irregular DistMesh mesh of the unit ball (fepre.distmesh, seed 0: reproducible)."""
    import fepre
    from fepre import sdf

    return fepre.distmesh(sdf.sphere(1.0), h=h)
