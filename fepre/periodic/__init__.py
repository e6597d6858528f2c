"""Periodic unit cells: meshes whose opposite faces match, node pairs, homogenised stiffness."""

from .cell import PeriodicCell
from .nodes import PeriodicNodes, periodic_nodes

__all__ = ["PeriodicCell", "PeriodicNodes", "periodic_nodes"]
