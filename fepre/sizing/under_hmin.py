"""The features a size field cannot resolve at ``hmin``: found, merged and named in one warning.

:func:`~fepre.sizing.size_field` names the walls, gaps and close sharp edges that would need
elements smaller than ``hmin``. A region mesh builds one field for the part and one for each
region (:func:`fepre.distmesh` with ``regions=``); a wall of a region is often a wall of the
part too. Inside :func:`one_warning` the fields' places are gathered and named once, each
feature once.
"""

from __future__ import annotations

import contextvars
from contextlib import contextmanager
from typing import Iterator

import numpy as np

from ..placement import in_user_frame

__all__ = ["under_hmin", "warn_under_hmin", "one_warning", "named_place", "MAX_NAMED"]

#: features named in the warning about sizes below hmin, at most
MAX_NAMED = 8

_GATHERED: contextvars.ContextVar[list | None] = contextvars.ContextVar("fepre_under_hmin", default=None)


def under_hmin(kind: str, points: np.ndarray, measure: np.ndarray, wanted: np.ndarray, reach: float) -> list[tuple]:
    """Places where ``kind`` needs sizes below hmin: one ``(size, point, measure, kind)`` per
    group of such points within ``reach`` of each other (the smallest size of the group)."""
    if points.shape[0] == 0:
        return []
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import connected_components
    from scipy.spatial import cKDTree

    pairs = cKDTree(points).query_pairs(reach, output_type="ndarray")
    graph = coo_matrix((np.ones(len(pairs)), (pairs[:, 0], pairs[:, 1])), shape=(len(points), len(points)))
    count, label = connected_components(graph, directed=False)
    places = []
    for group in range(count):
        members = np.flatnonzero(label == group)
        worst = members[np.argmin(wanted[members])]
        places.append((float(wanted[worst]), points[worst], float(measure[worst]), kind))
    return places


def warn_under_hmin(places: list[tuple], hmin: float, note: str = "") -> list[tuple]:
    """One ResolutionWarning naming every feature that would need sizes below hmin (inside
    :func:`one_warning`: gathered for it instead), ``note`` at its end. The places are taken to
    the user's frame now, and returned so."""
    placed = [(size, np.asarray(in_user_frame(point), dtype=np.float64), measure, kind) for size, point, measure, kind in places]
    gathered = _GATHERED.get()
    if gathered is not None:
        gathered.append((placed, hmin, note))
        return placed
    _warn(placed, hmin, note)
    return placed


@contextmanager
def one_warning() -> Iterator[list[tuple]]:
    """Size fields built inside name their features in one warning, at the end, each feature
    once: a place of one field within ``2 hmin`` of a place of the same kind that another field
    named before is left out. Yields a list that holds the places named, once it ends.

    Examples
    --------
    >>> import warnings
    >>> from fepre import sdf, size_field
    >>> plate = sdf.box((20.0, 20.0, 0.5))
    >>> with warnings.catch_warnings(record=True) as caught:
    ...     warnings.simplefilter("always")
    ...     with one_warning():
    ...         fields = [size_field(plate, 0.4, 4.0, features=False) for _ in range(2)]
    >>> len(caught)
    1
    """
    token = _GATHERED.set([])
    named: list[tuple] = []
    try:
        yield named
        gathered = _GATHERED.get()
    finally:
        _GATHERED.reset(token)
    if not gathered:
        return
    hmin = min(h for _, h, _ in gathered)
    note = next((note for _, _, note in gathered if note), "")
    kept: list[tuple] = []
    for places, _, _ in gathered:
        new = [place for place in places
               if not any(other[3] == place[3] and np.linalg.norm(other[1] - place[1]) <= 2.0 * hmin for other in kept)]
        kept.extend(new)
    named.extend(kept)
    _warn(kept, hmin, note)


def _warn(places: list[tuple], hmin: float, note: str = "") -> None:
    if not places:
        return
    from ..errors import ResolutionWarning, warn_user

    places = sorted(places, key=lambda place: place[0])
    lines = [named_place(size, point, measure, kind, hmin) for size, point, measure, kind in places[:MAX_NAMED]]
    if len(places) > MAX_NAMED:
        lines.append(f"and {len(places) - MAX_NAMED} more")
    sized = [kind for _, _, _, kind in places if kind not in _NO_SIZE]
    advice = []
    if sized:
        advice.append("pass a smaller hmin to resolve " + ("them" if len(sized) == len(places) else "those with a size"))
    if len(sized) < len(places):
        advice.append("no element size resolves a knife edge or faces that touch at an angle: thicken, trim or "
                      "join them in the model, or accept flat cells there")
    warn_user(
        f"the size field stops at hmin={hmin:g}; {len(places)} feature(s) would need smaller elements: "
        + "; ".join(lines) + " (" + "; ".join(advice) + ")" + note,
        ResolutionWarning,
    )


#: kinds measured as thinner than the rays can tell from nothing: no size is named for them
_NO_SIZE = ("knife", "touching")


def named_place(size: float, point: np.ndarray, measure: float, kind: str, hmin: float) -> str:
    """One place as the warning names it: "a wall 0.3 thick at (x, y, z) would need 0.1"."""
    where = "(" + ", ".join(f"{c:.6g}" for c in point) + ")"
    if kind == "wall":
        return f"a wall {measure:.3g} thick at {where} would need {size:.3g}"
    if kind == "gap":
        return f"a gap {measure:.3g} wide at {where} would need {size:.3g}"
    if kind == "knife":
        return f"a knife edge at {where} (a wall tapering to under {hmin / 256:.2g}, too thin to measure)"
    if kind == "touching":
        return f"faces touching at an angle at {where} (a gap closing to under {hmin / 256:.2g})"
    return f"sharp edges {measure:.3g} apart at {where} would need {size:.3g}"
