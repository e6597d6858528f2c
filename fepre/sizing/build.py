"""``fepre.size_field``: the edge length a part needs at every point, from the model alone.

Seeds are points on the surface, one near every node of a grid at spacing ``hmin`` (the nodes
within a spacing of the surface, projected onto it). Each seed gets the smallest of

- the wall's thickness there over ``elements_across`` (a ray along the inward normal, to where
  it leaves the part: :mod:`fepre.sizing.rays`);
- half the width of the gap in front of it (the ray along the outward normal, to where it
  enters the part again): a slot, a narrow gap, a small hole's diameter, two elements across;
- ``sqrt(8 * chord_tolerance / k)``, the chord of the circle of curvature ``k`` (the largest
  principal curvature of the smooth piece of surface there, :mod:`fepre.sizing.curvature`)
  whose sagitta is ``chord_tolerance`` (by default the smaller of ``hmin / 10`` and
  ``CHORD_RATIO / k``: chords then cut off at most 0.4% of a circle's area, so the volume of a
  part of small radii holds to 0.5%);
- with ``features``, the distance to the nearest feature curve facing it (two sharp edges
  closer than the size, e.g. a shallow step, a narrow ledge or a thin rib's top; hmin at least),

clamped to ``[hmin, hmax]``: ``hmin`` is the smallest size the field gives. Features that
would need smaller elements (a wall thinner than ``elements_across * hmin``, a gap narrower than
``hmin``, sharp edges closer than ``hmin``) get ``hmin`` and are named, each with where it is,
how thick or wide and the size it would need, in one :class:`fepre.ResolutionWarning`. Seeds
count only on the part's real surface: where two solids of a union touch face to face, their
common face inside the material is a zero of the union's distance but no wall and no gap. The field on the grid is the lower envelope of the cones
``size + (gradation - 1) * distance`` over the seeds (:mod:`fepre.sizing.gradation`), capped at
``hmax``: away from the surface, sizes grow at the rate ``gradation`` allows.
"""

from __future__ import annotations

import time
from typing import Any

import numpy as np

from ..arguments import domain_bounds, finite_float, positive_float
from ..sdf.core import SDF, require_solid_model
from ..placement import local_offset, user_frame
from .curvature import max_curvature
from .field import MAX_NODES, SizeField
from .gradation import graded_sizes
from .rays import ray_lengths
from .under_hmin import under_hmin, warn_under_hmin

__all__ = ["size_field"]

#: a seed is on the part's surface when this times hmin along its normal is outside the part
SIDE_STEP = 0.01
#: a gap ray at least this times the distance to the edge where its two faces' planes cross is
#: across a concave junction, not a gap (the faces open at more than atan(0.5), 27 degrees)
JUNCTION = 0.5
#: the two faces reach that edge to within this times the distance to it
EDGE_TOLERANCE = 0.05
#: features are named when they would need sizes below this times hmin
NAMED_BELOW = 0.99
#: a wall or gap the rays measure under this times hmin is one they cannot tell from nothing (their
#: first step is hmin / 8, bisected to hmin / 512): a knife edge, or faces that touch at an angle
NOTHING_BELOW = 1.0 / 256.0
#: the default chord tolerance is at most this times the radius of curvature: an edge of
#: sqrt(8 * CHORD_RATIO) = 0.155 times the radius, whose chords cut 4/3 CHORD_RATIO = 0.4% of a
#: circle's area off (hmin / 10 alone gave edges 2 hmin on a radius 5 hmin: a stepped shaft lost
#: 1.33% of its volume, issue 33)
CHORD_RATIO = 0.003


