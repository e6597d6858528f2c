"""What every writer receives: nodes, cells, region and boundary sets, in one checked bundle."""

from __future__ import annotations

from dataclasses import dataclass, field
from functools import cached_property
from typing import Any

import numpy as np

from .boundaries import FaceSets

__all__ = ["ExportData", "FACE_EDGE_NODES"]

# For each outward face (rows of boundaries.OUTWARD_FACES) the tet10 local nodes of its edges
# (a, b), (b, c), (c, a): the 6-node triangle is corners then these midside nodes.
_EDGE_NODE = {(0, 1): 4, (1, 2): 5, (0, 2): 6, (0, 3): 7, (1, 3): 8, (2, 3): 9}
FACE_EDGE_NODES = np.array(
    [
        [_EDGE_NODE[tuple(sorted(pair))] for pair in ((f[0], f[1]), (f[1], f[2]), (f[2], f[0]))]
        for f in ([0, 2, 1], [0, 1, 3], [1, 2, 3], [0, 3, 2])
    ],
    dtype=np.int64,
)


@dataclass(frozen=True)
class ExportData:
    """A mesh ready to write.

    Attributes
    ----------
    points : (N, 3) float64
    cells : (M, 4) or (M, 10) int64, VTK node order, 0-based
    region_ids : (M,) int64 index into ``region_names``
    region_names : list of str
    faces : FaceSets (boundary faces of the linear mesh, with their set index)
    title : str
        One line naming fepre and the model, for headers.
    model_text : str
        The model tree (``repr``), possibly several lines, or "".
    point_arrays, cell_arrays : dict name -> array
        The input mesh's own arrays (one value per corner node, per cell), for formats that carry
        them (VTU).
    periodic : fepre.periodic.PeriodicCell or None
        The cell of a periodic mesh.
    constraints : fepre.periodic.equations.PeriodicConstraints or None
        Its node pairs (over ``points``, midside nodes included), written as ``*EQUATION``.
    sections : list of fepre.export.sections.Section or None
        One elastic material per region, written as ``*MATERIAL`` and ``*SOLID SECTION``.
    """

    points: np.ndarray
    cells: np.ndarray
    region_ids: np.ndarray
    region_names: list[str]
    faces: FaceSets
    title: str
    model_text: str = ""
    point_arrays: dict = field(default_factory=dict)
    cell_arrays: dict = field(default_factory=dict)
    periodic: Any = None
    constraints: Any = None
    sections: Any = None

    @property
    def order(self) -> int:
        return 2 if self.cells.shape[1] == 10 else 1

    @cached_property
    def face_nodes(self) -> np.ndarray:
        """Boundary triangles (K, 3), or (K, 6) with midside nodes for order 2 (outward)."""
        if self.order == 1:
            return self.faces.triangles
        from .boundaries import OUTWARD_FACES

        local = np.hstack([OUTWARD_FACES, FACE_EDGE_NODES])[self.faces.local_faces]
        return np.take_along_axis(self.cells[self.faces.elements], local, axis=1)

    def face_set_nodes(self, index: int) -> np.ndarray:
        """Sorted unique node ids (0-based) of the faces in set ``index``."""
        return np.unique(self.face_nodes[self.faces.set_ids == index])

    @property
    def boundary_names(self) -> list[str]:
        return self.faces.names
