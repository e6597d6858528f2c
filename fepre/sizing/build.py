"""``fepre.size_field``: the edge length a part needs at every point, from the model alone.

Seeds are points on the surface, one near every node of a grid at spacing ``hmin`` (the nodes
within a spacing of the surface, projected onto it). Each seed gets the smallest of

- the wall's thickness there over ``elements_across`` (a ray along the inward normal, to where
  it leaves the part: :mod:`fepre.sizing.rays`);
- half the width of the gap in front of it (the ray along the outward normal, to where it
  enters the part again): a slot, a narrow gap, a small hole's diameter, two elements across;
- ``sqrt(8 * chord_tolerance / k)``, the chord of the circle of curvature ``k`` (the largest
  principal curvature of the smooth piece of surface there, :mod:`fepre.sizing.curvature`)
  whose sagitta is ``chord_tolerance``;
- with ``features``, the distance to the nearest feature curve facing it (two sharp edges
  closer than the size, e.g. a shallow step, a narrow ledge or a thin rib's top; below hmin too),

clamped to ``[hmin, hmax]`` (walls and gaps: to ``[WALL_FLOOR * hmin, hmax]``). The field on the grid is the lower envelope of the cones
``size + (gradation - 1) * distance`` over the seeds (:mod:`fepre.sizing.gradation`), capped at
``hmax``: away from the surface, sizes grow at the rate ``gradation`` allows.
"""

from __future__ import annotations

import time
from typing import Any

import numpy as np

from ..arguments import domain_bounds, finite_float, positive_float
from ..sdf.core import SDF
from ..placement import local_offset
from .curvature import max_curvature
from .field import MAX_NODES, SizeField
from .gradation import graded_sizes
from .rays import ray_lengths

__all__ = ["size_field", "WALL_FLOOR"]

#: walls thinner than ``elements_across * hmin`` get sizes below ``hmin``, down to this times it
WALL_FLOOR = 0.075


def _spread(seeds: np.ndarray, normal: np.ndarray, wall: np.ndarray, spacing: float, thickness: np.ndarray | None = None):
    """Copies of seeds under hmin (and, given the wall ``thickness``, of its mid-surface) at steps
    of their size across the tangent patch each stands for (a grid spacing square): the cones of
    seeds a spacing apart would let the size between them grow by (gradation - 1) * spacing / 2,
    far above a thin wall's or a narrow gap's size."""
    helper = np.where(np.abs(normal[:, :1]) < 0.9, np.array([[1.0, 0.0, 0.0]]), np.array([[0.0, 1.0, 0.0]]))
    first = np.cross(normal, helper)
    first /= np.linalg.norm(first, axis=1)[:, None]
    second = np.cross(normal, first)
    points, sizes = [], []
    for count in np.unique(np.ceil(spacing / wall).astype(np.int64)):
        group = np.ceil(spacing / wall).astype(np.int64) == count
        if count <= 1:
            continue
        steps = (np.arange(count) + 0.5) / count - 0.5  # across [-spacing/2, spacing/2]
        a, b = (g.ravel() for g in np.meshgrid(steps, steps, indexing="ij"))
        offsets = spacing * (a[None, :, None] * first[group][:, None, :] + b[None, :, None] * second[group][:, None, :])
        bases = [seeds[group]]
        if thickness is not None:
            bases.append(seeds[group] - 0.5 * thickness[group, None] * normal[group])
        for base in bases:
            points.append((base[:, None, :] + offsets).reshape(-1, 3))
            sizes.append(np.repeat(wall[group], a.size))
    return points, sizes


def _check(hmin: Any, hmax: Any, elements_across: Any, chord_tolerance: Any, gradation: Any):
    hmin = positive_float(hmin, "hmin")
    hmax = positive_float(hmax, "hmax")
    if hmin >= hmax:
        raise ValueError(f"hmin must be smaller than hmax; got hmin={hmin:g}, hmax={hmax:g} (for one size everywhere pass h alone)")
    elements_across = positive_float(elements_across, "elements_across")
    chord_tolerance = hmin / 10.0 if chord_tolerance is None else positive_float(chord_tolerance, "chord_tolerance")
    gradation = finite_float(gradation, "gradation")
    if not gradation > 1.0:
        raise ValueError(f"gradation must be > 1 (the largest ratio of neighbouring sizes); got {gradation!r}")
    return hmin, hmax, elements_across, chord_tolerance, gradation


