"""Wall thickness and gap width at surface points, by marching rays through the model.

From a point on the surface with outward normal ``n``, the wall's thickness is how far the ray
``-n`` stays inside the part, and the gap's width how far ``+n`` stays outside. The rays march
by sphere tracing: a step of ``|sdf|`` never crosses the surface (fepre's models are exact
distances or lower bounds of them), and a step of at least ``min_step`` keeps a ray moving off
the surface it starts from. The crossing is then placed by bisection between the last two
positions, to ``min_step / 64``.

A ray that meets the surface at a grazing angle (its direction at more than ``FACING`` degrees
from the normal there) has run along a face, not across a wall or gap: from a point on the rim
of a hole, the ray along the face's normal slides down the hole's wall. Such rays count as not
crossing (``inf``).

A crossing is a sign change to strictly outside (``inside``) or strictly inside: where two
solids of a union touch face to face, the union's distance is exactly zero on their common face
inside the material, and that face is not a surface a ray leaves or enters the part through.
"""

from __future__ import annotations

import numpy as np

__all__ = ["ray_lengths"]

#: sphere-tracing steps per ray at most (a ray at grazing incidence advances slowly)
MAX_STEPS = 64
#: bisection steps once a ray has crossed
BISECTIONS = 12
#: largest angle (degrees) between a ray and the surface's normal where it crosses
FACING = 60.0


def ray_lengths(model, origins: np.ndarray, directions: np.ndarray, inside: bool, limit: float, min_step: float) -> np.ndarray:
    """Distance along each ray until it leaves (``inside``) or enters the part; ``inf`` past ``limit``.

    Examples
    --------
    >>> import numpy as np
    >>> from fepre import sdf
    >>> plate = sdf.box((10.0, 10.0, 0.4))
    >>> top = np.array([[0.0, 0.0, 0.2]])
    >>> round(float(ray_lengths(plate, top, np.array([[0.0, 0.0, -1.0]]), True, 5.0, 0.02)[0]), 3)
    0.4
    """
    n = len(origins)
    travelled = np.full(n, min_step)
    length = np.full(n, np.inf)
    active = np.arange(n)
    previous = np.zeros(n)
    for _ in range(MAX_STEPS):
        if active.size == 0:
            break
        positions = origins[active] + travelled[active, None] * directions[active]
        values = model(positions)
        crossed = values > 0 if inside else values < 0
        if crossed.any():
            done = active[crossed]
            at = _bisect(model, origins[done], directions[done], previous[done], travelled[done], inside, min_step)
            _, gradient = model.value_and_gradient(origins[done] + at[:, None] * directions[done])
            norm = np.linalg.norm(gradient, axis=1)
            cosine = np.einsum("ij,ij->i", gradient, directions[done]) / np.where(norm > 0, norm, np.inf)
            facing = cosine >= np.cos(np.radians(FACING)) if inside else cosine <= -np.cos(np.radians(FACING))
            length[done] = np.where(facing, at, np.inf)
        beyond = travelled[active] > limit
        keep = ~crossed & ~beyond
        active, values = active[keep], values[keep]
        previous[active] = travelled[active]
        travelled[active] += np.maximum(np.abs(values), min_step)
    return length


def _bisect(model, origins, directions, low, high, inside: bool, min_step: float) -> np.ndarray:
    """Shrink ``[low, high]`` (the ray crosses in it) a few times; returns the midpoints."""
    for _ in range(BISECTIONS):
        if float(np.max(high - low, initial=0.0)) <= min_step / 64:
            break
        middle = 0.5 * (low + high)
        values = model(origins + middle[:, None] * directions)
        crossed = values > 0 if inside else values < 0
        high = np.where(crossed, middle, high)
        low = np.where(crossed, low, middle)
    return 0.5 * (low + high)
