"""Where a graded mesh's material checks sample at which spacing: zones by octave of the size.

The checks of :mod:`.lost_material` sample the model at a quarter of ``h`` in a band of ``h``
about its surface, and their depth tests are relative to the local size (a node must be deeper
than ``0.1`` of the size there). A graded mesh's ``h`` is its smallest size; sampled at
``h / 4`` over the whole surface, a part whose sizes run from ``h`` to ``6 h`` pays for the
finest sampling everywhere (a triangle-mesh model 1e4 from the origin, 36k cells: 14-30 s of a
graded mesh's 77-120 s). Here the box is cut into cubic zones; each zone is sampled at a quarter
of the octave ``h 2^level`` of the smallest size in it (in a band of that octave), so the number
of samples falls with the square of the local size, as the cells' count falls with its cube.
Every point of the box is in one zone and checked once, at that zone's spacing; the grids of
all octaves share their origin, so a zone's nodes are those of its octave's grid.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..arguments import evaluate_size

__all__ = ["CheckZones", "check_zones"]

#: a zone is this many of the coarsest octave's sample spacings wide (a quarter of that octave
#: each): one of its sizes, half a block of the banded sampler (:mod:`fepre.sampling`)
ZONE_SPACINGS = 4
#: sizes probed per zone and axis (corners included) for the smallest size in it
PROBES = 5
#: the smallest size probed is taken this much smaller (sizes between the probes)
MARGIN = 0.9


@dataclass(frozen=True)
class CheckZones:
    """Cubic zones of a box and the octave each is sampled at.

    Attributes
    ----------
    origin : (3,) float
        Corner of the first zone (and the first node of every octave's grid).
    side : float
        Edge of a zone.
    levels : (nz, ny, nx) int
        The octave of each zone: sampled at ``spacing * 2**level``.
    spacing : float
        The finest sampling (octave 0).
    """

    origin: np.ndarray
    side: float
    levels: np.ndarray
    spacing: float

    def level_at(self, points: np.ndarray) -> np.ndarray:
        """The octave of the zone holding each point (N,)."""
        index = np.floor((np.asarray(points, np.float64) - self.origin) / self.side).astype(np.int64)
        shape = np.array(self.levels.shape[::-1])  # (nx, ny, nz)
        index = np.clip(index, 0, shape - 1)
        return self.levels[index[:, 2], index[:, 1], index[:, 0]]

    def blocks(self, level: int, half: np.ndarray):
        """``centres (B, 3) -> (B,) bool``: the sampler's blocks (half-widths ``half``) that hold
        a node of a zone at ``level`` (probed at their centres, corners and mid-edges: zones
        are at least half a block wide)."""
        offsets = np.stack(np.meshgrid(*([-1.0, 0.0, 1.0],) * 3, indexing="ij"), axis=-1).reshape(-1, 3) * half

        def wanted(centres: np.ndarray) -> np.ndarray:
            probes = (centres[:, None, :] + offsets[None]).reshape(-1, 3)
            return (self.level_at(probes) == level).reshape(len(centres), -1).any(axis=1)

        return wanted

    def grid(self, level: int) -> tuple[list[np.ndarray], np.ndarray, np.ndarray]:
        """Octave ``level``'s grid over the box of its zones: its axes (x, y, z), spacing (3,)
        and which of its nodes (nz, ny, nx) are in its zones."""
        step = self.spacing * 2.0**level
        k, j, i = np.nonzero(self.levels == level)
        first = np.array([i.min(), j.min(), k.min()])
        last = np.array([i.max(), j.max(), k.max()]) + 1
        per_zone = int(round(self.side / step))
        nodes = [np.arange(first[a] * per_zone, last[a] * per_zone + 1) for a in range(3)]
        axes = [self.origin[a] + step * nodes[a] for a in range(3)]
        # a node on a zone's far face is the next zone's
        zone = [np.minimum(n // per_zone, self.levels.shape[2 - a] - 1) for a, n in enumerate(nodes)]
        mine = self.levels[np.ix_(zone[2], zone[1], zone[0])] == level
        return axes, np.full(3, step), mine


def check_zones(size, h: float, spacing: float, lower: np.ndarray, upper: np.ndarray) -> CheckZones | None:
    """The zones of the box ``lower``-``upper`` for sizes ``size`` (world units, at least ``h``)
    sampled at ``spacing`` per ``h``; None when every zone is at the finest octave (one grid).

    Examples
    --------
    >>> import numpy as np
    >>> graded = lambda p: 1.0 + 0.3 * np.abs(p[:, 0])        # 1 at x = 0, 7 at x = 20
    >>> zones = check_zones(graded, 1.0, 0.25, np.array([-20.0, -2, -2]), np.array([20.0, 2, 2]))
    >>> int(zones.levels.max()), int(zones.level_at(np.array([[0.0, 0, 0]]))[0])
    (2, 0)
    """
    lower, upper = np.asarray(lower, np.float64), np.asarray(upper, np.float64)
    lattice = np.stack(np.meshgrid(*(np.linspace(lower[a], upper[a], 16) for a in range(3)), indexing="ij"), axis=-1)
    largest = float(np.max(evaluate_size(size, lattice.reshape(-1, 3))))
    top = int(np.floor(np.log2(max(largest, h) / h)))  # the coarsest octave (an underestimate only samples finer)
    if top == 0:
        return None
    side = ZONE_SPACINGS * spacing * 2.0**top  # a zone holds whole blocks of the coarsest octave's grid
    counts = np.maximum(np.ceil((upper - lower) / side - 1e-9).astype(np.int64), 1)
    smallest = _smallest_sizes(size, lower, side, counts)
    levels = np.clip(np.floor(np.log2(np.maximum(smallest, h) / h)), 0, top).astype(np.int64)
    if not levels.any():
        return None
    return CheckZones(lower, side, levels, spacing)


def _smallest_sizes(size, lower: np.ndarray, side: float, counts: np.ndarray) -> np.ndarray:
    """The smallest size probed in each zone (nz, ny, nx), times ``MARGIN``."""
    probe = np.linspace(0.0, side, PROBES)
    offsets = np.stack(np.meshgrid(probe, probe, probe, indexing="ij"), axis=-1).reshape(-1, 3)
    k, j, i = np.meshgrid(*(np.arange(n) for n in counts[::-1]), indexing="ij")
    corners = lower + side * np.column_stack([i.ravel(), j.ravel(), k.ravel()])
    values = evaluate_size(size, (corners[:, None, :] + offsets[None]).reshape(-1, 3)).reshape(len(corners), -1)
    return MARGIN * values.min(axis=1).reshape(tuple(counts[::-1]))
