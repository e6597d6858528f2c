"""Checks of user arguments that raise errors naming the parameter and what is accepted.

Every public function validates its inputs with these helpers so that bad input fails early
with a message a user can act on, never deep inside numpy.
"""

from __future__ import annotations

import math
import numbers
import re
from typing import Any, Callable

import numpy as np

__all__ = [
    "as_points",
    "as_vector",
    "positive_float",
    "nonnegative_float",
    "finite_float",
    "positive_int",
    "as_bounds",
    "choice",
    "evaluate_size",
    "check_names",
    "shown",
]


def shown(value: Any) -> str:
    """``repr(value)`` with numbers as a user writes them: numpy scalars plain (``-5.0``, not
    ``np.float64(-5.0)``), numpy arrays as lists, tuples and lists of numpy scalars plain. For the
    ``got ...`` of error messages, which may receive numpy values.

    Examples
    --------
    >>> import numpy as np
    >>> shown(np.float64(-5.0)), shown((np.int64(2), 3)), shown("x")
    ('-5.0', '(2, 3)', "'x'")
    """
    if isinstance(value, np.generic):
        return repr(value.item())
    if isinstance(value, np.ndarray):
        return repr(value.tolist())
    if isinstance(value, (tuple, list)) and any(isinstance(v, (np.generic, np.ndarray)) for v in value):
        return repr(type(value)(v.item() if isinstance(v, np.generic) else v.tolist() if isinstance(v, np.ndarray) else v
                                for v in value))
    return repr(value)


def _numeric_array(value: Any, name: str) -> np.ndarray:
    try:
        array = np.asarray(value)
    except (ValueError, TypeError) as exc:  # ragged nested sequences
        raise ValueError(f"{name} must be a rectangular array of numbers; got {shown(value):.80}") from exc
    if array.dtype == object:
        raise ValueError(
            f"{name} must be a rectangular array of numbers (not ragged or mixed); got {shown(value):.80}"
        )
    if array.dtype.kind not in "biuf":
        raise TypeError(f"{name} must contain real numbers; got dtype {array.dtype}")
    return array


def as_points(points: Any, dim: int = 3, name: str = "points") -> tuple[np.ndarray, bool]:
    """Return ``points`` as a float64 (N, dim) array and whether a single point was given.

    A (dim,) array is one point. A (dim, N) array with N != dim is refused because it is almost
    always a transposed point array.
    """
    array = _numeric_array(points, name)
    if array.ndim == 1 and array.shape[0] == dim:
        single = True
        array = array.reshape(1, dim)
    elif array.ndim == 2 and array.shape[1] == dim:
        single = False
    elif array.ndim == 2 and array.shape[0] == dim:
        raise ValueError(
            f"{name} must have shape (N, {dim}); got {array.shape}, which looks transposed: "
            f"pass {name}.T"
        )
    else:
        raise ValueError(f"{name} must have shape (N, {dim}) or ({dim},); got {array.shape}")
    array = np.asarray(array, dtype=np.float64)
    if not np.isfinite(array).all():
        raise ValueError(f"{name} must be finite; got NaN or infinite coordinates")
    return array, single


def as_vector(value: Any, dim: int, name: str, *, allow_scalar: bool = False) -> np.ndarray:
    """Return a finite float64 vector of length ``dim`` (a scalar is broadcast if allowed)."""
    array = _numeric_array(value, name).astype(np.float64)
    if array.ndim == 0 and allow_scalar:
        array = np.full(dim, float(array))
    if array.shape != (dim,):
        accepted = f"a number or a sequence of {dim} numbers" if allow_scalar else f"a sequence of {dim} numbers"
        raise ValueError(f"{name} must be {accepted}; got {shown(value):.80}")
    if not np.isfinite(array).all():
        raise ValueError(f"{name} must be finite; got {np.array2string(array, precision=6)}")
    return array