def size_field(
    model: SDF,
    hmin: float,
    hmax: float,
    *,
    elements_across: float = 3,
    chord_tolerance: float | None = None,
    gradation: float = 1.3,
    features: bool = True,
    bounds: Any = None,
) -> SizeField:
    """The edge length wanted at every point of ``model``: fine at thin walls, narrow gaps,
    small holes, tight curvature and close sharp edges, growing to ``hmax`` away from them.

    Parameters
    ----------
    model : fepre.sdf.SDF
        The part (negative inside).
    hmin, hmax : float
        Smallest and largest edge length (world units), ``0 < hmin < hmax``.
    elements_across : float
        Elements through the thickness of every wall (default 3): a wall ``t`` thick gets
        ``t / elements_across``, below ``hmin`` too for walls thinner than
        ``elements_across * hmin`` (fewer elements than one per wall would lose or spoil it),
        down to ``WALL_FLOOR * hmin`` (0.075: a wall 0.3 hmin thick still gets 3 or more; the tip of an acute edge stops refining there).
    chord_tolerance : float, optional
        Largest distance between a curved surface and the chord of an element's edge (default
        ``hmin / 10``): a radius ``R`` gets ``sqrt(8 * chord_tolerance * R)``.
    gradation : float
        Largest ratio of the sizes of neighbouring elements (default 1.3: sizes grow by 0.3 of
        the distance).
    features : bool
        Also refine where two sharp feature curves face each other closer than the size
        (:func:`fepre.features`).
    bounds : ((xmin, ymin, zmin), (xmax, ymax, zmax)), optional
        Box holding the part; defaults to ``model.bounds``.

    Returns
    -------
    fepre.SizeField
        On a grid of spacing ``hmin`` (coarser when that would exceed
        ``fepre.sizing.MAX_NODES`` nodes) over the box; ``field.seconds`` is the time it took.

    Notes
    -----
    A part far from the origin is handled near it and the result moved back
    (:mod:`fepre.placement`), so it does not depend on where the part is placed.

    Examples
    --------
    >>> import fepre
    >>> from fepre import sdf
    >>> plate = sdf.box((20.0, 20.0, 0.6))
    >>> field = fepre.size_field(plate, 0.2, 4.0, features=False)
    >>> round(float(field([[0.0, 0.0, 0.0]])[0]), 3)   # three elements through 0.6
    0.2
    """
    start = time.perf_counter()
    if not isinstance(model, SDF) or model.dim != 3:
        raise TypeError(f"model must be a 3D fepre.sdf.SDF; got {type(model).__name__}")
    hmin, hmax, elements_across, chord_tolerance, gradation = _check(hmin, hmax, elements_across, chord_tolerance, gradation)
    if not isinstance(features, bool):
        raise TypeError(f"features must be True or False; got {features!r}")
    offset = local_offset(*domain_bounds(model, bounds))
    if offset.any():  # sized near the origin and moved back (fepre.placement)
        box = None if bounds is None else tuple(np.asarray(b, dtype=np.float64) - offset for b in domain_bounds(model, bounds))
        local = size_field(model.translate(-offset), hmin, hmax, elements_across=elements_across,
                           chord_tolerance=chord_tolerance, gradation=gradation, features=features, bounds=box)
        field = local.translated(offset)
        field.seconds = time.perf_counter() - start
        return field
    lower, upper, spacing, counts, axes, values = _sampled_box(model, bounds, hmin)
    near = np.flatnonzero(np.abs(values.reshape(-1)) < spacing)
    if near.size == 0:
        if float(values.min()) >= 0:
            raise ValueError("the model is empty inside the bounds: nothing to size (check the model's sign and the bounds)")
        return SizeField(lower, np.full(3, spacing), np.full(values.shape, hmax))
    seeds, normal = _surface_seeds(model, near, axes, counts, hmin)
    points, wanted = _wanted_sizes(
        model, seeds, normal, hmin, hmax, elements_across, chord_tolerance, features, (lower, upper), spacing
    )
    field = _graded_field(points, wanted, lower, upper, spacing, counts, hmin, hmax, gradation)
    field.seconds = time.perf_counter() - start
    return field


def _sampled_box(model: SDF, bounds: Any, hmin: float):
    """The model sampled on a grid of spacing ``hmin`` (coarser past ``MAX_NODES``) two nodes
    beyond the box: ``(lower, upper, spacing, counts, axes, values (nz, ny, nx))``."""
    lower, upper = (np.asarray(v, dtype=np.float64) for v in domain_bounds(model, bounds))
    spacing = hmin
    if float(np.prod((upper - lower) / spacing + 5.0)) > MAX_NODES:
        spacing = float(np.cbrt(np.prod(upper - lower + 4 * spacing) / MAX_NODES))
    lower, upper = lower - 2 * spacing, upper + 2 * spacing
    counts = np.ceil((upper - lower) / spacing - 1e-9).astype(np.int64) + 1
    axes = [lower[k] + spacing * np.arange(counts[k]) for k in range(3)]
    values = model.values_on_axes(*axes, dtype=np.float64)  # (nz, ny, nx)
    return lower, upper, spacing, counts, axes, values


