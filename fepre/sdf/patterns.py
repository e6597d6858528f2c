"""Polar patterns: copies of a shape turned about an axis (bolt circles, spokes, blades)."""

from __future__ import annotations

from typing import Any

import numpy as np

from ..arguments import as_vector, finite_float, positive_int
from .booleans import union
from .core import SDF
from .radial import unit_axis

__all__ = ["polar_pattern"]


def polar_pattern(
    shape: SDF, count: int, axis: Any = "z", center: Any = (0.0, 0.0, 0.0), angle: float = 360.0
) -> SDF:
    """``count`` copies of ``shape`` turned about ``axis`` through ``center``, the first in place.

    With ``angle=360`` (default) the copies are ``360 / count`` degrees apart around the full
    circle; with a smaller ``angle`` the first and last copies are ``angle`` degrees apart. The
    result is the sharp union of the copies (exact outside, like ``|``), and it keeps the copies'
    surfaces as patches, so sharp edges are found on each copy.

    Examples
    --------
    >>> from fepre import sdf
    >>> holes = sdf.polar_pattern(sdf.cylinder(radius=0.1, height=1.0, center=(1, 0, 0)), 6)
    >>> round(float(holes([0.5, 0.8660254037844386, 0.0])), 9)   # the second hole's axis, at 60 deg
    -0.1
    >>> flange = sdf.cylinder(radius=1.5, height=0.2) - holes
    """
    if not isinstance(shape, SDF):
        raise TypeError(f"shape must be an SDF (a fepre.sdf shape); got {type(shape).__name__}")
    if shape.dim != 3:
        raise ValueError(f"shape must be a 3D SDF for polar_pattern; got a {shape.dim}D one")
    count = positive_int(count.item() if isinstance(count, np.generic) else count, "count")
    direction = unit_axis(axis)
    center = as_vector(center, 3, "center")
    angle = finite_float(angle, "angle")
    if not 0.0 < angle <= 360.0:
        raise ValueError(f"angle must be in (0, 360] degrees; got {angle:g}")
    if count == 1:
        return shape
    step = angle / count if angle == 360.0 else angle / (count - 1)
    copies = [shape] + [shape.rotate(step * i, axis=direction, center=center) for i in range(1, count)]
    return union(*copies)