def finite_float(value: Any, name: str) -> float:
    """Return ``value`` as a finite float."""
    if isinstance(value, bool) or not isinstance(value, (numbers.Real, np.number)):
        raise TypeError(f"{name} must be a real number; got {type(value).__name__} {shown(value):.40}")
    result = float(value)
    if not math.isfinite(result):
        raise ValueError(f"{name} must be finite; got {shown(value)}")
    return result


def positive_float(value: Any, name: str) -> float:
    """Return ``value`` as a finite float > 0."""
    result = finite_float(value, name)
    if result <= 0:
        raise ValueError(f"{name} must be > 0; got {shown(value)}")
    return result


def nonnegative_float(value: Any, name: str) -> float:
    """Return ``value`` as a finite float >= 0."""
    result = finite_float(value, name)
    if result < 0:
        raise ValueError(f"{name} must be >= 0; got {shown(value)}")
    return result


def positive_int(value: Any, name: str) -> int:
    """Return ``value`` as an int >= 1."""
    if isinstance(value, bool) or not isinstance(value, (numbers.Integral, np.integer)):
        raise TypeError(f"{name} must be a positive integer; got {type(value).__name__} {shown(value):.40}")
    if value < 1:
        raise ValueError(f"{name} must be a positive integer; got {shown(value)}")
    return int(value)


def int_triple(value: Any, name: str, minimum: int, why: str = "") -> np.ndarray:
    """``value`` (an int, or three ints for x, y, z) as a (3,) int64 array, each at least ``minimum``.

    Examples
    --------
    >>> int_triple(16, "chunks", 8).tolist()
    [16, 16, 16]
    """
    if isinstance(value, (int, np.integer)) and not isinstance(value, bool):
        value = (value,) * 3
    try:
        entries = list(value)
    except TypeError:
        raise TypeError(f"{name} must be an int or 3 ints (x, y, z); got {shown(value)}") from None
    if len(entries) != 3 or any(isinstance(e, bool) or not isinstance(e, (int, np.integer)) for e in entries):
        raise TypeError(f"{name} must be an int or 3 ints (x, y, z); got {shown(value)}")
    if min(entries) < minimum:
        raise ValueError(f"{name} must be at least {minimum} nodes along each axis{why}; got {shown(value)}")
    return np.array([int(e) for e in entries], dtype=np.int64)


def as_bounds(value: Any, dim: int = 3, name: str = "bounds") -> tuple[tuple[float, ...], tuple[float, ...]]:
    """Return ``((min...), (max...))`` from that form or a flat VTK-style 2*dim sequence.

    Accepted: ``((xmin, ymin, zmin), (xmax, ymax, zmax))`` or
    ``(xmin, xmax, ymin, ymax, zmin, zmax)`` (VTK/PyVista order).
    """
    array = _numeric_array(value, name).astype(np.float64)
    if array.shape == (2, dim):
        lo, hi = array[0], array[1]
    elif array.shape == (2 * dim,):
        lo, hi = array[0::2], array[1::2]
    else:
        raise ValueError(
            f"{name} must be ((min...), (max...)) with {dim} entries each or a flat VTK-style "
            f"sequence of {2 * dim} numbers; got shape {array.shape}"
        )
    if not np.isfinite(array).all():
        raise ValueError(f"{name} must be finite; got {np.array2string(array, precision=6)}")
    if np.any(lo >= hi):
        axis = int(np.argmax(lo >= hi))
        raise ValueError(f"{name} must have min < max on every axis; axis {axis} has {lo[axis]} >= {hi[axis]}")
    return tuple(float(v) for v in lo), tuple(float(v) for v in hi)


