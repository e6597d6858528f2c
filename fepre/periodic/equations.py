"""Periodic boundary conditions as linear constraints between nodes and reference nodes.

For a cell of periods ``L`` under a macroscopic displacement gradient ``E``, periodicity asks
``u(x + L_k e_k) - u(x) = L_k E e_k``. Three reference nodes carry the right-hand sides: the
displacement of reference node ``k`` is ``L_k E[:, k]``. Each node on an upper face is tied to its
master on the lower faces (:mod:`fepre.periodic.nodes`):

    u(slave) - u(master) - sum_k shift_k u(ref_k) = 0,

one equation per degree of freedom. In a 10-node mesh, a midside node on a face whose edge is
not on the opposite face (the two faces' triangles differ at the rim of the solid) has no
partner; it follows its edge's end nodes linearly, ``u(q) = (u(a) + u(b)) / 2``, written against
their masters. A corner node on a face without a partner (a rim node whose cells the mesh kept
on one face only, :func:`fepre.periodic.nodes.match_faces`) is left unconstrained. Every
equation's first node is its dependent one and no dependent node appears in another equation.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .cell import PeriodicCell

__all__ = ["PeriodicConstraints", "periodic_constraints", "equation_text"]

TET10_EDGES = np.array([[0, 1], [1, 2], [2, 0], [0, 3], [1, 3], [2, 3]], dtype=np.int64)


@dataclass(frozen=True)
class PeriodicConstraints:
    """Constraints of a periodic mesh (0-based node ids).

    Attributes
    ----------
    slaves, masters : (M,) int64
        Paired nodes: ``points[slaves] = points[masters] + shifts @ diag(period)``.
    shifts : (M, 3) int8
    followers : (F,) int64
        Unpaired midside nodes on the faces (10-node meshes).
    follower_ends : (F, 2) int64
        The end nodes of their edges.
    unpaired : (K,) int64
        Corner nodes on a face without a partner (rim nodes whose cells the mesh kept on one
        face only, :func:`fepre.periodic.nodes.match_faces`): left unconstrained.
    """

    slaves: np.ndarray
    masters: np.ndarray
    shifts: np.ndarray
    followers: np.ndarray
    follower_ends: np.ndarray
    unpaired: np.ndarray

    @property
    def dependent(self) -> np.ndarray:
        return np.concatenate([self.slaves, self.followers])


def _edge_of_midside(cells: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Every (cell, edge)'s midside node and its two end nodes."""
    ends = cells[:, TET10_EDGES]  # (M, 6, 2)
    mid = cells[:, 4:10]
    return mid.ravel(), ends.reshape(-1, 2)


def periodic_constraints(points: np.ndarray, cells: np.ndarray, cell: PeriodicCell, tol: float) -> PeriodicConstraints:
    """The constraints of the mesh ``(points, cells)`` (4- or 10-node tetrahedra) of ``cell``."""
    from .nodes import match_faces

    slaves, masters, shifts, lonely = match_faces(points, cell, tol)
    followers = np.zeros(0, np.int64)
    ends = np.zeros((0, 2), np.int64)
    unpaired = lonely
    if lonely.size and cells.shape[1] == 10:
        mid, edge_ends = _edge_of_midside(cells)
        order = np.argsort(mid, kind="stable")
        unique_mid, start = np.unique(mid[order], return_index=True)
        position = np.minimum(np.searchsorted(unique_mid, lonely), unique_mid.size - 1)
        is_midside = unique_mid[position] == lonely
        followers = lonely[is_midside]
        ends = edge_ends[order[start[position[is_midside]]]]
        unpaired = lonely[~is_midside]
    return PeriodicConstraints(slaves.astype(np.int64), masters, shifts, followers.astype(np.int64), ends.astype(np.int64),
                               unpaired.astype(np.int64))


def _master_of(constraints: PeriodicConstraints, n: int) -> tuple[np.ndarray, np.ndarray]:
    """Every node as ``(master, shift)``: itself and 0 unless it is a slave."""
    master = np.arange(n, dtype=np.int64)
    shift = np.zeros((n, 3), np.int8)
    master[constraints.slaves] = constraints.masters
    shift[constraints.slaves] = constraints.shifts
    return master, shift


def _format(terms: list[tuple[np.ndarray, int, float | np.ndarray]], dof: int) -> str:
    """Equations (one per row) of the given terms: each term is (node ids 1-based, dof, coef)."""
    count = len(terms)
    rows = len(terms[0][0])
    table = np.empty((rows, 3 * count), dtype=object)
    for j, (nodes, _, coef) in enumerate(terms):
        table[:, 3 * j] = nodes
        table[:, 3 * j + 1] = dof
        table[:, 3 * j + 2] = coef
    per_line = 4
    line_formats = []
    for start in range(0, count, per_line):
        width = min(per_line, count - start)
        line_formats.append(", ".join(["%d, %d, %.12g"] * width))
    fmt = f"{count}\n" + "\n".join(line_formats) + "\n"
    flat = table.reshape(-1).tolist()
    return (fmt * rows) % tuple(flat)


def equation_text(constraints: PeriodicConstraints, n_points: int, references: tuple[int, int, int]) -> str:
    """``*EQUATION`` blocks (CalculiX/Abaqus) for the constraints; ``references`` are the
    1-based ids of the reference nodes of x, y and z."""
    if len(constraints.dependent) == 0:
        return ""
    master, shift = _master_of(constraints, n_points)
    refs = np.asarray(references, dtype=np.int64)
    parts = ["*EQUATION\n"]
    # pairs, grouped by which reference nodes they use
    codes = constraints.shifts.astype(np.int64) @ np.array([1, 2, 4])
    for code in np.unique(codes):
        rows = codes == code
        used = [k for k in range(3) if code >> k & 1]
        for dof in (1, 2, 3):
            terms = [(constraints.slaves[rows] + 1, dof, 1.0), (constraints.masters[rows] + 1, dof, -1.0)]
            terms += [(np.full(int(rows.sum()), refs[k]), dof, -1.0) for k in used]
            parts.append(_format(terms, dof))
    if constraints.followers.size:
        a, b = constraints.follower_ends[:, 0], constraints.follower_ends[:, 1]
        weights = 0.5 * (shift[a].astype(np.int64) + shift[b])  # (F, 3) in {0, 0.5, 1}
        keys = (2 * weights).astype(np.int64) @ np.array([1, 3, 9])
        for key in np.unique(keys):
            rows = keys == key
            w = weights[np.flatnonzero(rows)[0]]
            for dof in (1, 2, 3):
                terms = [(constraints.followers[rows] + 1, dof, 1.0), (master[a[rows]] + 1, dof, -0.5),
                         (master[b[rows]] + 1, dof, -0.5)]
                terms += [(np.full(int(rows.sum()), refs[k]), dof, -float(w[k])) for k in range(3) if w[k]]
                parts.append(_format(terms, dof))
    return "".join(parts)
