"""Seeded random CAD-style parts, by category, each with its mesh size and what is known of it.

Parts are rotated by random angles about random axes, except the odd-numbered parts of
:data:`ALIGNED` categories: their lengths are multiples of 0.5 and their faces lie on grid planes
(round dimensions with a round spacing). Sizes are drawn in units of the mesh size ``h`` (1 unless the category scales the part), so a
category states its difficulty in elements: a hole of radius 0.5-2 h, a gap of 0.2-2 h, a plate
0.3-3 h thick. Every part carries its volume (analytic where the construction gives it, else
``None``: estimate it by Monte Carlo), its number of components and whether it is *resolvable*:
its features are at least ``h`` apart, so the mesh quality targets apply; on the others the
mesh must be valid and either keep the volume or say where it did not
(:class:`fepre.ResolutionWarning`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Callable, Optional

import numpy as np

from ..arguments import shown
from .. import sdf
from ..sdf.core import SDF

__all__ = ["CorpusPart", "CATEGORIES", "ALIGNED", "parts"]


@dataclass(frozen=True)
class CorpusPart:
    """One part of the corpus."""

    name: str
    category: str
    model: SDF
    h: float
    volume: Optional[float]  # None: not known in closed form
    components: Optional[int]  # None: not known by construction
    resolvable: bool  # features at least h apart: the quality targets apply
    polyhedral: bool  # flat faces only: the boundary is exact, so is the volume
    min_wall: float = float("inf")  # the thinnest wall, in units of h, where the construction says

    def __repr__(self) -> str:
        return f"CorpusPart({self.name!r}, h={self.h:g})"


class _Draw:
    """The generators' random draws; ``aligned`` rounds lengths to multiples of 0.5 (at least
    0.5) and skips rotations, so faces lie on the planes of grids of spacing 0.5 and 1."""

    def __init__(self, rng: np.random.Generator, aligned: bool = False):
        self.rng, self.aligned = rng, aligned

    def uniform(self, low, high, size=None):
        value = self.rng.uniform(low, high, size)
        if not self.aligned:
            return value
        rounded = np.round(np.asarray(value) * 2.0) / 2.0
        rounded = np.where(np.asarray(value) > 0, np.maximum(rounded, 0.5), rounded)
        return float(rounded) if np.ndim(rounded) == 0 else rounded

    def __getattr__(self, name):
        return getattr(self.rng, name)


def _rotation(rng: np.random.Generator) -> tuple[float, tuple[float, float, float]]:
    axis = rng.normal(size=3)
    return float(rng.uniform(0, 360)), tuple(float(v) for v in axis / np.linalg.norm(axis))


def _rotated(model: SDF, rng) -> SDF:
    if getattr(rng, "aligned", False):
        return model
    angle, axis = _rotation(rng)
    return model.rotate(angle, axis)


def _touching(rng):
    size = rng.uniform(5, 8, 3)
    top = np.array([rng.uniform(2, size[0] - 2), rng.uniform(2, size[1] - 2), rng.uniform(2, 5)])
    # each side of the block either flush with the base's (coplanar) or at least h in from it
    room = (size[:2] - top[:2]) / 2
    shift = [float(rng.choice([-1, 1]) * room[k]) if rng.random() < 0.3 else float(rng.uniform(1 - room[k], room[k] - 1)) for k in range(2)]
    base = sdf.box(tuple(size))
    block = sdf.box(tuple(top), center=(shift[0], shift[1], (size[2] + top[2]) / 2))  # stands on the base
    return _rotated(base | block, rng), float(np.prod(size) + np.prod(top)), 1, True, True


def _coplanar(rng):
    a, b = rng.uniform(3, 7, 2), rng.uniform(3, 7, 2)
    height = rng.uniform(2, 5)
    flush = rng.random() < 0.5  # the side faces too are coplanar
    if flush:
        b[1] = a[1]
    offset = np.array([a[0] / 2 + b[0] / 2 - rng.uniform(1, 3), 0.0 if flush else rng.uniform(-1, 1)])
    first = sdf.box((a[0], a[1], height))
    second = sdf.box((b[0], b[1], height), center=(offset[0], offset[1], 0.0))  # same top and bottom
    overlap = [min(a[k] / 2, offset[k] + b[k] / 2) - max(-a[k] / 2, offset[k] - b[k] / 2) for k in range(2)]
    area = a[0] * a[1] + b[0] * b[1] - overlap[0] * overlap[1]
    steps = np.abs([a[1] / 2 - (offset[1] + b[1] / 2), a[1] / 2 + (offset[1] - b[1] / 2)])
    resolvable = bool(np.all((steps < 1e-12) | (steps >= 1.0)))
    return _rotated(first | second, rng), float(area * height), 1, resolvable, True


def _shared_edge(rng):
    a, b = rng.uniform(3, 6, 3), rng.uniform(3, 6, 3)
    b[2] = a[2]
    first = sdf.box(tuple(a))
    second = sdf.box(tuple(b), center=((a[0] + b[0]) / 2, (a[1] + b[1]) / 2, 0.0))  # meets along a z edge
    return _rotated(first | second, rng), float(np.prod(a) + np.prod(b)), None, False, True


def _acute(rng):
    angle = math.radians(rng.uniform(10, 30))
    length, height = rng.uniform(6, 10), rng.uniform(3, 5)
    wedge = sdf.polygon([(0, 0), (length, 0), (length * math.cos(angle), length * math.sin(angle))])
    area = 0.5 * length * length * math.sin(angle)
    return _rotated(sdf.extrude(wedge, height), rng), area * height, 1, False, True


def _reentrant(rng):
    w, d = rng.uniform(6, 10, 2)
    t1, t2 = rng.uniform(2, 3.5, 2)
    height = rng.uniform(3, 5)
    ell = sdf.polygon([(0, 0), (w, 0), (w, t1), (t2, t1), (t2, d), (0, d)])
    area = w * t1 + t2 * (d - t1)
    return _rotated(sdf.extrude(ell, height), rng), area * height, 1, True, True


def _small_hole(rng):
    size, thickness = rng.uniform(12, 16), rng.uniform(2.5, 4)
    plate = sdf.box((size, size, thickness))
    count = int(rng.integers(1, 4))
    radii = rng.uniform(0.5, 2.0, count)
    spots = [(-size / 4, -size / 4), (size / 4, -size / 4), (0.0, size / 4)][:count]
    part = plate
    for radius, (x, y) in zip(radii, spots):
        part = part - sdf.cylinder(float(radius), thickness + 2, center=(x, y, 0.0))
    volume = size * size * thickness - thickness * math.pi * float(np.sum(radii**2))
    ligament = min(size / 4 - radii.max(), size / 2 - 2 * radii.max())
    return _rotated(part, rng), volume, 1, bool(radii.min() >= 1.0), False, {"min_wall": float(ligament)}


def _narrow_gap(rng):
    length, width, height = rng.uniform(8, 12), rng.uniform(4, 6), rng.uniform(3, 5)
    gap = rng.uniform(0.2, 2.0)
    depth = rng.uniform(0.4, 0.7) * height
    block = sdf.box((length, width, height))
    slot = sdf.box((gap, width + 2, depth + 1), center=(0.0, 0.0, height / 2 - depth / 2 + 0.5))
    volume = length * width * height - gap * width * depth
    return _rotated(block - slot, rng), volume, 1, bool(gap >= 1.0), True, {"min_wall": float(min(height - depth, (length - gap) / 2))}


def _thin_plate(rng):
    size = rng.uniform(6, 10, 2)
    thickness = rng.uniform(0.3, 3.0)
    return _rotated(sdf.box((size[0], size[1], thickness)), rng), float(size[0] * size[1] * thickness), 1, bool(thickness >= 1.0), True, {"min_wall": float(thickness)}


def _lattice(rng):
    elements = rng.uniform(1, 4)  # wall thickness in elements
    h = 0.1
    period = rng.uniform(1.0, 1.5)
    shell = rng.uniform(2, 3) * h
    part = sdf.infill(sdf.box((2.0, 2.0, 1.0)), sdf.gyroid(period=period, thickness=elements * h), wall=shell)
    return part, None, 1, bool(elements >= 2), False, h


def _random_csg(rng):
    def primitive():
        kind = rng.choice(["box", "cylinder", "sphere", "torus", "extrusion", "revolution"])
        center = tuple(float(v) for v in rng.uniform(-2, 2, 3))
        if kind == "box":
            shape = sdf.box(tuple(float(v) for v in rng.uniform(3, 7, 3)), center=center)
        elif kind == "cylinder":
            shape = sdf.cylinder(float(rng.uniform(1.5, 3.5)), float(rng.uniform(3, 8)), center=center)
        elif kind == "sphere":
            shape = sdf.sphere(float(rng.uniform(2, 4)), center=center)
        elif kind == "torus":
            minor = float(rng.uniform(1.0, 1.8))
            shape = sdf.torus(float(rng.uniform(minor + 1.5, 4.5)), minor, center=center)
        elif kind == "extrusion":
            sides = int(rng.integers(3, 7))
            shape = sdf.extrude(sdf.regular_polygon(sides, float(rng.uniform(2, 4))), float(rng.uniform(3, 6))).translate(center)
        else:
            r1, r2, z = rng.uniform(1.5, 3.5), rng.uniform(1.0, 3.0), rng.uniform(3, 6)
            shape = sdf.revolve(sdf.polygon([(0, 0), (r1, 0), (r1, z / 2), (r2, z / 2), (r2, z), (0, z)])).translate(center)
        return _rotated(shape, rng)

    part = primitive()
    for _ in range(int(rng.integers(1, 3))):
        other = primitive()
        part = part | other if rng.random() < 0.6 else part - other
    return part, None, None, False, False


def _scaled(factor: float, placement: float = 0.0) -> Callable:
    def make(rng):
        model, volume, components, resolvable, polyhedral = _touching(rng)
        model = model.scale(factor)
        if placement:
            direction = rng.normal(size=3)
            model = model.translate(tuple(float(v) for v in placement * direction / np.linalg.norm(direction)))
        return model, volume * factor**3, components, resolvable, polyhedral, factor

    return make


#: category name -> generator(rng) -> (model, volume, components, resolvable, polyhedral[, h][, extra fields])
_GENERATORS: dict[str, Callable] = {
    "touching": _touching,
    "coplanar": _coplanar,
    "shared_edge": _shared_edge,
    "acute": _acute,
    "reentrant": _reentrant,
    "small_hole": _small_hole,
    "narrow_gap": _narrow_gap,
    "thin_plate": _thin_plate,
    "lattice": _lattice,
    "tiny": _scaled(1e-3),
    "huge": _scaled(1e3),
    "far": _scaled(1.0, 1e4),
    "random_csg": _random_csg,
}

#: the categories, in the order of the table
CATEGORIES: tuple[str, ...] = tuple(_GENERATORS)
#: categories whose odd-numbered parts are aligned: lengths multiples of 0.5, not rotated
ALIGNED = ("coplanar", "reentrant", "narrow_gap", "thin_plate")


def parts(seed: int = 0, per_category: int = 4, categories=None) -> list[CorpusPart]:
    """The corpus: ``per_category`` parts of each category, the same for the same ``seed``.

    Examples
    --------
    >>> corpus = parts(seed=0, per_category=1)
    >>> len(corpus) == len(CATEGORIES), corpus[0].category
    (True, 'touching')
    >>> [p.name for p in parts(seed=0, per_category=1)] == [p.name for p in corpus]
    True
    """
    chosen = CATEGORIES if categories is None else tuple(categories)
    unknown = [name for name in chosen if name not in _GENERATORS]
    if unknown:
        raise ValueError(f"categories must be among {', '.join(CATEGORIES)}; got {unknown}")
    if isinstance(per_category, bool) or not isinstance(per_category, (int, np.integer)) or per_category < 1:
        raise ValueError(f"per_category must be a positive integer; got {shown(per_category)}")
    result = []
    for index, category in enumerate(CATEGORIES):
        if category not in chosen:
            continue
        rng = np.random.default_rng([seed, index])
        for number in range(per_category):
            made = list(_GENERATORS[category](_Draw(rng, aligned=category in ALIGNED and number % 2 == 1)))
            extra = made.pop() if isinstance(made[-1], dict) else {}
            model, volume, components, resolvable, polyhedral = made[:5]
            h = made[5] if len(made) > 5 else 1.0
            result.append(CorpusPart(f"{category}-{number}", category, model, float(h), volume, components, resolvable, polyhedral, **extra))
    return result