def _surface_seeds(model: SDF, near: np.ndarray, axes: list[np.ndarray], counts: np.ndarray, hmin: float):
    """The grid nodes ``near`` the surface projected onto it, and the unit normals there."""
    nx, ny = int(counts[0]), int(counts[1])
    nodes = np.stack([axes[0][near % nx], axes[1][(near // nx) % ny], axes[2][near // (nx * ny)]], axis=1)
    seeds = model.project(nodes, iterations=6, tol=1e-4 * hmin, warn=False)
    on_surface = np.abs(model(seeds)) < 0.05 * hmin
    seeds = seeds[on_surface]
    _, gradient = model.value_and_gradient(seeds)
    norm = np.linalg.norm(gradient, axis=1)
    usable = norm > 1e-9
    return seeds[usable], gradient[usable] / norm[usable, None]


def _wanted_sizes(model, seeds, normal, hmin, hmax, elements_across, chord_tolerance, features, box, spacing):
    """Points and the edge length each wants: walls, gaps, curvature, facing feature curves,
    wall mid-surfaces, and seeds spread along walls and gaps thinner than ``hmin``."""
    step = hmin / 8.0
    thickness = ray_lengths(model, seeds, -normal, True, elements_across * hmax, step)
    gap = ray_lengths(model, seeds, normal, False, hmax, step)
    curvature = max_curvature(model, seeds, 0.05 * hmin)
    with np.errstate(divide="ignore"):
        chord = np.sqrt(8.0 * chord_tolerance / curvature)
    # walls keep elements_across elements below hmin too (down to WALL_FLOOR * hmin: the tip of
    # an acute edge would otherwise refine without end); other needs stop at hmin
    wall = np.clip(thickness / elements_across, WALL_FLOOR * hmin, hmax)
    # two elements across every gap (a hole's diameter): below hmin too, or it closes
    opening = np.clip(gap / 2.0, WALL_FLOOR * hmin, hmax)
    wanted = np.minimum.reduce([wall, opening, np.clip(chord, hmin, hmax)])
    # a wall's size holds through it, not only on its faces: its mid-surface is a seed too
    thin = np.isfinite(thickness) & (wall < hmax)
    points = [seeds, seeds[thin] - 0.5 * thickness[thin, None] * normal[thin]]
    sizes_at = [wanted, wall[thin]]
    if features:
        from .feature_gaps import feature_sizes

        feature_seeds, feature_wanted = feature_sizes(model, hmin, hmax, box)
        points.append(feature_seeds)
        # two sharp edges closer than hmin (a narrow ledge) need elements that small between them
        sizes_at.append(np.clip(feature_wanted, WALL_FLOOR * hmin, hmax))
    # walls under hmin: seeds as dense as their size along the wall, on a grid that fine
    below = np.flatnonzero(thin & (wall < hmin))
    if below.size:
        extra, extra_sizes = _spread(seeds[below], normal[below], wall[below], spacing, thickness[below])
        points += extra
        sizes_at += extra_sizes
    # and along the faces of gaps under hmin (their middle is outside the part)
    narrow = np.flatnonzero((opening < hmin) & ~(thin & (wall < hmin)))
    if narrow.size:
        extra, extra_sizes = _spread(seeds[narrow], normal[narrow], wanted[narrow], spacing)
        points += extra
        sizes_at += extra_sizes
    return np.concatenate(points), np.concatenate(sizes_at)


def _graded_field(points, wanted, lower, upper, spacing, counts, hmin, hmax, gradation) -> SizeField:
    """The sizes wanted at ``points`` spread over a grid, growing by at most ``gradation``."""
    nx, ny = int(counts[0]), int(counts[1])
    # finer than hmin where walls or gaps need it, but not below hmin / 2 (8 times the nodes):
    # one acute edge's tip would otherwise refine the whole grid
    fine = max(min(spacing, 2.0 * float(wanted.min())), 0.5 * hmin, float(np.cbrt(np.prod(upper - lower) / MAX_NODES)))
    if fine < spacing:
        spacing = fine
        counts = np.ceil((upper - lower) / spacing - 1e-9).astype(np.int64) + 1
        nx, ny = int(counts[0]), int(counts[1])
    index = np.clip(np.rint((points - lower) / spacing).astype(np.int64), 0, counts - 1)
    seed_nodes = index[:, 0] + nx * (index[:, 1] + ny * index[:, 2])
    shape = (int(counts[2]), int(counts[1]), int(counts[0]))
    sizes = graded_sizes(shape, np.full(3, spacing), seed_nodes, wanted, gradation - 1.0, hmax)
    return SizeField(lower, np.full(3, spacing), np.clip(sizes, WALL_FLOOR * hmin, hmax))