def _check(hmin: Any, hmax: Any, elements_across: Any, chord_tolerance: Any, gradation: Any):
    hmin = positive_float(hmin, "hmin")
    hmax = positive_float(hmax, "hmax")
    if hmin >= hmax:
        raise ValueError(f"hmin must be smaller than hmax; got hmin={hmin:g}, hmax={hmax:g} (for one size everywhere pass h alone)")
    elements_across = positive_float(elements_across, "elements_across")
    chord_tolerance = None if chord_tolerance is None else positive_float(chord_tolerance, "chord_tolerance")
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
        Smallest and largest edge length (world units), ``0 < hmin < hmax``. The field is
        clamped to ``[hmin, hmax]``: no need goes below ``hmin``. Walls thinner than
        ``elements_across * hmin``, gaps narrower than ``hmin`` and sharp edges closer than
        ``hmin`` get ``hmin``, and a :class:`fepre.ResolutionWarning` names each (where, how
        thick or wide, the size it would need); pass a smaller ``hmin`` to resolve them. A
        wall or gap thinner than the rays can measure (``hmin / 256``: a knife edge, faces that
        touch at an angle) is named without a size: none resolves it.
    elements_across : float
        Elements through the thickness of every wall (default 3): a wall ``t`` thick gets
        ``t / elements_across``, but never below ``hmin``: a wall thinner than
        ``elements_across * hmin`` gets ``hmin`` (fewer elements across) and is named in the
        warning.
    chord_tolerance : float, optional
        Largest distance between a curved surface and the chord of an element's edge: a radius
        ``R`` gets ``sqrt(8 * chord_tolerance * R)``. By default the smaller of ``hmin / 10`` and
        ``0.003 R`` (``CHORD_RATIO``): edges at most ``0.155 R``, whose chords lose at most 0.4%
        of a circle's area, so a part's volume holds to 0.5% wherever ``hmin`` allows it
        (radii above ``6.5 hmin``); large radii get ``sqrt(0.8 * hmin * R)``.
    gradation : float
        Largest ratio of the sizes of neighbouring elements (default 1.3: sizes grow by 0.3 of
        the distance).
    features : bool
        Also refine where two sharp feature curves face each other closer than the size
        (:func:`fepre.features`).
    bounds : ((xmin, ymin, zmin), (xmax, ymax, zmax)), optional
        Box holding the part; defaults to ``model.bounds``.

    Warns
    -----
    fepre.ResolutionWarning
        When features would need sizes below ``hmin`` (one warning naming them all).

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
    require_solid_model(model)
    hmin, hmax, elements_across, chord_tolerance, gradation = _check(hmin, hmax, elements_across, chord_tolerance, gradation)
    if not isinstance(features, bool):
        raise TypeError(f"features must be True or False; got {features!r}")
    offset = local_offset(*domain_bounds(model, bounds))
    if offset.any():  # sized near the origin and moved back (fepre.placement)
        box = None if bounds is None else tuple(np.asarray(b, dtype=np.float64) - offset for b in domain_bounds(model, bounds))
        with user_frame(offset):  # its warnings name places where the user's part is
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
    # the mesher's feature search at h = hmin takes this one's creases (fepre.features, creases=)
    found = _features(model, hmin, (lower, upper)) if features else None
    points, wanted, unresolved = _wanted_sizes(model, seeds, normal, hmin, hmax, elements_across, chord_tolerance,
                                               found, spacing)
    field = _graded_field(points, wanted, lower, upper, spacing, counts, hmin, hmax, gradation)
    field.seconds = time.perf_counter() - start
    field.unresolved = unresolved
    field.creases = None if found is None else found.creases
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
    """The grid nodes ``near`` the surface projected onto it, and the unit normals there.

    A seed counts only where the part really has a surface: a small step along the normal leaves
    the part. Where two solids of a union touch face to face (an I-beam's web on its flanges, a
    boss standing on a plate, a rib on a floor), the union's distance is zero on their common
    face inside the material; seeds there would measure a gap of zero in front of them."""
    nx, ny = int(counts[0]), int(counts[1])
    nodes = np.stack([axes[0][near % nx], axes[1][(near // nx) % ny], axes[2][near // (nx * ny)]], axis=1)
    seeds = model.project(nodes, iterations=6, tol=1e-4 * hmin, warn=False)
    on_surface = np.abs(model(seeds)) < 0.05 * hmin
    seeds = seeds[on_surface]
    _, gradient = model.value_and_gradient(seeds)
    norm = np.linalg.norm(gradient, axis=1)
    usable = norm > 1e-9
    seeds, normal = seeds[usable], gradient[usable] / norm[usable, None]
    real = model(seeds + SIDE_STEP * hmin * normal) > 0
    return seeds[real], normal[real]


def _across_junction(model: SDF, seeds: np.ndarray, normal: np.ndarray, gap: np.ndarray) -> np.ndarray:
    """Gaps that are the inside of a concave junction: the seed's face and the face its ray
    hits meet at an edge on the part's surface (the line where their tangent planes cross), and
    the ray is at least ``JUNCTION`` times as long as the distance from the seed to that edge
    (the faces open at more than atan(JUNCTION), 27 degrees; past 60 degrees the rays' facing
    test already drops them): a ray from one face of a V-groove hitting the other near the root.
    A slot's faces are parallel (no edge), a drafted slot's
    planes cross far away or inside the material, and the wedge beside a tube tangent to a
    plate curves away from the plane tangent to it (the two faces do not reach the planes' edge):
    those stay gaps."""
    junction = np.zeros(len(gap), dtype=bool)
    finite = np.flatnonzero(np.isfinite(gap))
    if finite.size == 0:
        return junction
    p, n = seeds[finite], normal[finite]
    hits = p + gap[finite, None] * n
    _, m = model.value_and_gradient(hits)
    m = m / np.maximum(np.linalg.norm(m, axis=1), 1e-300)[:, None]
    # the point of the line where the planes (p, n) and (hit, m) cross nearest to the seed: on
    # the seed's plane, along the direction in it that is across the line
    line = np.cross(n, m)
    sine = np.linalg.norm(line, axis=1)
    across = np.cross(line, n)  # in the seed's plane, perpendicular to the line
    with np.errstate(divide="ignore", invalid="ignore"):
        across /= sine[:, None]
        # p + t * across lies on the hit's plane: m . (p + t * across - hit) = 0
        t = np.einsum("ij,ij->i", m, hits - p) / np.einsum("ij,ij->i", m, across)
    edge = p + t[:, None] * across
    distance = np.abs(t)
    candidate = (sine > 1e-3) & np.isfinite(distance) & (gap[finite] >= JUNCTION * distance)
    meet = np.zeros(finite.size, dtype=bool)
    if candidate.any():
        # the two faces themselves (their smooth pieces, not their tangent planes) reach the
        # edge, and the part has a surface there: a tube's bottom tangent to a plate curves away
        # from the plane tangent to it, a drafted slot's planes cross inside the material
        c = np.flatnonzero(candidate)
        at, tolerance = edge[c], EDGE_TOLERANCE * distance[c]
        _, seed_pieces = model.patch_labels(p[c])
        _, hit_pieces = model.patch_labels(hits[c])
        meet[c] = ((np.abs(model.patch_values(seed_pieces, at)) < tolerance)
                   & (np.abs(model.patch_values(hit_pieces, at)) < tolerance)
                   & (np.abs(model(at)) < 0.25 * distance[c]))
    junction[finite] = candidate & meet
    return junction


def _features(model: SDF, hmin: float, bounds):
    """The model's features at ``hmin / 4`` over ``bounds`` (:func:`fepre.sizing.feature_gaps.search`)."""
    from .feature_gaps import search

    lower, upper = (np.asarray(b, dtype=np.float64) for b in bounds)
    return search(model, hmin, (lower, upper))


def _wanted_sizes(model, seeds, normal, hmin, hmax, elements_across, chord_tolerance, found, spacing):
    """Points and the edge length each wants (in ``[hmin, hmax]``): walls, gaps, curvature,
    facing feature curves and wall mid-surfaces; features that would need less than ``hmin``
    are named in a :class:`fepre.ResolutionWarning`."""
    step = hmin / 8.0
    thickness = ray_lengths(model, seeds, -normal, True, elements_across * hmax, step)
    gap = ray_lengths(model, seeds, normal, False, hmax, step)
    gap[_across_junction(model, seeds, normal, gap)] = np.inf
    if hasattr(model, "facet_curvature"):  # a faceted surface: flat on every facet, curved between
        curvature = model.facet_curvature(seeds, hmin)
    else:
        curvature = max_curvature(model, seeds, 0.05 * hmin)
    with np.errstate(divide="ignore"):
        tolerance = np.minimum(hmin / 10.0, CHORD_RATIO / curvature) if chord_tolerance is None else chord_tolerance
        chord = np.sqrt(8.0 * tolerance / curvature)
    wall = np.clip(thickness / elements_across, hmin, hmax)
    # two elements across every gap (a hole's diameter), down to hmin
    opening = np.clip(gap / 2.0, hmin, hmax)
    wanted = np.minimum.reduce([wall, opening, np.clip(chord, hmin, hmax)])
    # a wall's size holds through it, not only on its faces: its mid-surface is a seed too
    thin = np.isfinite(thickness) & (wall < hmax)
    points = [seeds, seeds[thin] - 0.5 * thickness[thin, None] * normal[thin]]
    sizes_at = [wanted, wall[thin]]
    reach = 2.0 * spacing
    # named when they need less than hmin by more than the rays' accuracy (hmin / 512)
    thin_wall = thickness < NAMED_BELOW * elements_across * hmin
    narrow = gap < NAMED_BELOW * hmin
    knife, touching = thickness < NOTHING_BELOW * hmin, gap < NOTHING_BELOW * hmin
    thin_wall, narrow = thin_wall & ~knife, narrow & ~touching
    # a wall is named at its mid-surface, which the seeds of both its faces reach: once, not twice
    middle = seeds[thin_wall] - 0.5 * thickness[thin_wall, None] * normal[thin_wall]
    places = under_hmin("wall", middle, thickness[thin_wall], thickness[thin_wall] / elements_across, reach)
    places += under_hmin("gap", seeds[narrow], gap[narrow], gap[narrow] / 2.0, reach)
    places += under_hmin("knife", seeds[knife], thickness[knife], np.zeros(int(knife.sum())), reach)
    places += under_hmin("touching", seeds[touching], gap[touching], np.zeros(int(touching.sum())), reach)
    if found is not None:
        from .feature_gaps import feature_sizes

        feature_seeds, feature_wanted = feature_sizes(model, hmin, hmax, None, found)
        points.append(feature_seeds)
        sizes_at.append(np.clip(feature_wanted, hmin, hmax))
        close = feature_wanted < NAMED_BELOW * hmin
        places += under_hmin("edges", feature_seeds[close], feature_wanted[close], feature_wanted[close], reach)
    return np.concatenate(points), np.concatenate(sizes_at), warn_under_hmin(places, hmin, _noise_note(model, places))


#: walls and gaps named on an image read without smoothing, up to this many voxels across, may be noise
NOISE_VOXELS = 4.0


def _noise_note(model: SDF, places: list[tuple]) -> str:
    """The note for walls and gaps a few voxels across on an image read without smoothing: a
    noisy scan's level set has nubs and dimples that size (a 90 degree edge of a CT block was
    named "a wall 0.355 thick", 1.4 of its largest voxel side)."""
    from ..sdf.imagemodel import ImageModel

    while not isinstance(model, ImageModel) and model.children and (
            len(model.children) == 1 or isinstance(model.children[0], ImageModel)):
        model = model.children[0]  # through a move and the image's box
    if not isinstance(model, ImageModel) or model.smoothing:
        return ""
    voxel = float(np.max(model.spacing))
    if not any(kind in ("wall", "gap") and measure <= NOISE_VOXELS * voxel for _, _, measure, kind in places):
        return ""
    return (f"; on an image read without smoothing, walls and gaps a few voxels ({voxel:g}) across can be its "
            "noise: smoothing=1 (fepre mesh --smoothing 1) evens them out")


def _graded_field(points, wanted, lower, upper, spacing, counts, hmin, hmax, gradation) -> SizeField:
    """The sizes wanted at ``points`` spread over a grid, growing by at most ``gradation``."""
    nx, ny = int(counts[0]), int(counts[1])
    index = np.clip(np.rint((points - lower) / spacing).astype(np.int64), 0, counts - 1)
    seed_nodes = index[:, 0] + nx * (index[:, 1] + ny * index[:, 2])
    shape = (int(counts[2]), int(counts[1]), int(counts[0]))
    sizes = graded_sizes(shape, np.full(3, spacing), seed_nodes, wanted, gradation - 1.0, hmax)
    return SizeField(lower, np.full(3, spacing), np.clip(sizes, hmin, hmax))