def domain_bounds(model: Any, bounds: Any) -> tuple[tuple[float, ...], tuple[float, ...]]:
    """The box to work in: ``bounds`` if given, else the model's own, with messages for an
    unbounded model and for an empty one (operands whose boxes do not overlap)."""
    if bounds is not None:
        return as_bounds(bounds, 3, "bounds")
    if model.bounds is None:
        raise ValueError(
            "bounds is required: the model is unbounded (its bounds are None); pass "
            "bounds=((xmin, ymin, zmin), (xmax, ymax, zmax))"
        )
    lo, hi = (np.asarray(b, dtype=np.float64) for b in model.bounds)
    if not (np.isfinite(lo).all() and np.isfinite(hi).all()):
        raise ValueError("bounds is required: the model's own bounds are not finite")
    if np.any(lo >= hi):
        raise ValueError(
            "the model is empty: its bounds have no volume (an intersection or difference of shapes "
            "that do not overlap); check the model's placement"
        )
    return tuple(float(v) for v in lo), tuple(float(v) for v in hi)


def diagonal_lengths(h: Any, lower: Any, upper: Any, name: str = "h") -> Any:
    """``h`` with every ``"D/N"`` in it (alone or in a pair) made the diagonal of the box
    ``lower``-``upper`` over N; other values are returned as given.

    Examples
    --------
    >>> diagonal_lengths("D/50", (0, 0, 0), (3, 4, 0))
    0.1
    >>> diagonal_lengths(("D/100", "D/10"), (0, 0, 0), (3, 4, 0))
    (0.05, 0.5)
    """
    if isinstance(h, (tuple, list)):
        return type(h)(diagonal_lengths(value, lower, upper, name) for value in h)
    if not isinstance(h, str):
        return h
    text = h.strip()
    count = float("nan")
    if text[:2].upper() == "D/":
        try:
            count = float(text[2:])
        except ValueError:
            pass
    if not (math.isfinite(count) and count > 0):
        raise ValueError(f"{name} must be a length, or 'D/N' for the part's bounding-box diagonal over N > 0 "
                         f"(e.g. 0.5 or 'D/50'); got {h!r}")
    return float(np.linalg.norm(np.subtract(upper, lower, dtype=np.float64))) / count


def choice(value: Any, name: str, accepted: tuple) -> Any:
    """Return ``value`` if it is one of ``accepted``."""
    if value not in accepted:
        raise ValueError(f"{name} must be one of {', '.join(map(repr, accepted))}; got {shown(value)}")
    return value


def evaluate_size(size: Callable, points: np.ndarray) -> np.ndarray:
    """``size(points)`` checked: an (N,) array of finite positive numbers."""
    try:
        values = np.asarray(size(points), dtype=np.float64)
    except (TypeError, ValueError) as exc:
        raise ValueError(f"size must return an (N,) array of positive numbers for (N, 3) points; calling it failed: {exc}") from exc
    if values.shape == (points.shape[0], 1):
        values = values[:, 0]
    if values.shape != (points.shape[0],):
        raise ValueError(f"size must return shape ({points.shape[0]},) for {points.shape[0]} points; got {values.shape}")
    bad = ~(np.isfinite(values) & (values > 0))
    if bad.any():
        raise ValueError(
            f"size must return finite values > 0; got {shown(values[bad][0])} at point {points[bad][0].tolist()}"
        )
    return values


#: Names of element, node and face sets: solver-safe identifiers (Abaqus/CalculiX, Gmsh, XDMF).
SET_NAME = re.compile(r"^[A-Za-z][A-Za-z0-9_]{0,63}$")


def check_names(names: list[str], parameter: str) -> None:
    """Set names must be solver-safe identifiers, unique ignoring case (Abaqus upper-cases)."""
    seen: dict[str, str] = {}
    for name in names:
        if not isinstance(name, str) or not SET_NAME.match(name):
            raise ValueError(
                f"{parameter}: set name {name!r} is not accepted; use a letter followed by up to 63 "
                f"letters, digits or underscores (solvers such as Abaqus/CalculiX need this)"
            )
        key = name.upper()
        if key in seen:
            raise ValueError(
                f"{parameter}: set names {seen[key]!r} and {name!r} differ only in case; solvers "
                f"such as Abaqus/CalculiX ignore case, so use distinct names"
            )
        seen[key] = name
