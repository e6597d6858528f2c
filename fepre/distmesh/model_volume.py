"""The volume of a model estimated from its values on the material checks' grids.

A triangle-mesh model's volume is exact (its divergence sum), and a mesh whose cells come out
more than 1% off it warns (:func:`.lost_material.volume_message`). A model given as a function
has no such figure, so a sphere of radius 2 joined to a capsule 1.2 across, meshed at ``h = 1``,
came out 7% short without a word. The checks of :mod:`.lost_material` have sampled the model at
``h / 4`` around its surface already; each node of those grids counts for the share of its cell
that is inside, ``clip(0.5 - value / spacing, 0, 1)``. The clipped ramp is symmetric about the
surface, so on a flat face it is exact in the mean whatever the gradient's norm (a level set
that is not a distance); on a curved face, an edge or a corner it is off by the square of the
spacing. The same sum over every second node (twice the spacing) gives a second figure whose
error is four times the first's; their Richardson extrapolation is the estimate, and a third of
their difference its uncertainty: a box 2 x 3 x 4 sampled at 0.25 is +2.3% at that spacing and
0.000% extrapolated; a torus of tube radius 0.5, +2.5% and +0.6%.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

__all__ = ["VolumeEstimate", "sampled_volume"]


@dataclass(frozen=True)
class VolumeEstimate:
    """A model's volume from sampled values: ``volume`` and ``uncertainty`` (world units cubed)."""

    volume: float
    uncertainty: float


def _inside_volume(values: np.ndarray, step: np.ndarray, mine: np.ndarray | None) -> float:
    """Sum over the nodes (all, or those of ``mine``) of the share of each node's cell inside."""
    spacing = float(np.cbrt(np.prod(step)))
    share = np.multiply(values, -1.0 / spacing, dtype=np.float64)
    share += 0.5
    np.clip(share, 0.0, 1.0, out=share)
    if mine is not None:
        share[~mine] = 0.0
    return float(share.sum()) * float(np.prod(step))


def sampled_volume(grids) -> VolumeEstimate:
    """The volume inside the model of ``grids``, sampled grids of :mod:`.lost_material`
    (``values`` (nz, ny, nx), ``step`` (3,), ``mine``: the nodes each grid counts, None for all)
    that together cover the model, each node counting for the cell from it to the next.

    Examples
    --------
    >>> import numpy as np
    >>> from types import SimpleNamespace
    >>> axis = np.arange(-1.5, 1.5001, 0.1)
    >>> z, y, x = np.meshgrid(axis, axis, axis, indexing="ij")
    >>> ball = SimpleNamespace(values=np.sqrt(x**2 + y**2 + z**2) - 1.0, step=np.full(3, 0.1), mine=None)
    >>> estimate = sampled_volume([ball])
    >>> abs(estimate.volume / (4 / 3 * np.pi) - 1) < 0.005, estimate.uncertainty < 0.02
    (True, True)
    """
    fine = coarse = 0.0
    for grid in grids:
        step = np.asarray(grid.step, np.float64)
        mine = grid.mine
        fine += _inside_volume(grid.values, step, mine)
        coarse += _inside_volume(grid.values[::2, ::2, ::2], 2.0 * step, None if mine is None else mine[::2, ::2, ::2])
    return VolumeEstimate(volume=(4.0 * fine - coarse) / 3.0, uncertainty=abs(fine - coarse) / 3.0)
